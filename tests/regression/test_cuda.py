"""The CUDA backend gives the CPU's answer (marked `gpu`: runs only with `--arch cuda` on a GPU machine).

The whole test session already runs every kernel test on CUDA when started with `--arch cuda`; this
file adds what that cannot show: the same scene, run as a user runs it (`main.py run`, f32) on the CPU
and on CUDA, reaches the same first fracture event. Up to the first contact the motion is a free fall
and one impact analysis in host float64, so the two backends agree to f32 rounding there; what follows
the split depends on float-atomic order and is compared only by invariants (mass).
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
FRAMES = 4  # glass_r3's ball strikes at frame 2


def run(arch: str, out: Path) -> dict:
    cmd = [sys.executable, str(ROOT / "main.py"), "run", "glass_r3", "--arch", arch, "--frames", str(FRAMES),
           "--renderer", "none", "--video", "none", "--no-progress", "--out", str(out)]
    subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True, timeout=600)
    return json.loads((out / "stats.json").read_text())


@pytest.mark.gpu
def test_first_fracture_event_is_the_cpus(tmp_path):
    cpu, cuda = run("cpu", tmp_path / "cpu"), run("cuda", tmp_path / "cuda")
    assert cuda["runtime"]["arch"] == "cuda" and cpu["runtime"]["arch"] == "cpu"
    ev_c, ev_g = cpu["events"][0], cuda["events"][0]
    assert ev_g["frame"] == ev_c["frame"] and ev_g["cracks"] == ev_c["cracks"]
    assert ev_g["speed"] == pytest.approx(ev_c["speed"], rel=1e-5)  # f32 free fall
    h_c, h_g = ev_c["analysis"]["hertz"], ev_g["analysis"]["hertz"]
    assert h_g["force"] == pytest.approx(h_c["force"], rel=1e-4)  # F ~ v^(6/5)
    for g_c, g_g in zip(ev_c["analysis"]["groups"], ev_g["analysis"]["groups"]):
        assert g_g["fired"] == g_c["fired"]
        cos = abs(float(np.dot(g_c["principal_dir"], g_g["principal_dir"])))
        assert cos > np.cos(np.radians(1.0))  # crack planes within 1 degree
    for stats in (cpu, cuda):
        assert abs(stats["mass"]["error_kg"]) <= 1e-6 * stats["mass"]["initial_kg"]


@pytest.mark.gpu
def test_f64_on_cuda_is_refused_in_one_line(tmp_path):
    """On a real device the refusal comes before Taichi starts (not the abort it would otherwise be)."""
    cmd = [sys.executable, str(ROOT / "main.py"), "run", "pot", "--arch", "cuda", "--precision", "f64",
           "--frames", "2", "--out", str(tmp_path / "o")]
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "--precision f64 with --arch cuda" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.gpu
def test_pot_breaks_on_cuda_with_its_mass(tmp_path):
    """The default scene as a user runs it on the GPU: it breaks into pieces and loses no mass."""
    cmd = [sys.executable, str(ROOT / "main.py"), "run", "pot", "--arch", "cuda", "--frames", "61",
           "--renderer", "none", "--video", "none", "--no-progress", "--out", str(tmp_path / "o")]
    subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True, timeout=600)
    stats = json.loads((tmp_path / "o" / "stats.json").read_text())
    assert stats["runtime"]["arch"] == "cuda" and stats["table1"]["pieces"]["total"] >= 2
    assert abs(stats["mass"]["error_kg"]) <= 1e-6 * stats["mass"]["initial_kg"]
