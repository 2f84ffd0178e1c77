"""Renderer selection: names, the auto rule, messages, errors, and the cached Vulkan probe."""

from __future__ import annotations

import pytest

import render.ggui as ggui
from core.errors import BackendError, ConfigError
from render.select import RENDERER_KINDS, make_renderer


@pytest.fixture
def vulkan(monkeypatch):
    """Set the cached probe answer for one test (the real probe result is restored afterwards)."""

    def set_status(ok: bool, why: str = "test"):
        monkeypatch.setattr(ggui, "_vulkan_status", (ok, why))

    return set_status


def test_kinds_and_names(taichi_runtime):
    assert RENDERER_KINDS == ("ggui", "raster", "auto", "none")
    r = make_renderer("raster", 32, 24)
    try:
        assert r.name == "raster" and "raster" in r.message
    finally:
        r.release()
    n = make_renderer("none", 32, 24)
    assert n.name == "none" and n.render(None, None) is None


@pytest.mark.parametrize("has_vulkan", [False, True])
def test_auto_is_the_rasteriser(taichi_runtime, vulkan, has_vulkan):
    """Headless frames come from the rasteriser whether Vulkan works or not (docs/decisions.md)."""
    vulkan(has_vulkan, "probe answer (test)")
    r = make_renderer("auto", 32, 24)
    try:
        assert r.name == "raster" and r.message.startswith("renderer: auto -> raster")
    finally:
        r.release()


def test_ggui_without_vulkan_is_a_one_line_error_and_exit_2(taichi_runtime, vulkan, tmp_path, capsys):
    """Asking for GGUI where Vulkan is missing names the way out (the rasteriser); the command line
    prints one line and exits with status 2, writing nothing."""
    import main
    from core.runtime import runtime

    vulkan(False, "no driver (test)")
    with pytest.raises(BackendError, match="raster"):
        make_renderer("ggui", 32, 24)
    out = tmp_path / "run"
    code = main.main(["run", "tet_cut_22", "--renderer", "ggui", "--frames", "1", "--out", str(out), "--no-progress",
                      "--precision", runtime().precision])
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("error:")]
    assert code == 2 and len(err) == 1 and "--renderer raster" in err[0]
    assert not (out / "stats.json").exists()


def test_bad_choices(taichi_runtime):
    with pytest.raises(ConfigError, match="--renderer"):
        make_renderer("opengl", 32, 24)
    with pytest.raises(ConfigError, match="size"):
        make_renderer("raster", 32, 0)
    with pytest.raises(ConfigError, match="size"):
        make_renderer("none", 10000, 10)


def test_probe_runs_once_and_env_override(monkeypatch):
    """The probe result is cached (no second subprocess); ANISOFRAC_VULKAN=0/1 answers without probing."""
    calls = []

    class Done:
        returncode, stdout, stderr = 0, "ANISOFRAC_VULKAN_OK\n", ""

    def fake_run(*a, **k):
        calls.append(a)
        return Done()

    monkeypatch.setattr(ggui, "_vulkan_status", None)
    monkeypatch.delenv("ANISOFRAC_VULKAN", raising=False)
    monkeypatch.setattr(ggui.subprocess, "run", fake_run)
    assert ggui.vulkan_available() and ggui.vulkan_available()
    assert len(calls) == 1
    monkeypatch.setattr(ggui, "_vulkan_status", None)
    monkeypatch.setenv("ANISOFRAC_VULKAN", "0")
    ok, why = ggui.vulkan_status()
    assert not ok and "ANISOFRAC_VULKAN=0" in why and len(calls) == 1
    # a failing probe gives the reason, and does not raise
    monkeypatch.setattr(ggui, "_vulkan_status", None)
    monkeypatch.delenv("ANISOFRAC_VULKAN")

    class Crash:
        returncode, stdout, stderr = -11, "", "Segmentation fault\n"

    monkeypatch.setattr(ggui.subprocess, "run", lambda *a, **k: Crash())
    ok, why = ggui.vulkan_status()
    assert not ok and "exit status -11" in why and "Segmentation fault" in why
