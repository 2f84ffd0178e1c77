"""Taichi storage of the rigid world: one `ti.FieldsBuilder` tree per capacity (DESIGN.md 3).

`RigidStore` holds every field of one `RigidWorld`, split into fixed data (set when a body,
sphere or collider is added; never written by a step) and changing data (pose, velocity, sleep
state, derived world quantities, the grid and the contacts). Capacities are fixed for the store's
life; `RigidWorld` grows by taking a bigger store, copying, and giving the old one back to the pool
(core/field_pool.py).

Body frame (docs/notes_rigid.md): a reference point X maps to world as
`x = R(body_q) (X - body_ref_com) + body_x`; quaternions are w-x-y-z (`body_q[b][0]` is w).
"""

from __future__ import annotations

import taichi as ti

from core import field_pool
from core.field_pool import pow2_at_least
from rigid.broad_phase import ENTRIES_PER_SPHERE


@ti.data_oriented
class RigidStore:
    """Fields of one rigid world; capacities nb (bodies), ns (spheres), ncol (colliders), nct (contacts)."""

    def __init__(self, nb: int, ns: int, ncol: int, nct: int) -> None:
        self.cap_bodies = int(nb)
        self.cap_spheres = int(ns)
        self.cap_colliders = int(ncol)
        self.cap_contacts = int(nct)
        self.grid_size = pow2_at_least(2 * self.cap_spheres)  # hash buckets at most, a power of two
        fb = ti.FieldsBuilder()

        def dense(n, *fields):
            for f in fields:
                fb.dense(ti.i, n).place(f)

        self._bodies(dense, nb)
        self._spheres(dense, ns)
        self._grid(dense, ns)
        self._colliders(dense, ncol)
        self._contacts(dense, nct)
        # ---- scalars ----
        self.sum_reach = ti.field(float)  # () m: sum of the spheres' radius + sweep this step
        self.max_half = ti.field(float)  # () m: largest half-width of a sphere's box this step
        self.grid_cell = ti.field(float)  # () m: the grid's cell edge this step
        self.grid_entries = ti.field(ti.i64)  # () -: entries the boxes need at the first choice of cell edge
        self.grid_mask = ti.field(ti.i32)  # () -: buckets in use this step - 1 (a power of two - 1, < grid_size)
        self.ct_total = ti.field(ti.i32)  # () -: contacts found by the narrow-phase count
        self.pc_valid = ti.field(ti.i32)  # () flag: previous contacts usable for warm starting
        self.max_level = ti.field(ti.i32)  # () -: largest support level this step
        self.max_closing = ti.field(float)  # () m/s: fastest closing speed of a contact that took impulse
        fb.place(self.sum_reach, self.max_half, self.grid_cell, self.grid_entries, self.grid_mask, self.ct_total,
                 self.pc_valid, self.max_level, self.max_closing)
        fb.finalize()

    def _bodies(self, dense, nb: int) -> None:
        """Per body: fixed mass properties and materials, then pose, velocity and step scratch."""
        vec3, vec4, mat3 = ti.math.vec3, ti.math.vec4, ti.math.mat3
        # ---- bodies: fixed data ----
        self.body_inv_mass = ti.field(float)  # (NB,) 1/kg: 0 for a static body
        self.body_ref_com = vec3.field()  # (NB,) m: centre of mass in reference coordinates
        self.body_inv_inertia = mat3.field()  # (NB,) 1/(kg m^2): body-frame inverse inertia about the COM
        self.body_principal_q = vec4.field()  # (NB,) -: w-x-y-z rotation principal frame -> body frame
        self.body_inv_principal = vec3.field()  # (NB,) 1/(kg m^2): inverse principal moments
        self.body_restitution = ti.field(float)  # (NB,) -: coefficient of restitution
        self.body_friction = ti.field(float)  # (NB,) -: Coulomb friction coefficient
        self.body_static = ti.field(ti.i32)  # (NB,) flag: 1 = immovable (window frame, fixed body)
        dense(nb, self.body_inv_mass, self.body_ref_com, self.body_inv_inertia, self.body_principal_q,
              self.body_inv_principal, self.body_restitution, self.body_friction, self.body_static)
        # ---- bodies: changing data ----
        self.body_alive = ti.field(ti.i32)  # (NB,) flag: 0 once removed (ids are never reused)
        self.body_x = vec3.field()  # (NB,) m: world position of the centre of mass
        self.body_q = vec4.field()  # (NB,) -: unit quaternion w-x-y-z, body frame -> world
        self.body_v = vec3.field()  # (NB,) m/s: linear velocity of the COM
        self.body_w = vec3.field()  # (NB,) rad/s: angular velocity, world frame
        self.body_asleep = ti.field(ti.i32)  # (NB,) flag: 1 = sleeping (not integrated)
        self.body_sleep_time = ti.field(float)  # (NB,) s: time spent below the sleep speeds
        self.body_active = ti.field(ti.i32)  # (NB,) flag: alive, dynamic and awake at the start of the step
        self.body_wake = ti.field(ti.i32)  # (NB,) flag: wake request raised by a moving partner
        self.body_inv_inertia_world = mat3.field()  # (NB,) 1/(kg m^2): R I^-1 R^T at the step's pose
        self.body_x0 = vec3.field()  # (NB,) m: COM position at the start of the step
        self.body_r0 = mat3.field()  # (NB,) -: rotation matrix at the start of the step
        self.body_dx = vec3.field()  # (NB,) m: COM displacement since the start of the step
        self.body_dr = mat3.field()  # (NB,) -: rotation since the start of the step, R(q) R0^T
        self.body_pv = vec3.field()  # (NB,) m/s: pseudo velocity of the position correction
        self.body_pw = vec3.field()  # (NB,) rad/s: pseudo angular velocity of the position correction
        self.body_level = ti.field(ti.i32)  # (NB,) -: contact-graph distance from static support (mass scaling)
        self.body_island = ti.field(ti.i32)  # (NB,) -: union-find parent for sleeping islands
        self.body_island_time = ti.field(float)  # (NB,) s: smallest sleep time of the island rooted here
        self.body_sphere_end = ti.field(ti.i32)  # (NB,) -: one past the body's last sphere id (they are contiguous)
        dense(nb, self.body_alive, self.body_x, self.body_q, self.body_v, self.body_w, self.body_asleep,
              self.body_sleep_time, self.body_active, self.body_wake, self.body_inv_inertia_world, self.body_x0,
              self.body_r0, self.body_dx, self.body_dr, self.body_pv, self.body_pw, self.body_level,
              self.body_island, self.body_island_time, self.body_sphere_end)

    def _spheres(self, dense, ns: int) -> None:
        """Per boundary sphere (Sect. 5.3): body-frame centre and radius, then this step's sweep."""
        vec3, ivec3 = ti.math.vec3, ti.math.ivec3
        # ---- boundary spheres: fixed data ----
        self.bp_local = vec3.field()  # (NS,) m: centre in the body frame (X_ref - body_ref_com)
        self.bp_radius = ti.field(float)  # (NS,) m: radius
        self.bp_body = ti.field(ti.i32)  # (NS,) -: owning body
        dense(ns, self.bp_local, self.bp_radius, self.bp_body)
        # ---- boundary spheres: changing data ----
        self.bp_x = vec3.field()  # (NS,) m: world centre at the start of the step
        self.bp_sweep = ti.field(float)  # (NS,) m: distance the sphere may travel this step
        self.bp_disp = vec3.field()  # (NS,) m: its displacement this step at the start velocities (v + w x r) dt
        self.bp_arc = ti.field(float)  # (NS,) m: bound on how far a rotation's arc leaves that line, (|w| dt)^2 r / 2
        self.bp_cell_lo = ivec3.field()  # (NS,) -: lowest grid cell the sphere's box covers (broad_phase.box_cells)
        self.bp_cell_hi = ivec3.field()  # (NS,) -: highest grid cell it covers
        dense(ns, self.bp_x, self.bp_sweep, self.bp_disp, self.bp_arc, self.bp_cell_lo, self.bp_cell_hi)
        self.bp_ct_start = ti.field(ti.i32)  # (NS+1,) -: CSR offsets of this step's contacts by sphere
        self.bp_pc_start = ti.field(ti.i32)  # (NS+1,) -: CSR offsets of the previous step's contacts
        dense(ns + 1, self.bp_ct_start, self.bp_pc_start)

    def _grid(self, dense, ns: int) -> None:
        """The broad phase's hashed uniform grid (CSR buckets of sphere ids)."""
        # ---- broad phase: hashed uniform grid ----
        self.grid_count = ti.field(ti.i32)  # (H,) -: spheres per bucket
        self.grid_fill = ti.field(ti.i32)  # (H,) -: scatter cursor per bucket
        self.grid_top = ti.field(ti.i32)  # (H,) -: the bucket's largest sphere id, -1 when empty
        dense(self.grid_size, self.grid_count, self.grid_fill, self.grid_top)
        self.grid_start = ti.field(ti.i32)  # (H+1,) -: CSR offsets into grid_entry
        dense(self.grid_size + 1, self.grid_start)
        # a sphere is listed in every cell its box covers: at most ENTRIES_PER_SPHERE on average (choose_cell)
        self.grid_entry = ti.field(ti.i32)  # (E,) -: sphere ids sorted by bucket, then id
        self.grid_reach = ti.math.vec4.field()  # (E,) m: that sphere's centre and radius + sweep, in entry order
        dense(ENTRIES_PER_SPHERE * ns, self.grid_entry, self.grid_reach)

    def _colliders(self, dense, ncol: int) -> None:
        """Per static collider (plane or oriented box)."""
        vec3, vec4 = ti.math.vec3, ti.math.vec4
        # ---- static colliders: fixed data ----
        self.col_kind = ti.field(ti.i32)  # (NC,) -: 0 = half-space (plane), 1 = oriented box
        self.col_x = vec3.field()  # (NC,) m: a point of the plane / centre of the box
        self.col_q = vec4.field()  # (NC,) -: w-x-y-z box orientation (box frame -> world)
        self.col_n = vec3.field()  # (NC,) -: outward unit normal of the plane
        self.col_half = vec3.field()  # (NC,) m: box half extents
        self.col_restitution = ti.field(float)  # (NC,) -
        self.col_friction = ti.field(float)  # (NC,) -
        dense(ncol, self.col_kind, self.col_x, self.col_q, self.col_n, self.col_half, self.col_restitution,
              self.col_friction)

    def _contacts(self, dense, nct: int) -> None:
        """Per contact of this step (sorted by (sphere a, key b)) and of the previous one (warm start)."""
        vec3 = ti.math.vec3
        # ---- contacts of this step (sorted by (sphere a, key b)) ----
        self.ct_a = ti.field(ti.i32)  # (NCT,) -: sphere A
        self.ct_b = ti.field(ti.i32)  # (NCT,) -: sphere B, or -1 - k for static collider k
        self.ct_body_a = ti.field(ti.i32)  # (NCT,) -: body of A
        self.ct_body_b = ti.field(ti.i32)  # (NCT,) -: body of B, -1 for a static collider
        self.ct_n = vec3.field()  # (NCT,) -: unit normal, from B towards A
        self.ct_p = vec3.field()  # (NCT,) m: contact point (midway between the surfaces)
        self.ct_ra = vec3.field()  # (NCT,) m: contact point minus COM of A
        self.ct_rb = vec3.field()  # (NCT,) m: contact point minus COM of B
        self.ct_t1 = vec3.field()  # (NCT,) -: first tangent
        self.ct_t2 = vec3.field()  # (NCT,) -: second tangent (n x t1)
        self.ct_sep = ti.field(float)  # (NCT,) m: signed gap at the step start (< 0: penetration)
        self.ct_ima = ti.field(float)  # (NCT,) 1/kg: inverse mass of A in this step (0 if inactive)
        self.ct_imb = ti.field(float)  # (NCT,) 1/kg: inverse mass of B in this step
        self.ct_sa = ti.field(float)  # (NCT,) -: inverse mass/inertia scale of A (mass-ratio clamp)
        self.ct_sb = ti.field(float)  # (NCT,) -: inverse mass/inertia scale of B
        self.ct_mn = ti.field(float)  # (NCT,) kg: normal effective mass
        self.ct_mt1 = ti.field(float)  # (NCT,) kg: effective mass along t1
        self.ct_mt2 = ti.field(float)  # (NCT,) kg: effective mass along t2
        self.ct_vn0 = ti.field(float)  # (NCT,) m/s: relative normal velocity before the solve
        self.ct_mu = ti.field(float)  # (NCT,) -: friction coefficient of the pair
        self.ct_e = ti.field(float)  # (NCT,) -: restitution of the pair
        self.ct_ln = ti.field(float)  # (NCT,) N s: accumulated normal impulse of the current substep
        self.ct_ltot = ti.field(float)  # (NCT,) N s: normal impulse applied over the whole step
        self.ct_lmax = ti.field(float)  # (NCT,) N s: largest normal impulse during the velocity solve
        self.ct_lt1 = ti.field(float)  # (NCT,) N s: accumulated friction impulse along t1
        self.ct_lt2 = ti.field(float)  # (NCT,) N s: accumulated friction impulse along t2
        self.ct_lp = ti.field(float)  # (NCT,) N s: accumulated pseudo impulse (position correction)
        dense(nct, self.ct_a, self.ct_b, self.ct_body_a, self.ct_body_b, self.ct_n, self.ct_p, self.ct_ra,
              self.ct_rb, self.ct_t1, self.ct_t2, self.ct_sep, self.ct_ima, self.ct_imb, self.ct_sa, self.ct_sb,
              self.ct_mn, self.ct_mt1, self.ct_mt2, self.ct_vn0, self.ct_mu, self.ct_e, self.ct_ln, self.ct_ltot,
              self.ct_lmax, self.ct_lt1, self.ct_lt2, self.ct_lp)
        # ---- contacts of the previous step, for warm starting ----
        self.pc_b = ti.field(ti.i32)  # (NCT,) -: key b of the previous contact (CSR by sphere a)
        self.pc_ln = ti.field(float)  # (NCT,) N s: its normal impulse
        self.pc_lt = vec3.field()  # (NCT,) N s: its friction impulse, world vector
        dense(nct, self.pc_b, self.pc_ln, self.pc_lt)


# Stores are recycled (core/field_pool.py): the rigid kernels take the store as a template argument, so
# each new store object recompiles every kernel of the step; a recycled store with the same capacities
# reuses them, and a released one is never destroyed (that clears every compiled kernel).
def _key(nb: int, ns: int, ncol: int, nct: int) -> tuple[int, int, int, int]:
    return tuple(pow2_at_least(n, 16) for n in (nb, ns, ncol, nct))  # type: ignore[return-value]


def acquire_store(nb: int, ns: int, ncol: int, nct: int) -> RigidStore:
    """A store with at least these capacities: a recycled one when available, else a new one."""
    key = _key(nb, ns, ncol, nct)
    return field_pool.acquire(("rigid", *key), lambda: RigidStore(*key))


def recycle_store(store: RigidStore) -> None:
    """Give a store back for reuse (its content is stale; the next owner uploads what it uses)."""
    key = (store.cap_bodies, store.cap_spheres, store.cap_colliders, store.cap_contacts)
    field_pool.recycle(("rigid", *key), store)
