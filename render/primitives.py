"""Small closed meshes for drawing colliders, floors and test scenes (outward, counter-clockwise faces)."""

from __future__ import annotations

import numpy as np

# faces of the unit cube with corners indexed by bits (x, y, z) = (i & 1, i >> 1 & 1, i >> 2 & 1)
_BOX_FACES = np.array(
    [
        [0, 4, 6], [0, 6, 2],  # -x
        [1, 3, 7], [1, 7, 5],  # +x
        [0, 1, 5], [0, 5, 4],  # -y
        [2, 6, 7], [2, 7, 3],  # +y
        [0, 2, 3], [0, 3, 1],  # -z
        [4, 5, 7], [4, 7, 6],  # +z
    ],
    dtype=np.int64,
)  # fmt: skip


def box_mesh(half_extents, center=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """(verts (8, 3), faces (12, 3)) of an axis-aligned box (m), faces outward."""
    h = np.asarray(half_extents, dtype=np.float64).reshape(3)
    c = np.asarray(center, dtype=np.float64).reshape(3)
    bits = np.arange(8)
    signs = np.stack([bits & 1, (bits >> 1) & 1, (bits >> 2) & 1], 1) * 2.0 - 1.0
    return c + signs * h, _BOX_FACES.copy()


def ground_quad(height: float = 0.0, half_size: float = 1.0, center_xz=(0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """(verts (4, 3), faces (2, 3)) of a horizontal square at y = height (m), normal +y."""
    cx, cz = center_xz
    s = half_size
    v = np.array([[cx - s, height, cz - s], [cx + s, height, cz - s], [cx + s, height, cz + s],
                  [cx - s, height, cz + s]])
    return v, np.array([[0, 2, 1], [0, 3, 2]], dtype=np.int64)


def sphere_mesh(radius: float, center=(0.0, 0.0, 0.0), points: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """(verts, faces) of a closed polyhedron inscribed in a sphere (m): the convex hull of a Fibonacci
    lattice of `points` points, faces turned outward."""
    from scipy.spatial import ConvexHull

    k = np.arange(points) + 0.5
    polar = np.arccos(1.0 - 2.0 * k / points)
    azimuth = np.pi * (1.0 + 5.0**0.5) * k
    unit = np.stack([np.sin(polar) * np.cos(azimuth), np.cos(polar), np.sin(polar) * np.sin(azimuth)], 1)
    faces = ConvexHull(unit).simplices.astype(np.int64)
    a, b, c = unit[faces[:, 0]], unit[faces[:, 1]], unit[faces[:, 2]]
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), a + b + c) < 0.0
    faces[inward] = faces[inward][:, [0, 2, 1]]
    return np.asarray(center, dtype=np.float64) + radius * unit, faces
