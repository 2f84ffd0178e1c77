"""Crack lines: where a crack face meets an object's outer surface, a thin ribbon lying on the outer
face (issue 14; the paper's Fig. 9 draws the cracks of a pane whose sectors stay in the frame).

Two pieces pressed together hide their crack faces: a held pane cut into six sectors, or a pot wall
cracked by a landing that did not separate it, looks whole in the faces' own colours. The line a crack
leaves on the surface is what an observer sees (light scatters at the fresh crack in glass; a dark
seam in an opaque body). It is the set of mesh edges an outer face shares with a crack face of the
same surface; each becomes a ribbon on its outer face: the strip of the face between the edge and the
parallel `width` away (a face narrower than that is covered whole; the strip's ends run along the
face's other two edges, so it stays inside the face), lifted `lift` along the face normal so that it
is drawn over the face and not depth-fought with it. The ribbons are triangles of the same body, so they
move with it. Pure numpy, no Taichi.
"""

from __future__ import annotations

import numpy as np

from core.arrays import unique_rows

LINE_WIDTH_REL = 0.12  # -: ribbon width as a share of the median edge of the objects' rest surface
LIFT_REL = 0.02  # -: ribbon lifted off its face by this share of the same edge
LINE_DARK = (0.10, 0.09, 0.08)  # -: linear RGB of a crack line on a light opaque body (a shadowed seam)
LINE_LIGHT = (0.90, 0.92, 0.94)  # -: on a dark or see-through body (fresh fracture faces scatter light)
DARK_BODY_LUMINANCE = 0.3  # -: below this luminance (or opacity < 1) a body gets the light line


def line_color(color, opacity: float) -> tuple:
    """Linear RGB of the crack lines on a body of this colour and opacity: the one that stands out."""
    luminance = float(np.dot([0.2126, 0.7152, 0.0722], np.asarray(color, dtype=np.float64)))
    return LINE_LIGHT if (opacity < 1.0 or luminance < DARK_BODY_LUMINANCE) else LINE_DARK


def rim_edges(faces: np.ndarray, outer: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Edges an outer face shares with a crack face. faces: (F, 3) vertex ids (outward, counter-clockwise
    seen from outside; vertices shared within a surface); outer: (F,) bool. Returns ((E, 2) vertex ids,
    directed as in the outer face, and (E,) the outer face of each edge)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    outer = np.asarray(outer, dtype=bool).reshape(-1)
    if len(faces) == 0 or outer.all() or not outer.any():
        return np.zeros((0, 2), np.int64), np.zeros(0, np.int64)
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)  # edge k of face f at row 3 f + k
    face = np.repeat(np.arange(len(faces)), 3)
    _, edge = unique_rows(np.sort(directed, axis=1), return_inverse=True)
    on_crack = np.bincount(edge, weights=~outer[face], minlength=int(edge.max()) + 1) > 0
    rows = np.flatnonzero(outer[face] & on_crack[edge])
    return directed[rows], face[rows]


def ribbons(verts: np.ndarray, faces: np.ndarray, outer: np.ndarray, width: float,
            lift: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ribbon triangles along the rim edges (module doc). Returns (verts (4E, 3) m, faces (2E, 3),
    (2E,) the outer face each ribbon triangle lies on); outward like the surface."""
    verts = np.asarray(verts, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    edges, face = rim_edges(faces, outer)
    if len(edges) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros(0, np.int64)
    a, b = verts[edges[:, 0]], verts[edges[:, 1]]
    c = verts[faces[face].sum(axis=1) - edges.sum(axis=1)]  # the face's third corner
    n = np.cross(b - a, c - a)
    area2 = np.linalg.norm(n, axis=1)  # twice the face's area
    n = n / np.maximum(area2, 1e-300)[:, None]
    height = area2 / np.maximum(np.linalg.norm(b - a, axis=1), 1e-300)  # of c over the edge
    share = np.minimum(1.0, width / np.maximum(height, 1e-300))[:, None]  # the strip's share of the height
    up = lift * n
    quad = np.stack([a + up, b + up, b + share * (c - b) + up, a + share * (c - a) + up], axis=1)  # (E, 4, 3)
    base = 4 * np.arange(len(edges))[:, None]
    tris = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]], axis=1).reshape(-1, 3)
    return quad.reshape(-1, 3), tris, np.repeat(face, 2)
