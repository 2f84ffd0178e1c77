"""Compile a Taichi kernel ahead of its first launch (issue 16: no compile stall after the build).

Taichi runs a kernel's Python frontend at its first launch, and with the offline cache that is most
of the cost (tens of ms per kernel, more for large ones). `precompile(kernel, *args)` runs that
step for the arguments the kernel will be launched with (same types, ranks and template objects)
and launches nothing, so no state changes; the later launch only loads the cached machine code.
"""

from __future__ import annotations


def precompile(kernel, *args) -> None:
    """Materialise `kernel` (a @ti.kernel function or a bound kernel of a @ti.data_oriented object)
    for `args` as they will be passed (numpy arrays of the right dtype and rank, the same template
    objects)."""
    owner = getattr(kernel, "_kernel_owner", None)
    kernel._primal.ensure_compiled(*(args if owner is None else (owner, *args)))


__all__ = ["precompile"]
