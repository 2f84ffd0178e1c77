"""Bodies from tet particles, and splitting a body into fragments (DESIGN.md 4, 5.3 of the paper).

`add_tet_body` makes one rigid body from a set of tet particles: exact mass properties from the
tets (rigid.mass) and boundary spheres from its surface particles (geometry.boundary, Sect. 5.3).

`split_body` replaces a body by one body per label (the connected components the fracture stage
found). Each child keeps the reference coordinates of its tets; with the parent's pose (q_p, x_p,
ref_com_p) and velocity (v_p, w_p):

    ref_com_c  = centre of mass of the child's tets (reference frame)
    q_c        = q_p
    x_c        = R(q_p) (ref_com_c - ref_com_p) + x_p
    v_c        = v_p + w_p x (x_c - x_p)          (the parent's velocity field)
    w_c        = w_p

so the total mass is the sum of the tet masses (exactly rounded sums, math.fsum), and linear and
angular momentum are conserved to round-off (parallel-axis theorem; exact unless the inertia floor
of rigid.mass raised a child's inertia). Boundary spheres of the children are rebuilt from the
particles on the child's surface: a particle is on it when a face link is missing (-1) or leads
to a particle outside the child (a cut link).

Also small procedural tet meshes used by tests and benchmarks (box, ball).
"""

from __future__ import annotations

import itertools

import numpy as np

from core.arrays import cross3, group_indices
from core.errors import ConfigError
from geometry.boundary import DEFAULT_GROUP_SIZE, area_weights, build_boundary_particles
from geometry.particles import ParticleSet
from geometry.tetmesh import TetMesh, signed_volumes
from rigid.mass import mass_properties
from rigid.quat import IDENTITY, quat_to_matrix
from rigid.world import RigidWorld


# --------------------------------------------------------------------------- procedural meshes
def box_tetmesh(half_extents, divisions=(1, 1, 1), center=(0.0, 0.0, 0.0)) -> TetMesh:
    """Axis-aligned box of half extents (m) cut into nx*ny*nz cells of 6 tets (Kuhn split)."""
    h = np.asarray(half_extents, dtype=np.float64)
    n = np.asarray(divisions, dtype=np.int64)
    axes = [np.linspace(-h[a], h[a], n[a] + 1) for a in range(3)]
    gx, gy, gz = np.meshgrid(*axes, indexing="ij")
    verts = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], 1) + np.asarray(center, dtype=np.float64)

    def vid(i, j, k):
        return (i * (n[1] + 1) + j) * (n[2] + 1) + k

    tets = []
    for i, j, k in itertools.product(range(n[0]), range(n[1]), range(n[2])):
        for perm in itertools.permutations(range(3)):
            p = np.array([i, j, k])
            path = [vid(*p)]
            for a in perm:
                p = p.copy()
                p[a] += 1
                path.append(vid(*p))
            tets.append(path)
    tets = np.array(tets, dtype=np.int64)
    vol = signed_volumes(verts[tets])
    tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
    return TetMesh(verts, tets, source=f"box{tuple(h)}")


def ball_tetmesh(radius: float, shells: int = 3, points_outer: int = 96, center=(0.0, 0.0, 0.0)) -> TetMesh:
    """Ball of `radius` (m): Delaunay tets of Fibonacci-sphere shells plus the centre (scipy)."""
    from scipy.spatial import Delaunay

    pts = [np.zeros((1, 3))]
    for s in range(1, shells + 1):
        r = radius * s / shells
        m = max(8, int(points_outer * (s / shells) ** 2))
        k = np.arange(m) + 0.5
        phi = np.arccos(1 - 2 * k / m)
        th = np.pi * (1 + 5**0.5) * k
        pts.append(r * np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], 1))
    verts = np.concatenate(pts)
    tets = Delaunay(verts).simplices.astype(np.int64)
    vol = signed_volumes(verts[tets])
    tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
    vol = np.abs(vol)
    tets = tets[vol > 1e-9 * radius**3]  # drop slivers of cospherical points
    return TetMesh(verts + np.asarray(center, dtype=np.float64), tets, source=f"ball(r={radius})")


