"""The paper's own tetrahedralization (Sect. 5.1): Delaunay of surface samples and layered interior
samples, for anisotropic objects whose vertices must lie in layers normal to the material axis.

The kept mesher (geometry.netgen_mesher) cannot place vertices on prescribed layers, so this path
remains for `layer_axis`; everything else is meshed by Netgen. Steps, all vectorised:
1. Surface samples about `h` apart from the shape (creases sampled exactly).
2. Interior samples: layers normal to the material axis (the paper's layered sampling of
   anisotropic objects), jittered by a seeded random offset of `JITTER` x h to break co-spherical
   ties; points closer than `SURFACE_GAP` x h to the surface are dropped.
3. scipy Delaunay; keep tets whose centroid lies inside the solid.
4. Sliver removal: tets with a free face and a radius ratio below `SLIVER_RATIO` are peeled off
   the surface, repeatedly; interior tets are never removed (that would break conformity).
"""

from __future__ import annotations

import numpy as np

from core.errors import MeshError
from geometry.tetmesh import face_adjacency, signed_volumes

JITTER = 0.08  # interior sample jitter, fraction of h
SURFACE_GAP = 0.45  # interior samples nearer than this x h to the surface are dropped
SLIVER_RATIO = 0.05  # radius ratio (3 r_in / r_circ, 1 = regular) below which a surface tet is peeled


def _bcc_lattice(lo: np.ndarray, hi: np.ndarray, h: float) -> np.ndarray:
    axes = [np.arange(lo[a] - h, hi[a] + h, h) for a in range(3)]
    corners = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return np.concatenate([corners, corners + 0.5 * h])


