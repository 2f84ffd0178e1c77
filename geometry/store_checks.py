"""The particle store's validity check (geometry/particle_store.py, `ParticleStore.first_invalid`; run
by sim/guards.py whenever fracture changed the particles): per check, the first alive particle whose
rest data is not finite or not physical. One kernel over the store's ndarrays (compiled once for any
capacity), over every row or over given rows (those written since the store was last found valid),
and the same checks in numpy for a host copy of the store (`host_first_invalid`: a run's first frame
checks the build's particles without compiling the kernel, 0.1 s of its start).
No `from __future__ import annotations` here: Taichi reads the kernel's annotations as objects.
"""

import numpy as np
import taichi as ti

Arr = ti.types.ndarray()  # any ndarray argument (also the particle store's kernels)


@ti.func
def _finite(x) -> ti.i32:
    return ti.abs(x) < 1e300  # False for inf and NaN


@ti.kernel
def k_first_invalid(n: ti.i32, rows: Arr, n_rows: ti.i32, check_kernel: ti.i32, particle_alive: Arr,
                    particle_centroid: Arr, particle_rest_verts: Arr, particle_volume: Arr, particle_mass: Arr,
                    particle_kernel: Arr, first: Arr):
    """Per check (centroid, rest verts, volume, mass, kernel tensor), the first alive particle that
    fails it, or n: non-finite values, volume or mass <= 0, a kernel tensor whose symmetric part is
    not positive definite (Sylvester: its leading minors > 0). Over rows[:n_rows] where n_rows >= 0,
    else over the rows 0..n-1."""
    for c in range(5):
        first[c] = n
    m = n
    if n_rows >= 0:
        m = n_rows
    for r in range(m):
        i = r
        if n_rows >= 0:
            i = rows[r]
        if particle_alive[i] != 0:
            bad = ti.Vector([0, 0, 0, 0, 0])
            for a in ti.static(range(3)):
                if not _finite(particle_centroid[i, a]):
                    bad[0] = 1
            for a, b in ti.ndrange(4, 3):
                if not _finite(particle_rest_verts[i, a, b]):
                    bad[1] = 1
            if not (_finite(particle_volume[i]) and particle_volume[i] > 0.0):
                bad[2] = 1
            if not (_finite(particle_mass[i]) and particle_mass[i] > 0.0):
                bad[3] = 1
            if check_kernel != 0:
                g = ti.Matrix.zero(ti.f64, 3, 3)
                for a, b in ti.static(ti.ndrange(3, 3)):
                    g[a, b] = 0.5 * (particle_kernel[i, a, b] + particle_kernel[i, b, a])
                m2 = g[0, 0] * g[1, 1] - g[0, 1] * g[1, 0]
                m3 = g.determinant()
                if not (_finite(m3) and g[0, 0] > 0.0 and m2 > 0.0 and m3 > 0.0):
                    bad[4] = 1
            for c in ti.static(range(5)):
                if bad[c] != 0:
                    ti.atomic_min(first[c], i)


def host_first_invalid(ps, kernel_G, n: int | None = None) -> np.ndarray:
    """(5,) int: `k_first_invalid`'s answer for a host ParticleSet (or anything with its alive, centroid,
    rest_verts, volume and mass columns, of `n` rows) and its kernel tensors (N, 3, 3) (None: not
    checked), in float64: per check, the first alive particle that fails it, or N."""
    n = len(ps) if n is None else n
    alive = np.asarray(ps.alive, bool)

    def positive(v):
        v = np.asarray(v, np.float64)
        return (np.abs(v) < 1e300) & (v > 0.0)

    bad = [~(np.abs(np.asarray(ps.centroid, np.float64)) < 1e300).all(axis=1),
           ~(np.abs(np.asarray(ps.rest_verts, np.float64)) < 1e300).reshape(n, 12).all(axis=1),
           ~positive(ps.volume), ~positive(ps.mass), np.zeros(n, bool)]
    if kernel_G is not None:
        k = np.asarray(kernel_G, np.float64)
        g = 0.5 * (k + np.swapaxes(k, 1, 2))
        m2 = g[:, 0, 0] * g[:, 1, 1] - g[:, 0, 1] * g[:, 1, 0]
        with np.errstate(invalid="ignore", over="ignore"):  # the kernel's cofactor expansion (LAPACK: 4x the time)
            m3 = (g[:, 0, 0] * (g[:, 1, 1] * g[:, 2, 2] - g[:, 1, 2] * g[:, 2, 1])
                  - g[:, 0, 1] * (g[:, 1, 0] * g[:, 2, 2] - g[:, 1, 2] * g[:, 2, 0])
                  + g[:, 0, 2] * (g[:, 1, 0] * g[:, 2, 1] - g[:, 1, 1] * g[:, 2, 0]))
        bad[4] = ~((np.abs(m3) < 1e300) & (g[:, 0, 0] > 0.0) & (m2 > 0.0) & (m3 > 0.0))
    return np.array([int(np.argmax(b & alive)) if (b & alive).any() else n for b in bad], np.int64)


__all__ = ["host_first_invalid", "k_first_invalid"]
