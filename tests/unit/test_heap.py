"""core/heap.py: a run's long-lived objects leave the collector's generations (in a child process:
freezing the test process would keep its own objects from later collections)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

CHILD = """
import gc, sys
sys.path.insert(0, {root!r})
from core.heap import freeze_long_lived
before = [[]]  # a tracked container, alive across the freeze
tracked = any(o is before for o in gc.get_objects())
held = freeze_long_lived()
after = [[]]
walked = {{id(o) for o in gc.get_objects()}}
gc.collect()
print(tracked, held > 0, id(before) in walked, id(after) in walked, before == [[]])
"""


def test_objects_alive_at_the_freeze_are_walked_by_no_collection():
    out = subprocess.run([sys.executable, "-c", CHILD.format(root=str(ROOT))], capture_output=True, text=True,
                         check=True).stdout.split()
    tracked, held, before_walked, after_walked, intact = out
    assert tracked == "True" and held == "True"  # the collector walked it before; the freeze holds objects
    assert before_walked == "False" and after_walked == "True"  # only what came after is walked
    assert intact == "True"  # a full collection leaves the frozen objects as they were
