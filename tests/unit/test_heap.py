"""core/heap.py: a run's long-lived objects leave the collector's generations until the process exits
(in child processes: freezing the test process would keep its own objects from later collections)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

CHILD = """
import gc, sys
sys.path.insert(0, {root!r})
from core.heap import freeze_long_lived

class Ring:
    def __del__(self):
        print("finalised at exit", flush=True)

ring = Ring()
ring.me = ring  # a reference cycle: only a collection frees it
before = [[]]  # a tracked container, alive across the freeze
tracked = any(o is before for o in gc.get_objects())
held = freeze_long_lived()
after = [[]]
walked = {{id(o) for o in gc.get_objects()}}
del ring
gc.collect()
print(tracked, held > 0, id(before) in walked, id(after) in walked, before == [[]], flush=True)
"""


def _child(code: str, **env) -> list[str]:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                          env={**os.environ, **env}).stdout.splitlines()


def test_objects_alive_at_the_freeze_are_walked_by_no_collection_until_exit():
    first, *rest = _child(CHILD.format(root=str(ROOT)))
    tracked, held, before_walked, after_walked, intact = first.split()
    assert tracked == "True" and held == "True"  # the collector walked it before; the freeze holds objects
    assert before_walked == "False" and after_walked == "True"  # only what came after is walked
    assert intact == "True"  # a full collection leaves the frozen objects as they were
    assert rest == ["finalised at exit"]  # the frozen cycle survived the collection, and exit finalised it


KERNEL = """
import taichi as ti

@ti.kernel
def twice(x: ti.i32) -> ti.i32:
    return 2 * x
"""

CACHE_CHILD = """
import sys
sys.path[:0] = [{root!r}, {here!r}]
from core.heap import freeze_long_lived
from core.runtime import init_taichi
init_taichi("cpu", "f32", threads=1)
freeze_long_lived()  # as main.py does, with Taichi's program alive
import tiny_kernel
print(tiny_kernel.twice(21))
"""


def test_taichi_writes_its_offline_cache_at_exit_after_a_freeze(tmp_path):
    """Taichi writes the kernels it compiled to its offline cache when its program is finalised at the
    interpreter's exit; frozen, it never was, and every run compiled everything again."""
    (tmp_path / "tiny_kernel.py").write_text(KERNEL)
    cache = tmp_path / "ticache"
    out = _child(CACHE_CHILD.format(root=str(ROOT), here=str(tmp_path)), TI_OFFLINE_CACHE_FILE_PATH=str(cache))
    assert out[-1] == "42"
    assert any(p.suffix == ".tic" for p in cache.iterdir())


def test_main_called_from_python_leaves_the_callers_collector_alone(tmp_path, taichi_runtime):
    """`main.main()` called from Python (a test, a notebook) does not freeze its caller's objects; only
    main.py run as the program does (`owns_process`)."""
    import gc

    import main
    from core.runtime import runtime

    frozen = gc.get_freeze_count()
    code = main.main(["run", "tet_cut_22", "--frames", "1", "--renderer", "none", "--video", "none", "--no-progress",
                      "--precision", runtime().precision, "--out", str(tmp_path / "run")])
    assert code == 0 and (tmp_path / "run" / "stats.json").exists()
    assert gc.get_freeze_count() == frozen
