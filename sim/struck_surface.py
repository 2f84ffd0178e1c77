"""The struck surface at a contact, in the struck body's reference frame: where Algorithm 1 puts its
point P and its inward normal n, and the surface's radius of curvature there for Hertz's R1 (Sect. 4.2;
used by sim/fracture_stage.py for every impact and strike). The surface is the body's free tet faces (no
link across them) that face the other body.
"""

from __future__ import annotations

import math

import numpy as np

from core.arrays import cross3, unique_rows
from geometry.tetmesh import TET_FACES
from sph.contact import surface_radius

# The struck surface is smooth at the contact when the area-weighted mean of its facing faces' unit
# normals (within one tet edge) is at least this long: their mean deviation from the mean normal is
# under about 30 degrees. Below it an edge or a corner bears the blow (a disc landing on its rim's
# edge: 0.72-0.75; a curved pot wall: 0.998; a pane: 1.0) and the contact's normal is the load's.
SMOOTH_SURFACE_RATIO = math.cos(math.radians(30.0))
NEAR_PAD = 1e-9  # relative: distances of particles and of their faces round differently


def _surface_particles(ps, body: int) -> np.ndarray:
    """Rows of the body's particles with a free tet face (no link across it)."""
    return np.flatnonzero(ps.alive & (ps.body == body) & (ps.links < 0).any(1))


