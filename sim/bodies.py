"""Host-side facts about the World's rigid bodies that the physics packages do not keep: which scene
object a body came from, whether it may break, its thickness B for Eq. 11, its crack history and the
groups of its boundary spheres (by store particle id, so that its next split keeps those it leaves
whole: geometry/boundary.py, "Groups kept through a split")."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class SphereGroups:
    """A body's boundary-sphere groups by store particle id."""

    member_start: np.ndarray  # (G + 1,) int64: CSR offsets into `members`
    members: np.ndarray  # (M,) int64: store ids of each group's particles, ascending within a group
    member_faces: np.ndarray  # (M,) uint8: their free faces when the group was made (bit k: face k)
    position: np.ndarray  # (G, 3) m: each group's sphere, reference frame
    radius: np.ndarray  # (G,) m
    mass: np.ndarray  # (G,) kg


def sphere_groups(bp, store_ids: np.ndarray, body: int) -> SphereGroups | None:
    """The groups of body `body`'s spheres in `bp` (geometry.boundary.BoundaryParticles, bodies in
    order, members as positions in `store_ids`: the store id of each position); None where its
    spheres are a chip's corners or no free faces were given (nothing to keep)."""
    lo, hi = np.searchsorted(bp.body, [body, body + 1])
    if bp.member_faces is None or bp.corner is None or bp.corner[lo:hi].any():
        return None
    a, b = bp.member_start[lo], bp.member_start[hi]
    return SphereGroups(bp.member_start[lo:hi + 1] - a, np.asarray(store_ids)[bp.members[a:b]],
                        bp.member_faces[a:b].copy(), bp.position[lo:hi].copy(), bp.radius[lo:hi].copy(),
                        bp.mass[lo:hi].copy())


def kept_groups(groups: SphereGroups | None, store_ids: np.ndarray):
    """`groups` as geometry.boundary.KeptGroups over positions whose store ids are `store_ids`
    (ascending): a member no longer among them is -1. None without groups."""
    if groups is None:
        return None
    from geometry.boundary import KeptGroups

    store_ids = np.asarray(store_ids, np.int64)
    pos = np.searchsorted(store_ids, groups.members)
    there = pos < len(store_ids)
    there[there] = store_ids[pos[there]] == groups.members[there]
    return KeptGroups(groups.member_start, np.where(there, pos, -1), groups.member_faces, groups.position,
                      groups.radius, groups.mass)


@dataclass
class BodyInfo:
    """Host-side facts about a simulated body (index = rigid body id)."""

    object_index: int  # index into scene.objects
    breakable: bool
    static: bool
    thickness: float  # m: the object's thickness B (Eq. 11)
    resolution: float  # m: tet size the object was built at
    history: list = field(default_factory=list)  # cracks already applied (reference frame)
    bounds: tuple = ()  # (lo, hi) m: rest bounding box of the object the body came from
    spheres: SphereGroups | None = None  # its boundary spheres' groups (None: its next split groups anew)