def corner_spheres(half_extents, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """8 spheres of `radius` inset in the corners of a box (body frame centred on the box): the
    box's faces are tangent to them, so a box resting on a plane sits at its exact height."""
    h = np.asarray(half_extents, dtype=np.float64) - radius
    if np.any(h < 0):
        raise ConfigError("corner_spheres.radius", radius, f"<= the smallest half extent {min(half_extents)}")
    c = np.array(list(itertools.product([-1, 1], repeat=3)), dtype=np.float64) * h
    return c, np.full(8, float(radius))


def box_surface_spheres(half_extents, radius: float, per_edge: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Spheres of `radius` inset under all six faces of a box on a per_edge x per_edge grid (body
    frame centred on the box): a tight, regular covering used for deep-overlap tests."""
    h = np.asarray(half_extents, dtype=np.float64) - radius
    if np.any(h < 0):
        raise ConfigError(
            "box_surface_spheres.radius", radius, f"<= the smallest half extent {min(half_extents)}"
        )
    pts = []
    t = np.linspace(-1.0, 1.0, per_edge)
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        gu, gv = np.meshgrid(t * h[u], t * h[v], indexing="ij")
        for side in (-1.0, 1.0):
            p = np.zeros((gu.size, 3))
            p[:, axis] = side * h[axis]
            p[:, u] = gu.ravel()
            p[:, v] = gv.ravel()
            pts.append(p)
    c = np.unique(np.round(np.concatenate(pts), 12), axis=0)
    return c, np.full(len(c), float(radius))


# --------------------------------------------------------------------------- bodies from particles
def free_faces(particles: ParticleSet, ids: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """(len(ids), 4) bool: faces on their group's surface (no face link, or one to another group)."""
    lab = np.full(len(particles), -1, dtype=np.int64)
    lab[ids] = labels
    lk = particles.links[ids]
    across = np.where(lk >= 0, lab[np.maximum(lk, 0)], -2)
    return (lk < 0) | (across != labels[:, None])


def surface_mask(particles: ParticleSet, ids: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """(len(ids),) bool: particle on its group's surface (a missing face link, or one to another group)."""
    return free_faces(particles, ids, labels).any(axis=1)


def boundary_spheres(particles: ParticleSet, ids: np.ndarray, labels: np.ndarray, group_size: int,
                     cache: bool = False, keep=None):
    """Boundary spheres (geometry.boundary) of each label's surface particles; body = label index;
    `cache`: the groups through the disk cache (a whole object's build); `keep`: the groups of the
    body these particles were (geometry.boundary.KeptGroups, members as positions in `ids`), kept
    where the split left them whole. The spheres' members are positions in `ids`."""
    free = free_faces(particles, ids, labels)
    return build_boundary_particles(
        particles.centroid[ids],
        particles.radius[ids],
        particles.mass[ids],
        labels.astype(np.int32),
        free.any(axis=1),
        group_size=group_size,
        rest_verts=particles.rest_verts[ids],
        free_faces=free,
        cache=cache,
        weight=area_weights(particles.radius, particles.parent, ids),
        keep=keep,
    )


def add_tet_body(
    world: RigidWorld,
    particles: ParticleSet,
    particle_ids=None,
    group_size: int = DEFAULT_GROUP_SIZE,
    offset=(0.0, 0.0, 0.0),
    q=IDENTITY,
    v=(0.0, 0.0, 0.0),
    w=(0.0, 0.0, 0.0),
    static: bool = False,
    restitution: float = 0.0,
    friction: float = 0.5,
    spheres: tuple[np.ndarray, np.ndarray] | None = None,
    cache: bool = False,
) -> int:
    """Add a body made of `particles[particle_ids]` (default: all alive) and return its id.

    The body starts at its rest pose moved by `offset` (m): body_x = ref_com + offset, rotated by q
    about its COM. Boundary spheres come from the surface particles with `group_size` n (Sect. 5.3),
    unless `spheres` = (centres in the reference frame (B,3) m, radii (B,) m) is given; `cache`: their
    grouping through the disk cache (geometry/build_cache.py: a scene's bodies at its build).
    Sets particles.body[particle_ids] to the new id.
    """
    ids = (
        np.flatnonzero(particles.alive) if particle_ids is None else np.asarray(particle_ids, dtype=np.int64)
    )
    mp = mass_properties(
        particles.rest_verts[ids], particles.mass[ids], source=f"body of {len(ids)} particles"
    )
    if spheres is None:
        bp = boundary_spheres(particles, ids, np.zeros(len(ids), np.int64), group_size, cache)
        centres, radii = bp.position, bp.radius
    else:
        centres, radii = np.asarray(spheres[0], dtype=np.float64), np.asarray(spheres[1], dtype=np.float64)
    bid = world.add_body(
        mp,
        centres - mp.com,
        radii,
        x=mp.com + np.asarray(offset, dtype=np.float64),
        q=q,
        v=v,
        w=w,
        static=static,
        restitution=restitution,
        friction=friction,
    )
    particles.body[ids] = bid
    return bid


def split_body(
    world: RigidWorld,
    body_id: int,
    particles: ParticleSet,
    particle_ids,
    labels,
    group_size: int = DEFAULT_GROUP_SIZE,
    static_labels=None,
    spheres=None,
) -> list[int]:
    """Replace body `body_id` by one body per distinct label; returns the new ids in label order.

    particle_ids: (N,) the parent's alive tet particles; labels: (N,) non-negative fragment label
    of each. static_labels: optional bool array indexed by label value, True = that child is static
    (a shard still held by a window frame); default: every child inherits the parent's flag.
    spheres: the children's boundary spheres, `boundary_spheres(particles, particle_ids, dense labels,
    group_size, ...)` made by the caller (which keeps their groups), else made here.
    Sets particles.body of each child's particles. See the module docstring for the kinematics.
    """
    ids = np.asarray(particle_ids, dtype=np.int64).reshape(-1)
    lab = np.asarray(labels).reshape(-1)
    if len(ids) != len(lab) or len(ids) == 0:
        raise ConfigError(
            "split_body.labels", (len(ids), len(lab)), "one label per particle id, at least one"
        )
    if body_id < 0 or body_id >= world.n_bodies:
        raise ConfigError("split_body.body_id", body_id, f"[0, {world.n_bodies})")
    st = world.body_state()
    if not st.alive[body_id]:
        raise ConfigError("split_body.body_id", body_id, "a body that is alive")
    uniq, dense = np.unique(lab, return_inverse=True)
    if static_labels is not None:
        held = np.asarray(static_labels, dtype=bool).reshape(-1)
        if uniq.min() < 0 or uniq.max() >= len(held):
            raise ConfigError(
                "split_body.static_labels", len(held), f"one flag per label value 0..{uniq.max()}"
            )
    dense = dense.ravel().astype(np.int64)
    x_p, q_p, v_p, w_p = st.x[body_id], st.q[body_id], st.v[body_id], st.w[body_id]
    rot = quat_to_matrix(q_p)
    com_p = world.body_ref_com(body_id)
    static = world.body_is_static(body_id)
    rest = float(world._hb.restitution[body_id])
    fric = float(world._hb.friction[body_id])
    bp = boundary_spheres(particles, ids, dense, group_size) if spheres is None else spheres
    by_label = [ids[g] for g in group_indices(dense)]  # every label 0..C-1 has particles (np.unique)
    sphere_cut = np.searchsorted(bp.body, np.arange(len(uniq) + 1))  # bp's spheres come in label order
    specs = []
    for c, sel in enumerate(by_label):  # sel: the particles of label c, ascending
        mp = mass_properties(
            particles.rest_verts[sel], particles.mass[sel], source=f"fragment {c} of body {body_id}"
        )
        x_c = rot @ (mp.com - com_p) + x_p
        v_c = v_p + cross3(w_p, x_c - x_p)
        sph = slice(sphere_cut[c], sphere_cut[c + 1])
        static_c = static if static_labels is None else bool(held[uniq[c]])
        specs.append(
            dict(
                mass=mp,
                sphere_local=bp.position[sph] - mp.com,
                sphere_radius=bp.radius[sph],
                x=x_c,
                q=q_p,
                v=v_c,
                w=w_p,
                static=static_c,
                restitution=rest,
                friction=fric,
            )
        )
    new_ids = world.replace_bodies([body_id], specs)
    for sel, bid in zip(by_label, new_ids):
        particles.body[sel] = bid
    return new_ids


def add_box_body(
    world: RigidWorld,
    half_extents,
    density: float,
    x=(0.0, 0.0, 0.0),
    q=IDENTITY,
    v=(0.0, 0.0, 0.0),
    w=(0.0, 0.0, 0.0),
    sphere_radius: float | None = None,
    divisions=(1, 1, 1),
    group_size: int | None = None,
    surface_grid: int = 0,
    static: bool = False,
    restitution: float = 0.0,
    friction: float = 0.5,
) -> int:
    """A box of tets (Kuhn split, `divisions` cells per axis) with COM at world `x` (m).

    Spheres: 8 corner spheres of `sphere_radius` (default: a fifth of the smallest half extent);
    with `surface_grid` k > 1, a k x k grid of such spheres under every face; with `group_size`, the
    boundary particles of geometry.boundary with that sampling size n.
    """
    from geometry.particles import build_particles

    h = np.asarray(half_extents, dtype=np.float64)
    ps = build_particles(box_tetmesh(h, divisions), float(density))
    mp = mass_properties(ps.rest_verts, ps.mass, source="box")
    r = float(h.min()) / 5.0 if sphere_radius is None else sphere_radius
    if group_size is None:
        loc, rad = box_surface_spheres(h, r, surface_grid) if surface_grid > 1 else corner_spheres(h, r)
        loc = loc - mp.com
    else:
        bp = boundary_spheres(ps, np.arange(len(ps)), np.zeros(len(ps), np.int64), group_size)
        loc, rad = bp.position - mp.com, bp.radius
    return world.add_body(
        mp, loc, rad, x=x, q=q, v=v, w=w, static=static, restitution=restitution, friction=friction
    )