def _facing_faces(ps, rows: np.ndarray, point: np.ndarray, normal: np.ndarray):
    """The free tet faces of particles `rows` whose outward normal is against `normal` (the side a
    striker meets; a thin wall's far face is as near): (triangles (F,3,3) m relative to `point`,
    area-weighted outward normals (F,3), centroids (F,3)), or None where there is none. Each face's
    numbers depend on its own particle only, so a subset of rows gives those faces' rows exactly."""
    if rows.size == 0:
        return None
    tet, face = np.nonzero(ps.links[rows] < 0)
    v = ps.rest_verts[rows[tet]] - point  # (F,4,3) m: relative to the point (a scene far from 0 keeps its bits)
    tri = np.take_along_axis(v, TET_FACES[face][:, :, None], axis=1)  # (F,3,3)
    cen = tri.mean(1)
    an = 0.5 * cross3(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # area-weighted face normals
    opposite = v[np.arange(len(face)), face]
    flip = np.einsum("fi,fi->f", an, opposite - cen) > 0.0  # outward: away from the opposite vertex
    an[flip] *= -1.0
    facing = an @ normal < 0.0
    if not facing.any():
        return None
    return tri[facing], an[facing], cen[facing]


class SurfaceRows:
    """A body's surface particles (rows with a free face), their centroids and the farthest any of their
    tet vertices lies from its centroid (`spread`): what `surface_frame` and `surface_radius_at` search,
    made once for both (an analysis calls each once, at two points)."""

    def __init__(self, ps, body: int) -> None:
        self.rows = _surface_particles(ps, body)
        self.centroid = ps.centroid[self.rows]
        off = ps.rest_verts[self.rows] - self.centroid[:, None, :]
        self.spread = float(np.sqrt(np.einsum("nkj,nkj->nk", off, off).max())) if self.rows.size else 0.0

    def near(self, point: np.ndarray) -> _SurfaceNear:
        return _SurfaceNear(self, point)


class _SurfaceNear:
    """The body's surface particles by distance from a point, so that only those near it are cut into
    faces (a Pots fragment has thousands of surface particles; a contact patch is a few tet edges).
    A face centroid lies within `spread` of its particle's centroid (the farthest tet vertex), so a
    face of a particle farther than R + spread is farther than R (exact selections, see callers)."""

    def __init__(self, surface: SurfaceRows, point: np.ndarray) -> None:
        self.rows, self.spread = surface.rows, surface.spread
        self.dist = np.linalg.norm(surface.centroid - point, axis=1)

    def within(self, reach: float) -> np.ndarray:
        """Rows whose faces may lie within `reach` (m) of the point (padded against rounding)."""
        return self.rows[self.dist <= (reach + self.spread) * (1.0 + NEAR_PAD)]


def _nearest_patch(ps, body: int, point: np.ndarray, normal: np.ndarray, radius: float,
                   surface: SurfaceRows | None = None):
    """`_facing_faces` of the body's particles near `point`, holding the facing face nearest to the
    point and every face within `radius` of that one: the same faces, bit for bit, as over the whole
    body for `surface_frame`. Grows the selection until the nearest face found is certain."""
    near = (surface or SurfaceRows(ps, body)).near(point)
    if near.rows.size == 0:
        return None
    reach = float(near.dist.min()) + 2.0 * radius
    while True:
        rows = near.within(reach)
        faces = _facing_faces(ps, rows, point, normal)
        if rows.size == near.rows.size:
            return faces
        # a face not selected lies beyond `reach`: none nearer than the nearest found, none near it
        if faces is not None and float(np.linalg.norm(faces[2], axis=1).min()) + radius < reach * (1.0 - NEAR_PAD):
            return faces
        reach = 2.0 * reach + near.spread


def surface_frame(ps, body: int, point: np.ndarray, normal: np.ndarray, radius: float,
                  striker: np.ndarray | None = None, surface: SurfaceRows | None = None):
    """The struck surface at a contact (reference frame): (point on it, inward unit normal).

    The rigid solver's contact normal and point are impulse-weighted means over a few collision
    spheres: the normal can lean far off the surface (18 degrees on a pane struck square-on) and the
    point lies off the striker's axis and outside the tets, and Algorithm 1 builds its frame on them.
    The surface's own normal is the area-weighted mean of the outward normals of the body's free tet
    faces that face the striker (`_facing_faces`) and whose centroid lies within `radius` of the
    nearest such face. The point is the foot on that plane of the striker's centre (`striker`, a
    moving body; the first contact of a convex striker) or, for a collider, of the reported point.
    Falls back to the given point and normal where the body has no free face or its faces point away
    from the given normal, and keeps the given normal where an edge or a corner bears the blow (the
    faces' normals spread: SMOOTH_SURFACE_RATIO): a corner has no normal of its own, the other surface
    sets the load's direction (a floor's is exact), and the faces' mean would turn with which faces lie
    within one tet edge (14-46 degrees off the floor's for a disc landing on its rim at 76-82 degrees).
    `surface`: the body's SurfaceRows where the caller has them.
    """
    return _frame_of(_nearest_patch(ps, body, point, normal, radius, surface), point, normal, radius, striker)


def _frame_of(faces, point: np.ndarray, normal: np.ndarray, radius: float, striker: np.ndarray | None):
    """`surface_frame` from the facing faces (`_facing_faces`) that hold the nearest one's patch."""
    if faces is None:
        return point, normal
    _, an, cen = faces
    dist = np.linalg.norm(cen, axis=1)
    near = np.linalg.norm(cen - cen[int(np.argmin(dist))], axis=1) < radius
    an, cen = an[near], cen[near]
    total = an.sum(0)
    w = np.linalg.norm(an, axis=1)
    inward = -total / max(float(np.linalg.norm(total)), 1e-300)
    if np.linalg.norm(total) < 1e-3 * float(w.sum()) or float(np.dot(inward, normal)) <= 0.0:
        return point, normal
    plane = (w[:, None] * cen).sum(0) / w.sum()
    if np.linalg.norm(total) < SMOOTH_SURFACE_RATIO * float(w.sum()):  # an edge or a corner
        inward = np.asarray(normal, dtype=np.float64)
    foot = np.zeros(3) if striker is None else np.asarray(striker, dtype=np.float64) - point
    foot = foot - float(np.dot(foot - plane, inward)) * inward
    if np.linalg.norm(foot - plane) > radius + float(np.linalg.norm(plane)):
        foot = -float(np.dot(-plane, inward)) * inward  # striker centre far off the patch: the point's foot
    return point + foot, inward


def surface_radius_at(ps, body: int, point: np.ndarray, normal: np.ndarray, radius: float,
                      surface: SurfaceRows | None = None) -> float:
    """Radius of curvature (m) of the struck surface at `point` (on it; `normal` inward), for Hertz's
    R1: `sph.contact.surface_radius` fitted to the corners of the facing free faces within `radius`
    of the point; inf for a flat patch. `surface`: the body's SurfaceRows where the caller has them."""
    rows = (surface or SurfaceRows(ps, body)).near(point).within(radius)
    return _radius_of(_facing_faces(ps, rows, point, normal), point, normal, radius)


def _radius_of(faces, point: np.ndarray, normal: np.ndarray, radius: float) -> float:
    """`surface_radius_at` from the facing faces (`_facing_faces`) that hold all within `radius`."""
    if faces is None:
        return math.inf
    tri, _, cen = faces
    corners = tri[np.linalg.norm(cen, axis=1) < radius].reshape(-1, 3)
    return surface_radius(unique_rows(corners) + point, point, normal)


__all__ = ["SMOOTH_SURFACE_RATIO", "SurfaceRows", "surface_frame", "surface_radius_at"]
