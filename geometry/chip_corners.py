"""Boundary spheres of a chip: its corners (a departure from Sect. 5.3; docs/decisions.md, "A chip
rests on its corners").

The paper's boundary spheres (geometry/boundary.py) of a body of a few particles lie on a line: one or
two spheres, or a chain. Such a body touches a plane along that line and rolls on it without losing
energy, for ever (a 2 mm chip of the pot rolled at 0.11 m/s, spinning at 93 rad/s, 10 s after the
drop; a chain of three rocked at 0.15 rad/s, above the sleep speed). A chip's spheres are put at
its corners instead: the vertices of its convex hull (at most CHIP_CORNERS; beyond, its support points
along eight diagonal directions of its principal axes, which keep its centre of mass inside them): it
comes to rest on a face, as the polyhedron it is.
Each corner sphere passes through its vertex, centred towards its tet's incentre, of CORNER_SCALE x
that tet's inradius (about 0.05 tet edge): at a sharp corner it pokes out of the faces by less than
its radius, so a chip lying on a face stands that little above the floor (a 4 mm cube of six tets,
0.1 mm); spheres twice as large centred inside the corners (tangent to the tet's faces there) left
the cube tilted, its corners 0.7 mm into the floor. The chip's mass is split evenly over its corner
spheres (the spheres' masses still add up to the body's). A loop over chips, not particles: a split
makes a few.
"""

from __future__ import annotations

import numpy as np

from geometry.tetmesh import insphere

CHIP_CORNERS = 8  # corner spheres of a chip at most (a tet has 4, two 5, a cube of six 8)
CORNER_SCALE = 0.25  # -: a corner sphere's radius in its tet's inradius (about 0.05 tet edge)
# the eight diagonal directions of a cube: they span space positively, so the support points of a
# convex body in these directions surround its centre
DIAGONALS = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)]) / np.sqrt(3.0)


def on_a_line(body: np.ndarray, position: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """(B,) bool per sphere: its body's sphere centres lie within their mean radius of one line (the
    principal axis through their mean), as one or two spheres always do."""
    nb = int(body.max(initial=-1)) + 1
    count = np.maximum(np.bincount(body, minlength=nb), 1).astype(np.float64)
    mean = np.stack([np.bincount(body, weights=position[:, a], minlength=nb) for a in range(3)], 1) / count[:, None]
    d = position - mean[body]
    cov = np.zeros((nb, 3, 3))
    for a in range(3):
        for b in range(3):
            cov[:, a, b] = np.bincount(body, weights=d[:, a] * d[:, b], minlength=nb)
    axis = np.linalg.eigh(cov)[1][:, :, 2]  # (nb, 3): the principal axis
    off = np.linalg.norm(d - np.einsum("ij,ij->i", d, axis[body])[:, None] * axis[body], axis=1)
    farthest = np.zeros(nb)
    np.maximum.at(farthest, body, off)
    r_mean = np.bincount(body, weights=radius, minlength=nb) / count
    return (farthest < r_mean)[body]


def _corners(verts: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Indices into `verts` (a chip's tet vertices, (4k,3)) of its corners: the distinct vertices of
    its convex hull, or, beyond CHIP_CORNERS of them, its support points along the eight diagonals of
    its principal axes about `centre` (its centre of mass stays inside them)."""
    from scipy.spatial import ConvexHull, QhullError

    _, first = np.unique(verts, axis=0, return_index=True)
    try:
        hull = first[ConvexHull(verts[first]).vertices]
    except QhullError:  # vertices (nearly) in one plane: every one is a corner candidate
        hull = first
    if len(hull) <= CHIP_CORNERS:
        return hull
    d = verts[hull] - centre
    axes = np.linalg.eigh(d.T @ d)[1]  # (3,3): columns, the principal axes
    return hull[np.unique(np.argmax(d @ axes @ DIAGONALS.T, axis=0))]


def chip_corners(particles: list[np.ndarray], rest_verts: np.ndarray, mass: np.ndarray):
    """Corner spheres of chips, each chip given as the particle ids of its spheres' members:
    (centres (K,3) m, radii (K,) m, masses (K,) kg, member particle (K,), chip index (K,))."""
    out = []
    for c, ids in enumerate(particles):
        verts = rest_verts[ids].reshape(-1, 3)
        corner = _corners(verts, mass[ids] @ rest_verts[ids].mean(1) / mass[ids].sum())
        tet = ids[corner // 4]
        centre, r_in = insphere(rest_verts[tet])
        v = verts[corner]
        towards = (centre - v) / np.linalg.norm(centre - v, axis=1, keepdims=True)
        r_c = CORNER_SCALE * r_in
        out.append((v + r_c[:, None] * towards, r_c,
                    np.full(len(corner), mass[ids].sum() / len(corner)), tet, np.full(len(corner), c)))
    return tuple(np.concatenate(parts) for parts in zip(*out))
