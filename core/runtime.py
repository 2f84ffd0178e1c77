"""Taichi start-up: backend and floating-point precision, chosen once per process.

Precision is the single switch of DESIGN.md section 3: `init_taichi(precision="f64")` sets
Taichi's `default_fp`, so every field and kernel declared with `float` / `ti.math.vec3` follows
it. Nothing in the project names f32 or f64 elsewhere; numpy code asks `numpy_float()`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import BackendError, ConfigError

PRECISIONS = ("f32", "f64")
ARCHES = ("cpu", "cuda", "auto")
# bytes: Taichi's offline kernel cache. Its default, 100 MB with LRU eviction of a quarter when full,
# is reached by the test suite and a few scenes in both precisions (90 MB here), after which runs
# recompile evicted kernels: a 4 s start became 10-12 s.
OFFLINE_CACHE_MAX_BYTES = 1 << 30


@dataclass(frozen=True)
class RuntimeInfo:
    arch: str  # "cpu" or "cuda": the backend actually running
    precision: str  # "f32" or "f64"
    threads: int  # CPU threads (0 = Taichi's default)
    device: str  # human-readable device name, for reports


_runtime: RuntimeInfo | None = None

# Taichi 1.7.4's CUDA backend aborts the process on f64 kernels that use the anisotropic kernel's
# local matrices (CUDA_ERROR_MISALIGNED_ADDRESS, then std::terminate; measured on an H200, docs/decisions.md
# "CUDA and f64"); f32 runs there give the CPU's results.
CUDA_F64_REFUSED = ("--precision f64 with --arch cuda: Taichi 1.7.4 aborts on this project's f64 kernels on CUDA "
                    "(misaligned address); use --precision f32 on CUDA, or f64 on the CPU")


def cuda_available() -> bool:
    """True when a CUDA driver and device can be opened (checked without initialising Taichi)."""
    import ctypes

    try:
        lib = ctypes.CDLL("libcuda.so.1")
    except OSError:
        return False
    count = ctypes.c_int(0)
    if lib.cuInit(0) != 0 or lib.cuDeviceGetCount(ctypes.byref(count)) != 0:
        return False
    return count.value > 0


def cuda_device_name() -> str:
    import ctypes

    try:
        lib = ctypes.CDLL("libcuda.so.1")
        buf = ctypes.create_string_buffer(256)
        lib.cuInit(0)
        dev = ctypes.c_int(0)
        lib.cuDeviceGet(ctypes.byref(dev), 0)
        lib.cuDeviceGetName(buf, 256, dev)
        return buf.value.decode()
    except OSError:
        return "CUDA device"


def resolve_arch(arch: str, precision: str = "f32") -> str:
    """The backend an `arch` of "cpu", "cuda" or "auto" runs on: auto is CUDA where a device is present
    and the precision is f32 (f64 stays on the CPU: CUDA_F64_REFUSED), else the CPU."""
    if arch == "auto":
        return "cuda" if precision == "f32" and cuda_available() else "cpu"
    return arch


def _cpu_name() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "CPU"


def init_taichi(
    arch: str = "cpu", precision: str = "f32", threads: int = 1, debug: bool = False
) -> RuntimeInfo:
    """Start Taichi once. A second call with the same settings is a no-op; other settings raise.

    arch: "cpu", "cuda" or "auto" (CUDA when a device is present and precision is f32, else CPU;
    f64 on CUDA is refused: CUDA_F64_REFUSED). Vulkan is never
    picked for compute: on a machine without a GPU it is a slow software device (TAICHI_NOTES).
    threads: CPU threads; 1 makes float atomics, hence whole runs, bitwise reproducible.
    """
    global _runtime
    if precision not in PRECISIONS:
        raise ConfigError("--precision", precision, " or ".join(PRECISIONS))
    if arch not in ARCHES:
        raise ConfigError("--arch", arch, ", ".join(ARCHES))
    arch = resolve_arch(arch, precision)
    if arch == "cuda" and not cuda_available():
        raise BackendError("--arch cuda was requested but no CUDA device is available on this machine")
    if arch == "cuda" and precision == "f64":
        raise BackendError(CUDA_F64_REFUSED)
    wanted = (arch, precision, threads)
    if _runtime is not None:
        if (_runtime.arch, _runtime.precision, _runtime.threads) != wanted:
            raise BackendError(
                f"Taichi already runs with arch={_runtime.arch} precision={_runtime.precision} "
                f"threads={_runtime.threads}; start a new process for {wanted}"
            )
        return _runtime

    from core.taichi_frontend import install_before_import

    install_before_import()  # Taichi's own kernels, defined while it is imported, gain too

    import taichi as ti

    from core.taichi_frontend import install as fast_frontend
    from core.taichi_frontend import install_serial_loops as serial_loops
    from core.taichi_launch import install as short_launch

    fast_frontend()  # Taichi's AST transformer: memoised excerpts, matrix operations built directly (same IR)
    short_launch()  # a kernel's later calls skip Taichi's per-argument lookup (core/taichi_launch.py)
    kwargs: dict = dict(
        default_fp=ti.f64 if precision == "f64" else ti.f32,
        default_ip=ti.i32,
        random_seed=0,
        debug=debug,
        log_level=ti.WARN,
        offline_cache_max_size_of_files=OFFLINE_CACHE_MAX_BYTES,
    )
    if arch == "cuda":
        ti.init(arch=ti.cuda, enable_fallback=False, **kwargs)
        device = cuda_device_name()
    else:
        if threads > 0:
            kwargs["cpu_max_num_threads"] = threads
        if threads == 1:
            serial_loops()  # no thread-pool round trip per loop (core/taichi_frontend.py)
        ti.init(arch=ti.cpu, enable_fallback=False, **kwargs)
        device = _cpu_name()
    _runtime = RuntimeInfo(arch=arch, precision=precision, threads=threads, device=device)
    return _runtime


def taichi_started() -> bool:
    """True once `init_taichi` has run in this process."""
    return _runtime is not None


def started_on_cpu() -> bool:
    """True once Taichi runs on the CPU backend: where the host-side kernels of events run (the analysis'
    sums, the fragments' labels); before it starts, and on CUDA, their numpy or scipy twins answer."""
    return _runtime is not None and _runtime.arch == "cpu"


def ensure_runtime() -> RuntimeInfo:
    """The running configuration, starting Taichi with the defaults (cpu, f32, 1 thread) if needed."""
    return _runtime if _runtime is not None else init_taichi()


def runtime() -> RuntimeInfo:
    """The running configuration; raises if `init_taichi` has not been called."""
    if _runtime is None:
        raise RuntimeError("init_taichi() must be called before building any Taichi data")
    return _runtime


def numpy_float() -> type:
    """The numpy dtype matching the Taichi precision (float64 before Taichi starts)."""
    if _runtime is None or _runtime.precision == "f64":
        return np.float64
    return np.float32


def float_eps() -> float:
    """Machine epsilon of the running precision, for tolerances that follow the precision."""
    return float(np.finfo(numpy_float()).eps)
