"""Test session set-up: Taichi starts once, on the arch named by --arch or ANISOFRAC_ARCH.

Tests run in f64 (they check accuracy) on one CPU thread (float atomics are then deterministic).
Re-initialising Taichi per test would recompile every kernel, so it happens exactly once here.
With `--arch cuda` the session runs the tests marked `gpu` (each compares CUDA runs in f32 with the
CPU's) and skips the f64 ones: Taichi 1.7.4 cannot run this project's f64 kernels on CUDA
(core.runtime.CUDA_F64_REFUSED, docs/decisions.md "CUDA and f64").
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--arch",
        default=os.environ.get("ANISOFRAC_ARCH", "cpu"),
        choices=["cpu", "cuda", "auto"],
        help="Taichi backend for the whole session (default: cpu, or $ANISOFRAC_ARCH)",
    )


def pytest_configure(config: pytest.Config) -> None:
    import tempfile

    from core.runtime import init_taichi, resolve_arch
    from geometry.build_cache import CACHE_ENV

    # the tet cache of this session (its subprocesses inherit it): no test reads a user's cache
    os.environ[CACHE_ENV] = tempfile.mkdtemp(prefix="anisofrac-test-cache-")

    on_cuda = resolve_arch(config.getoption("--arch")) == "cuda"
    info = init_taichi(arch="cuda" if on_cuda else "cpu", precision="f32" if on_cuda else "f64", threads=1)
    config._anisofrac_runtime = info  # type: ignore[attr-defined]


def pytest_report_header(config: pytest.Config) -> str:
    info = config._anisofrac_runtime  # type: ignore[attr-defined]
    return f"anisofrac: taichi arch={info.arch} precision={info.precision} device={info.device}"


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    info = config._anisofrac_runtime  # type: ignore[attr-defined]
    if info.arch != "cuda":
        skip = pytest.mark.skip(reason="needs a CUDA device: run with --arch cuda on a GPU machine")
        wanted = [item for item in items if "gpu" in item.keywords]
    else:
        skip = pytest.mark.skip(reason="an f64 test: Taichi 1.7.4 cannot run f64 on CUDA (docs/decisions.md)")
        wanted = [item for item in items if "gpu" not in item.keywords]
    for item in wanted:
        item.add_marker(skip)


@pytest.fixture(scope="session")
def taichi_runtime(pytestconfig: pytest.Config):
    return pytestconfig._anisofrac_runtime  # type: ignore[attr-defined]