def _layered_lattice(lo, hi, h, axis: np.ndarray, layer_spacing: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0, 0]) if abs(axis[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    centre = 0.5 * (lo + hi)
    reach = 0.5 * np.linalg.norm(hi - lo) + h
    s = h * np.arange(-np.ceil(reach / h), np.ceil(reach / h) + 1)
    t = layer_spacing * np.arange(-np.ceil(reach / layer_spacing), np.ceil(reach / layer_spacing) + 1)
    a, b, c = np.meshgrid(s, s, t, indexing="ij")
    pts = centre + a.reshape(-1, 1) * u + b.reshape(-1, 1) * v + c.reshape(-1, 1) * axis
    inside_box = np.all((pts >= lo - h) & (pts <= hi + h), axis=1)
    return pts[inside_box]


def project_to_surface(shape, h: float, iterations: int = 6) -> np.ndarray:
    """Surface samples of a smooth implicit solid: lattice points near the surface moved onto it.

    Used by shapes without an explicit sampler (the figurine). Newton steps along the numerical
    gradient of the signed distance, then thinning to one point per cell of size 0.7 h.
    """
    from scipy.spatial import cKDTree  # here, not at the top: a run that does not mesh imports no scipy

    lo, hi = shape.bounds()
    fine = 0.5 * h
    pts = _bcc_lattice(lo, hi, fine)
    pts = pts + np.random.default_rng(7).uniform(-0.2 * fine, 0.2 * fine, pts.shape)
    pts = pts[np.abs(shape.sdf(pts)) < fine]
    eps = 1e-4 * h
    for _ in range(iterations):
        d = shape.sdf(pts)
        grad = np.stack(
            [(shape.sdf(pts + eps * e) - shape.sdf(pts - eps * e)) / (2 * eps) for e in np.eye(3)], 1
        )
        pts = pts - (d / np.maximum((grad * grad).sum(1), 1e-12))[:, None] * grad
    pts = pts[np.abs(shape.sdf(pts)) < 1e-6 * h]
    # thin to a minimum spacing of 0.6 h: drop the later point of every close pair, a few rounds
    for _ in range(8):
        pairs = cKDTree(pts).query_pairs(0.6 * h, output_type="ndarray")
        if len(pairs) == 0:
            break
        drop = np.zeros(len(pts), dtype=bool)
        drop[np.unique(pairs.max(1))] = True
        drop[np.unique(pairs.min(1))] = False  # keep the earlier point of each pair this round
        if not drop.any():
            drop[pairs[0, 1]] = True
        pts = pts[~drop]
    return pts


def _radius_ratio(p: np.ndarray) -> np.ndarray:
    vol = np.abs(signed_volumes(p))
    a, b, c = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]
    faces = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
    area = sum(0.5 * np.linalg.norm(np.cross(p[:, j] - p[:, i], p[:, k] - p[:, i]), axis=1) for i, j, k in faces)
    num = (
        (a * a).sum(1)[:, None] * np.cross(b, c)
        + (b * b).sum(1)[:, None] * np.cross(c, a)
        + (c * c).sum(1)[:, None] * np.cross(a, b)
    )
    circ = np.linalg.norm(num, axis=1) / np.maximum(12.0 * vol, 1e-300)
    inr = 3.0 * vol / np.maximum(area, 1e-300)
    return np.where(vol > 0, 3.0 * inr / np.maximum(circ, 1e-300), 0.0)


def _peel_surface_slivers(points: np.ndarray, tets: np.ndarray, name: str) -> tuple[np.ndarray, int]:
    """Remove surface tets (a face without neighbour) whose radius ratio is below SLIVER_RATIO,
    layer by layer (at most 50); returns (tets, number removed)."""
    removed = 0
    for _ in range(50):
        ratio = _radius_ratio(points[tets])
        adj = face_adjacency(tets, name)
        bad = (ratio < SLIVER_RATIO) & (adj < 0).any(1)
        if not bad.any():
            break
        removed += int(bad.sum())
        tets = tets[~bad]
    return tets, removed


def layered_delaunay(shape, h: float, seed: int, layer_axis, layer_spacing: float | None):
    """(verts (V, 3) m, tets (T, 4), counts) of `shape` with interior vertices in layers normal to
    `layer_axis`, `layer_spacing` (m, default h) apart. Same inputs and seed give identical meshes."""
    from scipy.spatial import Delaunay, cKDTree

    surface = shape.surface_samples(h)
    interior = _layered_lattice(*shape.bounds(), h, np.asarray(layer_axis, float), layer_spacing or h)
    rng = np.random.default_rng(seed)
    interior = interior + rng.uniform(-JITTER * h, JITTER * h, interior.shape)
    interior = interior[shape.sdf(interior) < -SURFACE_GAP * h]
    # also keep interior points clear of surface samples (the sdf of a crease under-reports)
    if len(interior):
        dist, _ = cKDTree(surface).query(interior)
        interior = interior[dist > SURFACE_GAP * h]
    points = np.concatenate([surface, interior])
    # QJ (joggle) keeps qhull fast on the co-planar samples of flat faces; the flat tets it leaves on
    # those faces are peeled below like any surface sliver.
    tets = Delaunay(points, qhull_options="Qbb Qc Q12 QJ").simplices.astype(np.int64)
    p = points[tets]
    flip = signed_volumes(p) < 0
    tets[flip] = tets[flip][:, [0, 2, 1, 3]]
    tets = tets[shape.sdf(p.mean(1)) < 0]
    name = getattr(shape, "name", "shape")
    tets, removed = _peel_surface_slivers(points, tets, name)
    if len(tets) == 0:
        raise MeshError(name, f"resolution {h:g} m is too coarse for this object: no tet lies inside it",
                        "use a resolution below the object's thickness")
    flat = np.flatnonzero(signed_volumes(points[tets]) <= 1e-12 * h**3)
    if flat.size:  # co-spherical samples left a flat tet inside: refuse rather than build a broken mesh
        raise MeshError(name, f"resolution {h:g} m leaves {flat.size} flat interior tets (co-spherical samples)",
                        "use a finer resolution, or another seed")
    counts = dict(surface_samples=int(len(surface)), interior_samples=int(len(interior)), slivers_removed=removed)
    return points, tets, counts


__all__ = ["layered_delaunay", "project_to_surface"]
