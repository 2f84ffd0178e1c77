"""core.runtime: a backend the project cannot run is refused with a clear error before Taichi starts."""

import pytest

import core.runtime as rt
from core.errors import BackendError


def test_f64_on_cuda_is_refused_before_taichi_starts(monkeypatch):
    """Taichi 1.7.4 aborts the process on this project's f64 kernels on CUDA (docs/decisions.md,
    "CUDA and f64"): the run must stop with a message naming both options, whatever device is there."""
    monkeypatch.setattr(rt, "cuda_available", lambda: True)
    with pytest.raises(BackendError, match=r"--precision f64 with --arch cuda.*f32 on CUDA.*f64 on the CPU"):
        rt.init_taichi(arch="cuda", precision="f64")


def test_f64_on_the_cpu_and_f32_on_cuda_are_not_refused(monkeypatch):
    monkeypatch.setattr(rt, "cuda_available", lambda: True)
    info = rt.runtime()  # the test session's runtime (f64 on the CPU): the same settings are a no-op
    assert info.arch == "cpu" and info.precision == "f64"
    assert rt.init_taichi(arch=info.arch, precision="f64", threads=info.threads) is info
    assert rt.init_taichi(arch="auto", precision="f64", threads=info.threads) is info  # auto keeps f64 on the CPU
    with pytest.raises(BackendError, match="already runs with"):  # refused only for being a second backend
        rt.init_taichi(arch="cuda", precision="f32")


@pytest.mark.parametrize("device", [True, False])
def test_auto_picks_cuda_only_for_f32_on_a_device(monkeypatch, device):
    monkeypatch.setattr(rt, "cuda_available", lambda: device)
    assert rt.resolve_arch("auto", "f32") == ("cuda" if device else "cpu")
    assert rt.resolve_arch("auto", "f64") == "cpu"
    assert rt.resolve_arch("cpu", "f32") == "cpu" and rt.resolve_arch("cuda", "f64") == "cuda"  # explicit: kept
