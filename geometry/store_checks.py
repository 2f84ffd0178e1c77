"""The particle store's validity check (geometry/particle_store.py, `ParticleStore.first_invalid`; run
by sim/guards.py whenever fracture changed the particles): per check, the first alive particle whose
rest data is not finite or not physical. One kernel over the store's ndarrays (compiled once for any
capacity).
No `from __future__ import annotations` here: Taichi reads the kernel's annotations as objects.
"""

import taichi as ti

Arr = ti.types.ndarray()


@ti.func
def _finite(x) -> ti.i32:
    return ti.abs(x) < 1e300  # False for inf and NaN


@ti.kernel
def k_first_invalid(n: ti.i32, check_kernel: ti.i32, particle_alive: Arr, particle_centroid: Arr,
                    particle_rest_verts: Arr, particle_volume: Arr, particle_mass: Arr, particle_kernel: Arr,
                    first: Arr):
    """Per check (centroid, rest verts, volume, mass, kernel tensor), the first alive particle that
    fails it, or n: non-finite values, volume or mass <= 0, a kernel tensor whose symmetric part is
    not positive definite (Sylvester: its leading minors > 0)."""
    for c in range(5):
        first[c] = n
    for i in range(n):
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


__all__ = ["k_first_invalid"]
