"""Self-intersection guard for input surfaces (DESIGN.md promise 2: bad input gets a clear error).

`check_surface_overlap(vertices, faces, source)`: a closed, consistently wound surface can still
overlap itself (two intersecting shells in one file, a fold); the generalised winding number just
inside and just outside sampled faces must be 1 and 0. geometry.mesh_io calls it on every mesh it
reads; docs/robustness.md lists it in the envelope.
"""

from __future__ import annotations

import numpy as np

from core.errors import MeshError


def winding_numbers(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray, chunk: int = 64) -> np.ndarray:
    """Generalised winding number of a triangle surface at points (P, 3): the sum of the signed solid
    angles of the triangles (van Oosterom and Strackee 1983) over 4 pi. 1 inside a closed outward
    surface, 0 outside, 2 where two shells overlap, -1 inside an inverted one."""
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]  # (F, 3, 3)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    out = np.empty(len(pts))
    for s in range(0, len(pts), chunk):
        d = tri[None] - pts[s:s + chunk, None, None, :]  # (p, F, 3, 3)
        a, b, c = d[..., 0, :], d[..., 1, :], d[..., 2, :]
        la, lb, lc = (np.linalg.norm(v, axis=-1) for v in (a, b, c))
        num = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc + np.einsum("pfi,pfi->pf", b, c) * la
               + np.einsum("pfi,pfi->pf", c, a) * lb)
        out[s:s + chunk] = 2.0 * np.arctan2(num, den).sum(1) / (4.0 * np.pi)
    return out


def check_surface_overlap(vertices: np.ndarray, faces: np.ndarray, source: str, max_faces: int = 256,
                          offset_rel: float = 1e-4) -> None:
    """Refuse a surface whose winding number just inside (outside) sampled faces is not 1 (0).

    Detects overlapping shells, folds and pockets whose volume is counted twice or negatively
    (the mesh validation of geometry.mesh_io checks closure and winding, not self-intersection).
    Up to `max_faces` faces are probed (a fixed stride, deterministic), `offset_rel` x the bounding
    box diagonal off their centroids. Touching without overlap is not detected.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    tri = v[f]
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(nrm, axis=1)
    probe = np.flatnonzero(area2 > 0.0)
    if probe.size > max_faces:
        probe = probe[np.linspace(0, probe.size - 1, max_faces).astype(np.int64)]
    diag = float(np.linalg.norm(np.ptp(v, axis=0)))
    delta = offset_rel * diag
    c = tri[probe].mean(1)
    n = nrm[probe] / area2[probe, None]
    w_in = winding_numbers(v, f, c - delta * n)
    w_out = winding_numbers(v, f, c + delta * n)
    bad = np.flatnonzero((np.abs(w_in - 1.0) > 0.5) | (np.abs(w_out) > 0.5))
    if bad.size:
        k = int(bad[0])
        raise MeshError(
            source, "self-intersecting surface (overlapping or folded shells)",
            f"winding number {w_in[k]:.3g} inside and {w_out[k]:.3g} outside face {int(probe[k])}, "
            f"expected 1 and 0; {bad.size} of {probe.size} probed faces",
        )


def wall_thickness(vertices: np.ndarray, faces: np.ndarray, samples: int = 400) -> np.ndarray:
    """(S,) m: the wall thickness at up to `samples` faces (a fixed stride, deterministic): the distance
    from each face's centre, inwards along its normal, to the next face the ray meets (trimesh's ray
    test). A solid box gives its sizes, a pot its wall; Eq. 11's B for a mesh file and the check that
    a part is not too thin for the tet size."""
    import trimesh

    mesh = trimesh.Trimesh(np.asarray(vertices, np.float64), np.asarray(faces, np.int64), process=False)
    pick = np.unique(np.linspace(0, len(mesh.faces) - 1, min(samples, len(mesh.faces))).astype(np.int64))
    normal = mesh.face_normals[pick]
    start = mesh.triangles_center[pick]
    hits, rays, _ = mesh.ray.intersects_location(start, -normal, multiple_hits=True)
    dist = np.linalg.norm(hits - start[rays], axis=1)
    far = dist > 1e-6 * float(np.ptp(mesh.vertices, axis=0).max())  # not the face the ray leaves from
    out = np.full(len(pick), np.inf)
    np.minimum.at(out, rays[far], dist[far])
    return out[np.isfinite(out)]
