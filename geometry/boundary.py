"""Boundary particles (Sect. 5.3): coarse collision spheres made from groups of surface particles.

The paper groups the surface particles of a body into sets of n nearest neighbours (n = 4 by
default), one boundary sphere per set: mass = sum of the members' masses, position = mean of
their positions; particles left over at sharp corners become spheres on their own.

Grouping rule (deterministic): per body, surface particles are visited along a Morton curve over
their rest centroids; an unassigned particle takes its n - 1 nearest unassigned surface
neighbours that lie within `reach` x (the larger of the two radii) of it. If fewer are left, it
becomes a sphere on its own (the paper's "unaided particles at sharp corners"). The radius of a
sphere covers every member: max |x_k - c| + r_k. Ties among equally near candidates fall in
scipy's k-d tree order.

A subdivided child counts for the part of its parent's surface it stands for (`area_weights`): a
group takes particles until they stand for n unsubdivided ones, so a crack's faces, made of small
children, get spheres about as large as the rest of the body's (at most 3n particles a group, the
candidates' count), and a child that cannot start a group joins the sphere of its nearest grouped
child instead of staying alone; a group of unsubdivided particles is the paper's n.

Every body is grouped in one pass: the fragments of a split are tens of bodies, and one tree, one
query and one grouping kernel serve them all (the same groups as a pass per body, tested). A whole
object's build (`cache=True`) keeps its groups on disk (geometry/build_cache.py): the query is fast, but
importing scipy for it costs a start 0.45 s, and the grouping kernel's first launch 50 ms.

Groups kept through a split (`keep`, issue 16 item 3: an event's cost grows with its crack, not
with the body): a fragment's surface away from the crack is the parent's, so a group of the parent
whose members are all still surface particles of one fragment, with the same free faces, keeps its
members; its sphere is then the parent's sphere, bit for bit (centre, radius and pull inside come
from the members alone), and is taken as it was where `keep` holds it (made again otherwise: the
same numbers). Only the other surface particles (the crack's faces, and the groups it broke) are
grouped by the rule above, among themselves, and only their spheres are made. A chip's corner
spheres are not kept.

Departure from the paper (docs/decisions.md): with the members' free faces given, the sphere's
centre is moved inwards along the group's mean outward normal until its outermost point lies on
the surface (the paper keeps the mean position); one-particle spheres stay where they are. A
covering sphere around several surface particles
otherwise sticks out by about half a tet edge and objects rest visibly above the floor. And a body
whose spheres lie on a line (a chip) gets spheres at its corners instead (geometry/chip_corners.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.arrays import cross3
from core.host_threads import host_cores
from geometry.boundary_groups import greedy_groups

DEFAULT_GROUP_SIZE = 4  # particles per boundary sphere (the paper's sampling size n)
DEFAULT_REACH = 4.0  # candidate members lie within this many particle radii of the seed (n = 4)
PARALLEL_QUERY = 2000  # surface particles of a body from which its nearest-neighbour query uses every core
# the grouping's version in the cache keys: raise it when `_group_ids` (the Morton order, the candidate
# search or the grouping rule) answers the same input differently, so that cached groups are not read
GROUPS_VERSION = 1


@dataclass
class BoundaryParticles:
    """Collision spheres of one or more bodies, in the reference frame."""

    position: np.ndarray  # (B, 3) m: mean of the members' rest centroids
    radius: np.ndarray  # (B,) m: covers every member sphere
    mass: np.ndarray  # (B,) kg: sum of the members' masses
    body: np.ndarray  # (B,) int32: body id
    member_start: np.ndarray  # (B + 1,) int64: CSR offsets into `members`
    members: np.ndarray  # (M,) int64: particle indices of each sphere
    member_faces: np.ndarray | None = None  # (M,) uint8: each member's free faces (bit k: face k), where given
    corner: np.ndarray | None = None  # (B,) bool: a chip's corner sphere (geometry/chip_corners.py), not a group's

    def __len__(self) -> int:
        return len(self.mass)


@dataclass
class KeptGroups:
    """Groups of an earlier grouping, offered to `build_boundary_particles` (module doc, "Groups kept
    through a split")."""

    member_start: np.ndarray  # (G + 1,) int64: CSR offsets into `members`
    members: np.ndarray  # (M,) int64: each group's rows in the call's arrays, -1 where the particle is gone
    member_faces: np.ndarray  # (M,) uint8: each member's free faces when the group was made (bit k: face k)
    position: np.ndarray | None = None  # (G, 3) m: each group's sphere when it was made (reference frame)
    radius: np.ndarray | None = None  # (G,) m
    mass: np.ndarray | None = None  # (G,) kg


def face_bits(free_faces: np.ndarray) -> np.ndarray:
    """(N,) uint8: the free faces (N, 4) bool of each particle as bits (face k: bit k)."""
    return (np.asarray(free_faces, np.uint8) << np.arange(4, dtype=np.uint8)).sum(axis=1).astype(np.uint8)


def _kept_rows(keep: KeptGroups, surface: np.ndarray, body: np.ndarray, bits: np.ndarray) -> np.ndarray:
    """(N,) int64: the kept group of each row (its index in `keep`), -1 for a row in none: a group is
    kept when every member is there, on the surface, with the faces it had, and all in one body."""
    start, m = np.asarray(keep.member_start, np.int64), np.asarray(keep.members, np.int64)
    kept = np.full(len(surface), -1, np.int64)
    if len(m) == 0:
        return kept
    group_of = np.repeat(np.arange(len(start) - 1), np.diff(start))
    row = np.maximum(m, 0)
    ok = (m >= 0) & surface[row] & (bits[row] == keep.member_faces)
    ok &= body[row] == body[row[start[:-1]]][group_of]
    whole = np.bincount(group_of, weights=~ok, minlength=len(start) - 1) == 0
    kept[row[whole[group_of]]] = group_of[whole[group_of]]
    return kept


def _by_body(body_rows: np.ndarray):
    """(first row of each body (B,), body index of each row (n,)) of rows sorted by body."""
    first = np.r_[0, np.flatnonzero(np.diff(body_rows)) + 1]
    return first, np.repeat(np.arange(len(first)), np.diff(np.r_[first, len(body_rows)]))


def _morton_order(points: np.ndarray, first: np.ndarray, body_of: np.ndarray, bits: int = 10) -> np.ndarray:
    """Rows visited body by body, each body's along a Morton curve over its own bounding box
    (ties in row order)."""
    lo = np.minimum.reduceat(points, first, axis=0)
    span = np.maximum((np.maximum.reduceat(points, first, axis=0) - lo).max(1), 1e-300)
    q = np.clip(((points - lo[body_of]) / span[body_of, None] * ((1 << bits) - 1)).astype(np.uint64), 0,
                (1 << bits) - 1)
    key = np.zeros(len(points), dtype=np.uint64)
    for b in range(bits):
        for axis in range(3):
            key |= ((q[:, axis] >> np.uint64(b)) & np.uint64(1)) << np.uint64(3 * b + axis)
    return np.lexsort((key, body_of))


def _group_ids(points, rad, body_of, first, group_size: int, reach: float, cache: bool,
               weight: np.ndarray) -> np.ndarray:
    """(n,) group id of each row: the greedy grouping (geometry.boundary_groups) of the rows in Morton
    order over their candidates; read from the disk cache when `cache` (a whole object's build)."""

    def group() -> np.ndarray:
        near, ok = _query_candidates(points, rad, body_of, min(len(points), 3 * group_size), reach)
        return greedy_groups(_morton_order(points, first, body_of), near, ok, group_size, 0, weight)[0]

    if not cache:
        return group()

    from geometry.build_cache import cached_arrays, digest, package_version

    inputs = b"".join(np.asarray(a, t).tobytes() for a, t in ((points, np.float64), (rad, np.float64),
                                                              (body_of, np.int64)))
    if (weight != 1.0).any():  # subdivided children among the rows; a build's (all 1) keeps its earlier key
        inputs += np.asarray(weight, np.float64).tobytes()
    key = digest("boundary-groups", f"{GROUPS_VERSION} scipy {package_version('scipy')}", inputs,
                 group_size=int(group_size), reach=float(reach))

    def valid(hit: dict) -> bool:
        gid = hit["gid"]
        return gid.shape == (len(points),) and (len(gid) == 0 or (gid.min() >= 0 and bool(np.all(np.bincount(gid)))))

    return cached_arrays("boundary", key, ("gid",), lambda: dict(gid=group()), valid)["gid"].astype(np.int64)


def _query_candidates(points, rad, body_of, k, reach):
    """Each row's k nearest rows of its own body (itself first) and which lie within reach x the
    larger radius: one tree over every body, the body index as a 4th coordinate further apart than
    any two points, so that distances within a body are the 3D ones bit for bit."""
    from scipy.spatial import cKDTree

    extent = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    apart = 4.0 * extent + 1.0  # m: more than any distance within a body
    p4 = np.column_stack([points, body_of * apart])
    workers = host_cores() if len(points) >= PARALLEL_QUERY else 1
    # no candidate lies further than reach x the largest radius: the search stops there (the rows it
    # leaves out, inf and len(points), would fail the test below anyway)
    bound = reach * float(rad.max()) * (1.0 + 1e-9)
    dist, near = cKDTree(p4).query(p4, k=k, workers=workers, distance_upper_bound=bound)
    dist, near = dist.reshape(len(points), k), near.reshape(len(points), k)
    near = np.minimum(near, len(points) - 1)  # a missing neighbour comes as len(points): any row, not ok
    ok = (body_of[near] == body_of[:, None]) & (dist <= reach * np.maximum(rad[:, None], rad[near]))
    return near, ok


def build_boundary_particles(
    centroid: np.ndarray,
    radius: np.ndarray,
    mass: np.ndarray,
    body: np.ndarray,
    surface: np.ndarray,
    group_size: int = DEFAULT_GROUP_SIZE,
    reach: float | None = None,
    rest_verts: np.ndarray | None = None,
    free_faces: np.ndarray | None = None,
    cache: bool = False,
    weight: np.ndarray | None = None,
    keep: KeptGroups | None = None,
) -> BoundaryParticles:
    """Group the surface particles of every body into boundary spheres (Sect. 5.3).

    centroid (N,3) m, radius (N,) m, mass (N,) kg, body (N,) int: per particle;
    surface (N,) bool: which particles take part (surface particles of live bodies);
    rest_verts (N,4,3) m and free_faces (N,4) bool (faces on the surface): optional; when given,
    spheres are pulled inside the surface (module docstring); cache: keep the groups on disk (whole
    objects at their build, which the next run builds again); weight (N,): the surface each particle
    stands for, in unsubdivided particles (`area_weights`; default 1 each): a group takes members until
    their weights sum to group_size; keep: an earlier grouping whose groups stay where they still hold
    (with free_faces given; module doc). Each body's kept groups come first, in their order.
    """
    if group_size < 1:
        raise ValueError(f"group_size must be >= 1, got {group_size}")
    if reach is None:  # a group of n surface particles spans about sqrt(n) particle spacings
        reach = DEFAULT_REACH * max(1.0, np.sqrt(group_size / DEFAULT_GROUP_SIZE))
    idx = np.flatnonzero(surface)
    if len(idx) == 0:
        z = np.zeros(0)
        return BoundaryParticles(
            np.zeros((0, 3)), z, z.copy(), np.zeros(0, np.int32), np.zeros(1, np.int64), np.zeros(0, np.int64)
        )
    bits = face_bits(free_faces) if free_faces is not None else None
    kept = np.full(len(surface), -1, np.int64)
    if keep is not None and bits is not None:
        kept = _kept_rows(keep, np.asarray(surface, bool), np.asarray(body), bits)
    rest = idx[kept[idx] < 0]
    # every body at once (a split makes tens of fragments: one query and one grouping instead of one each)
    rows = rest[np.argsort(body[rest], kind="stable")]  # each body's surface particles together, ascending
    gid = np.zeros(0, np.int64)
    if len(rows):
        first, body_of = _by_body(body[rows])
        area = np.ones(len(rows)) if weight is None else np.asarray(weight, np.float64)[rows]
        gid = _group_ids(centroid[rows], radius[rows], body_of, first, group_size, reach, cache, area)
    held = np.flatnonzero(kept >= 0)
    everyone = np.concatenate([held, rows])
    # groups body by body, each body's kept ones first; a group's members in row order
    fresh = np.r_[np.zeros(len(held), np.int64), np.ones(len(rows), np.int64)]
    group = np.concatenate([kept[held], gid])
    order = np.lexsort((everyone, group, fresh, body[everyone]))
    members = everyone[order]
    key = np.stack([body[members], fresh[order], group[order]], 1)
    new_group = np.r_[True, (key[1:] != key[:-1]).any(axis=1)]
    g = np.cumsum(new_group) - 1
    start = np.r_[np.flatnonzero(new_group), len(members)].astype(np.int64)
    made = np.ones(len(start) - 1, bool)  # the groups whose spheres are made here
    if keep is not None and keep.position is not None and rest_verts is not None and bits is not None:
        made = fresh[order][start[:-1]] == 1  # a kept group's sphere is its parent's (module doc)
    c, rad, msum = _made_spheres(made, g, start, members, centroid, radius, mass, rest_verts, free_faces)
    if not made.all():
        src = group[order][start[:-1]][~made]
        c[~made], rad[~made], msum[~made] = keep.position[src], keep.radius[src], keep.mass[src]
    out = BoundaryParticles(
        position=c,
        radius=rad,
        mass=msum,
        body=body[members[start[:-1]]].astype(np.int32),
        member_start=start,
        members=members,
        member_faces=None if bits is None else bits[members],
        corner=np.zeros(len(c), bool),
    )
    return out if rest_verts is None else _chips_on_corners(out, rest_verts, mass)


def _made_spheres(made, g, start, members, centroid, radius, mass, rest_verts, free_faces):
    """Centres (pulled inside where the faces are given), radii and masses of the groups where `made`
    (G,) bool, of the grouping `g`, `start` over the rows `members`; the other groups' entries are
    left for the caller. Each group's numbers come from its own members alone."""
    ng = len(start) - 1
    c, rad, msum = np.empty((ng, 3)), np.empty(ng), np.empty(ng)
    if not made.any():
        return c, rad, msum
    mine = made[g]
    rows = members[mine]
    sub_g = (np.cumsum(made) - 1)[g[mine]]
    sub_start = np.r_[0, np.cumsum(np.diff(start)[made])]
    cm, rm, mm = _group_spheres(sub_g, sub_start, centroid[rows], radius[rows], mass[rows])
    if rest_verts is not None and free_faces is not None:
        cm = _pull_inside(cm, rm, sub_g, sub_start, centroid[rows], rest_verts[rows], free_faces[rows])
    c[made], rad[made], msum[made] = cm, rm, mm
    return c, rad, msum


def area_weights(radius: np.ndarray, parent: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """(len(ids),) the surface each particle of rows `ids` stands for in boundary groups, in units of its
    unsubdivided parent's: (r / r_parent)^2 for a subdivided child whose parent row is in the set
    (radius (N,) m and parent (N,) of every row; a parent outside it is -2 - its id, none -1), 1 otherwise.
    A crack's faces are made of the children of the tets it cut (Sect. 5.2, 2-20 a tet): grouped four
    by four they would be covered by spheres two to four times smaller than the rest of the body's,
    which resolve no contact better (the body's other faces set its collision resolution) and made
    Pots' spheres 3.5x as many after its fractures (docs/decisions.md, session 34)."""
    w = np.ones(len(ids))
    par = parent[ids]
    child = np.flatnonzero(par >= 0)
    w[child] = np.minimum((radius[ids[child]] / radius[par[child]]) ** 2, 1.0)
    return w


def _chips_on_corners(bp: BoundaryParticles, rest_verts: np.ndarray, mass: np.ndarray) -> BoundaryParticles:
    """The spheres of every body whose spheres lie on a line replaced by its corners
    (geometry/chip_corners.py); the other bodies' spheres unchanged, every body's still contiguous."""
    from geometry.chip_corners import chip_corners, on_a_line

    line = on_a_line(bp.body, bp.position, bp.radius)
    if not line.any():
        return bp
    sizes = np.diff(bp.member_start)
    sphere_of = np.repeat(np.arange(len(bp)), sizes)  # the sphere of each entry of bp.members
    chip_body = np.unique(bp.body[line])
    in_chips = line[sphere_of]
    member_body = bp.body[sphere_of[in_chips]]  # spheres are contiguous per body: so are these members
    cut = np.searchsorted(member_body, chip_body[1:])
    pos, rad, m, member, chip = chip_corners(np.split(bp.members[in_chips], cut), rest_verts, mass)
    keep = ~line
    body = np.concatenate([bp.body[keep], chip_body[chip]])
    size = np.concatenate([sizes[keep], np.ones(len(member), np.int64)])
    members = np.concatenate([bp.members[keep[sphere_of]], member])
    order = np.argsort(body, kind="stable")  # each body's spheres together, in body order
    start = np.r_[0, np.cumsum(size[order])].astype(np.int64)
    old_first = np.r_[0, np.cumsum(size)[:-1]]  # each sphere's first entry in `members` before the reorder
    entry = np.repeat(old_first[order] - start[:-1], size[order]) + np.arange(start[-1])
    faces = None
    if bp.member_faces is not None:  # a corner sphere's member: its faces are not read (corners are never kept)
        faces = np.concatenate([bp.member_faces[keep[sphere_of]], np.zeros(len(member), np.uint8)])[entry]
    return BoundaryParticles(
        position=np.concatenate([bp.position[keep], pos])[order],
        radius=np.concatenate([bp.radius[keep], rad])[order],
        mass=np.concatenate([bp.mass[keep], m])[order],
        body=body[order].astype(np.int32),
        member_start=start,
        members=members[entry],
        member_faces=faces,
        corner=np.r_[np.zeros(int(keep.sum()), bool), np.ones(len(pos), bool)][order],
    )


def free_face_normals(rest_verts: np.ndarray, free_faces: np.ndarray, centroid: np.ndarray):
    """Per particle: the sum of its free faces' outward unit normals, and the largest distance from
    its centroid to a free face plane (0 without free faces). Only the free faces are computed (a
    surface particle has one or two of its four)."""
    from geometry.tetmesh import TET_FACES

    p, f = np.nonzero(free_faces)  # particle ascending, then face: each particle's faces in face order
    tri = rest_verts[p[:, None], TET_FACES[f]]  # (F, 3, 3)
    n = cross3(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    depth = np.zeros(free_faces.shape)
    depth[p, f] = np.einsum("fk,fk->f", n, tri[:, 0] - centroid[p])
    count = len(free_faces)
    normal_sum = np.stack([np.bincount(p, weights=n[:, a], minlength=count) for a in range(3)], 1)
    return normal_sum, depth.max(1)


def _pull_inside(c, rad, g, start, x, rest_verts, free_faces):
    normal_sum, depth = free_face_normals(rest_verts, free_faces, x)
    ng = len(c)
    n = np.stack([np.bincount(g, weights=normal_sum[:, a], minlength=ng) for a in range(3)], 1)
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    ok = norm[:, 0] > 1e-12
    n = np.where(ok[:, None], n / np.maximum(norm, 1e-300), 0.0)
    # distance from the centre to the surface along the group's normal
    reach = np.maximum.reduceat(np.einsum("ij,ij->i", n[g], x - c[g]) + depth, start[:-1])
    # a one-particle sphere is the particle itself (it protrudes by about 0.1 tet edge): kept as is
    single = np.diff(start) == 1
    shift = np.where(ok & ~single, np.maximum(rad - reach, 0.0), 0.0)
    return c - shift[:, None] * n


def _group_spheres(gid: np.ndarray, start: np.ndarray, x: np.ndarray, r: np.ndarray, w: np.ndarray):
    """Centres, radii and masses of the groups `gid` (sorted; group k's rows start[k]:start[k + 1])."""
    ng = len(start) - 1
    count = np.diff(start).astype(np.float64)
    wsum = np.bincount(gid, weights=w, minlength=ng)
    # mean position (the paper's "average position"), equal weights
    c = np.stack([np.bincount(gid, weights=x[:, a], minlength=ng) for a in range(3)], 1) / count[:, None]
    reach = np.linalg.norm(x - c[gid], axis=1) + r
    rad = np.maximum(np.maximum.reduceat(reach, start[:-1]), 0.0)
    return c, rad, wsum
