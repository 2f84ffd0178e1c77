"""Taichi field store of the tet particles of DESIGN.md section 3 (physical and subdivided).

Bodies and boundary particles (Sect. 5.3) live in the rigid-body world (`rigid/`), which owns
their fields; this module holds the particle store the SPH and fracture stages share.

Each store owns one `ti.FieldsBuilder` tree allocated once with spare capacity, a live count,
and `release()` to free the tree (a process can hold only about 512 trees). Fixed data (rest
shape, material, kernel) is kept apart from changing data (links, alive flags, poses). Stores
are filled from the host-side structs (geometry.particles.ParticleSet,
geometry.boundary.BoundaryParticles) between frames, never inside a substep.
"""

from __future__ import annotations

import numpy as np
import taichi as ti

from sim.errors import CapacityError
from sim.runtime import numpy_float


def _check_capacity(store: str, need: int, capacity: int, option: str) -> None:
    if need > capacity:
        raise CapacityError(
            f"{store}: {need} entries needed but capacity is {capacity}; raise the scene option '{option}'"
        )


class _Store:
    """Common life cycle: build fields in one tree, count, release."""

    capacity_option = ""

    def __init__(self, capacity: int) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.capacity = int(capacity)
        self._fb = ti.FieldsBuilder()
        self._declare(self._fb, self.capacity)
        self._tree = self._fb.finalize()
        self.count = 0  # live entries (host copy; kernels take it as an argument)

    def _declare(self, fb: ti.FieldsBuilder, n: int) -> None:
        raise NotImplementedError

    def release(self) -> None:
        """Free the Taichi memory of this store; the object must not be used afterwards."""
        if self._tree is not None:
            self._tree.destroy()
            self._tree = None


class TetParticleStore(_Store):
    """Physical and subdivided tet particles of every body (Sect. 5.1-5.2)."""

    capacity_option = "scene.particle_capacity"

    def _declare(self, fb: ti.FieldsBuilder, n: int) -> None:
        vec3, mat3 = ti.math.vec3, ti.math.mat3
        # fixed data: set when a particle is made, never changed afterwards
        self.tet_rest_verts = vec3.field()  # (n, 4) m: tet vertices in the reference frame
        self.tet_rest_centroid = vec3.field()  # (n,) m: rest centroid, reference frame
        self.tet_volume = ti.field(float)  # (n,) m^3
        self.tet_mass = ti.field(float)  # (n,) kg
        self.tet_radius = ti.field(float)  # (n,) m: (3V / 4 pi)^(1/3)
        self.tet_material = ti.field(ti.i32)  # (n,) material id
        self.tet_kind = ti.field(ti.i32)  # (n,) 0 physical, 1 subdivided
        self.tet_parent = ti.field(ti.i32)  # (n,) parent particle of a child, -1 otherwise
        self.tet_kernel_G0 = mat3.field()  # (n,) 1/m: rest kernel tensor G (Eq. 5)
        # changing data
        self.tet_body = ti.field(ti.i32)  # (n,) owning body (changes when a body splits)
        self.tet_links = ti.field(ti.i32)  # (n, 4) particle across face k, -1 for none
        self.tet_alive = ti.field(ti.i32)  # (n,) 0 once replaced by its children
        fb.dense(ti.i, n).place(
            self.tet_rest_centroid,
            self.tet_volume,
            self.tet_mass,
            self.tet_radius,
            self.tet_material,
            self.tet_kind,
            self.tet_parent,
            self.tet_kernel_G0,
            self.tet_body,
            self.tet_alive,
        )
        fb.dense(ti.ij, (n, 4)).place(self.tet_rest_verts, self.tet_links)

    def load(self, ps, kernel_G0: np.ndarray | None = None) -> None:
        """Replace the store's content by a host ParticleSet (between frames)."""
        n = len(ps)
        _check_capacity("tet particle store", n, self.capacity, self.capacity_option)
        f = numpy_float()
        cap = self.capacity

        def pad(a: np.ndarray, fill=0) -> np.ndarray:
            out = np.full((cap,) + a.shape[1:], fill, dtype=a.dtype)
            out[:n] = a
            return out

        self.tet_rest_verts.from_numpy(pad(ps.rest_verts.astype(f)))
        self.tet_rest_centroid.from_numpy(pad(ps.centroid.astype(f)))
        self.tet_volume.from_numpy(pad(ps.volume.astype(f)))
        self.tet_mass.from_numpy(pad(ps.mass.astype(f)))
        self.tet_radius.from_numpy(pad(ps.radius.astype(f)))
        self.tet_material.from_numpy(pad(ps.material.astype(np.int32)))
        self.tet_kind.from_numpy(pad(ps.kind.astype(np.int32)))
        self.tet_parent.from_numpy(pad(ps.parent.astype(np.int32), -1))
        self.tet_body.from_numpy(pad(ps.body.astype(np.int32), -1))
        self.tet_links.from_numpy(pad(ps.links.astype(np.int32), -1))
        self.tet_alive.from_numpy(pad(ps.alive.astype(np.int32)))
        if kernel_G0 is None:
            # isotropic default: support radius twice the particle spacing estimate (2 x 2r)
            h = 4.0 * ps.radius
            kernel_G0 = np.eye(3)[None] / h[:, None, None]
        self.tet_kernel_G0.from_numpy(pad(np.asarray(kernel_G0).astype(f)))
        self.count = n
