"""Picking for the interactive viewer: the surface point under the cursor (numpy only, no window).

The cursor gives a world ray (`Camera.ray`, the inverse of GGUI's `clip = [p, 1] @ V @ P`,
docs/notes_render.md); the ray is intersected with every drawn triangle at once (Moller-Trumbore,
vectorised) and the nearest hit in front of the eye wins. The triangles are the world corners the
`RenderScene` transform kernel wrote this frame, so picking sees exactly what is drawn.

GGUI's `window.get_cursor_pos()` is (x, y) in [0, 1] with y measured from the BOTTOM of the window
(measured under Xvfb: a pointer 50 px below the top of a 480 px window reads y = 0.896).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from render.camera import Camera

PARALLEL_EPS = 1e-12  # -: |det| (relative to the edge lengths) below which a ray is parallel to a triangle


@dataclass
class Hit:
    """The nearest triangle a ray meets (world frame)."""

    point: np.ndarray  # (3,) m: hit point
    normal: np.ndarray  # (3,) -: unit face normal on the side the ray came from (outward for a closed surface)
    body: int  # body id of the triangle (-1: static geometry such as the floor)
    triangle: int  # index of the triangle in the array given
    distance: float  # m: distance from the ray origin (the ray direction is unit)


def cursor_pixels(cursor: tuple[float, float], width: int, height: int) -> tuple[float, float]:
    """GGUI cursor (x, y in [0, 1], y from the bottom) -> continuous pixel position (x right, y down)."""
    return float(cursor[0]) * width, (1.0 - float(cursor[1])) * height


def ray_triangles(origin, direction, tris: np.ndarray) -> np.ndarray:
    """(T,) distance t >= 0 along the ray to each triangle of `tris` (T, 3, 3), inf where it misses
    (Moller-Trumbore; edges and corners count as hits)."""
    o = np.asarray(origin, dtype=np.float64).reshape(3)
    d = np.asarray(direction, dtype=np.float64).reshape(3)
    tris = np.asarray(tris, dtype=np.float64).reshape(-1, 3, 3)
    t = np.full(len(tris), np.inf)
    if len(tris) == 0:
        return t
    a = tris[:, 0]
    e1 = tris[:, 1] - a
    e2 = tris[:, 2] - a
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    scale = np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
    ok = np.abs(det) > PARALLEL_EPS * np.maximum(scale, 1e-300)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = o - a
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    v = (q @ d) * inv
    tt = np.einsum("ij,ij->i", e2, q) * inv
    tol = 1e-12
    hit = ok & (u >= -tol) & (v >= -tol) & (u + v <= 1.0 + tol) & (tt >= 0.0)
    t[hit] = tt[hit]
    return t


def ray_cast(origin, direction, tris: np.ndarray, bodies: np.ndarray | None = None,
             t_min: float = 0.0) -> Hit | None:
    """Nearest hit of the ray (origin, unit direction) with triangles (T, 3, 3) beyond t_min (m), or None.
    `bodies` (T,) gives each triangle's body id (default -1)."""
    tris = np.asarray(tris, dtype=np.float64).reshape(-1, 3, 3)
    t = ray_triangles(origin, direction, tris)
    t[t < t_min] = np.inf
    if not len(t) or not np.isfinite(t.min()):
        return None
    k = int(np.argmin(t))
    d = np.asarray(direction, dtype=np.float64).reshape(3)
    n = np.cross(tris[k, 1] - tris[k, 0], tris[k, 2] - tris[k, 0])
    n /= np.linalg.norm(n)
    if n @ d > 0.0:  # a back face: report the side the ray came from
        n = -n
    body = -1 if bodies is None else int(np.asarray(bodies).reshape(-1)[k])
    return Hit(point=np.asarray(origin, dtype=np.float64) + t[k] * d, normal=n, body=body, triangle=k,
               distance=float(t[k]))


def scene_triangles(scene) -> tuple[np.ndarray, np.ndarray]:
    """World triangles (T, 3, 3) and their body ids (T,) from a RenderScene (host copy of this frame's
    transformed corners: call after `scene.update()`)."""
    n = scene.n_tris
    if n == 0:
        return np.zeros((0, 3, 3)), np.zeros(0, np.int64)
    x = scene.corner_x.to_numpy()[: 3 * n].reshape(n, 3, 3).astype(np.float64)
    body = scene.corner_body.to_numpy()[0 : 3 * n : 3].astype(np.int64)
    return x, body


def pick(tris: np.ndarray, bodies: np.ndarray, camera: Camera, x_px: float, y_px: float, width: int,
         height: int) -> Hit | None:
    """The surface point under pixel (x_px, y_px) (from the top-left corner), seen by `camera`."""
    origin, direction = camera.ray(x_px, y_px, width, height)
    return ray_cast(origin, direction, tris, bodies, t_min=camera.near)
