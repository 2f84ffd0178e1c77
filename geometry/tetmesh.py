"""Tetrahedral meshes: the container, orientation, face adjacency and validation (Sect. 5.1).

Face convention used everywhere in the project: face k of tet (v0, v1, v2, v3) is the face
opposite vertex k, listed in `TET_FACES[k]` so that its normal (right-hand rule) points out of a
positively oriented tet (det[v1-v0, v2-v0, v3-v0] > 0).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.arrays import cross3, unique_rows
from core.errors import MeshError

TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], dtype=np.int64)


def signed_volumes(points: np.ndarray) -> np.ndarray:
    """Signed volumes (m^3) of tets given as (T, 4, 3) vertex coordinates."""
    a = points[:, 1] - points[:, 0]
    b = points[:, 2] - points[:, 0]
    c = points[:, 3] - points[:, 0]
    return np.einsum("ij,ij->i", a, cross3(b, c)) / 6.0


def face_areas_normals(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Areas (T, 4) m^2 and unit normals (T, 4, 3) of the face opposite each vertex of tets given as
    (T, 4, 3) vertex coordinates (outward for positively oriented tets, TET_FACES)."""
    faces = points[:, TET_FACES]  # (T, 4, 3, 3): face i is opposite vertex i
    cross = cross3(faces[:, :, 1] - faces[:, :, 0], faces[:, :, 2] - faces[:, :, 0])
    twice = np.linalg.norm(cross, axis=2)
    return 0.5 * twice, cross / np.maximum(twice, 1e-300)[..., None]


def insphere(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Incentres (T,3) m and inradii (T,) m of tets given as (T, 4, 3) vertex coordinates:
    I = sum_i A_i v_i / sum A_i (A_i: the area of the face opposite vertex i), r = 3 |V| / sum A_i."""
    area, _ = face_areas_normals(points)
    total = area.sum(1)
    return np.einsum("ti,tij->tj", area, points) / total[:, None], 3.0 * np.abs(signed_volumes(points)) / total


@dataclass
class TetMesh:
    """A conforming tetrahedral mesh of one solid object, in metres."""

    verts: np.ndarray  # (V, 3) m: vertex positions
    tets: np.ndarray  # (T, 4) int: vertex indices, positively oriented
    tet_region: np.ndarray = field(default=None)  # (T,) int: region / material slot (0 if one material)
    source: str = "<generated>"  # file name or shape description, for messages

    def __post_init__(self) -> None:
        self.verts = np.ascontiguousarray(self.verts, dtype=np.float64)
        self.tets = np.ascontiguousarray(self.tets, dtype=np.int64)
        if self.tet_region is None:
            self.tet_region = np.zeros(len(self.tets), dtype=np.int32)
        self.tet_region = np.ascontiguousarray(self.tet_region, dtype=np.int32)

    @property
    def tet_points(self) -> np.ndarray:
        """(T, 4, 3) m: the four vertex positions of each tet."""
        return self.verts[self.tets]

    @property
    def volumes(self) -> np.ndarray:
        """(T,) m^3: signed tet volumes (positive for a valid mesh)."""
        return signed_volumes(self.tet_points)

    @property
    def volume(self) -> float:
        return float(self.volumes.sum())


def face_adjacency(tets: np.ndarray, source: str = "<mesh>") -> np.ndarray:
    """Neighbour across each face: (T, 4) int, `adj[t, k]` = tet sharing face k of t, or -1.

    Raises MeshError when a face is shared by more than two tets (non-manifold tet mesh).
    """
    n = len(tets)
    faces = np.sort(tets[:, TET_FACES].reshape(-1, 3), axis=1)  # (4T, 3)
    _, inverse, counts = unique_rows(faces, return_inverse=True, return_counts=True)
    if counts.size and counts.max() > 2:
        bad = int(np.argmax(counts[inverse] > 2))
        raise MeshError(
            source,
            "non-manifold tetrahedral mesh",
            f"{int((counts > 2).sum())} faces shared by more than two tets; first is face "
            f"{bad % 4} of tet {bad // 4}",
        )
    order = np.argsort(inverse, kind="stable")
    sorted_keys = inverse[order]
    pair_start = np.flatnonzero(sorted_keys[1:] == sorted_keys[:-1])
    a = order[pair_start]
    b = order[pair_start + 1]
    adj = np.full(4 * n, -1, dtype=np.int64)
    adj[a] = b // 4
    adj[b] = a // 4
    return adj.reshape(n, 4)


def boundary_faces(tets: np.ndarray, adjacency: np.ndarray) -> np.ndarray:
    """(F, 3) int: outward-oriented faces with no neighbour across (the surface of the mesh)."""
    t, k = np.nonzero(adjacency < 0)
    return tets[t[:, None], TET_FACES[k]]


def validate_tets(mesh: TetMesh, repair: bool = False) -> list[str]:
    """Check a tet mesh before use; return the repairs made (only when `repair`).

    Errors name the source, the problem and the count and first index: non-finite coordinates,
    indices out of range, repeated vertices in a tet, zero-volume tets, inverted tets (all of them:
    the file lists its tets inside out) and mixed orientation. With `repair`, inverted tets are
    flipped and the fix is reported instead of raised; zero-volume tets are never repaired.
    """
    src = mesh.source
    repairs: list[str] = []
    if len(mesh.tets) == 0:
        raise MeshError(src, "no tetrahedra")
    if not np.all(np.isfinite(mesh.verts)):
        bad = np.flatnonzero(~np.all(np.isfinite(mesh.verts), axis=1))
        raise MeshError(src, "non-finite vertex coordinates", f"{len(bad)} vertices, first index {bad[0]}")
    if mesh.tets.min() < 0 or mesh.tets.max() >= len(mesh.verts):
        bad = np.flatnonzero((mesh.tets < 0).any(1) | (mesh.tets >= len(mesh.verts)).any(1))
        raise MeshError(src, "vertex index out of range", f"{len(bad)} tets, first index {bad[0]}")
    s = np.sort(mesh.tets, axis=1)
    rep = np.flatnonzero((s[:, 1:] == s[:, :-1]).any(1))
    if rep.size:
        raise MeshError(src, "tets with a repeated vertex", f"{rep.size} tets, first index {rep[0]}")
    vol = mesh.volumes
    edge = np.linalg.norm(mesh.verts[mesh.tets[:, 1]] - mesh.verts[mesh.tets[:, 0]], axis=1)
    scale = max(float(np.median(edge)) ** 3, np.finfo(float).tiny)
    zero = np.flatnonzero(np.abs(vol) <= 1e-12 * scale)
    if zero.size:
        raise MeshError(src, "zero-volume tets", f"{zero.size} tets, first index {zero[0]}")
    neg = np.flatnonzero(vol < 0)
    if neg.size:
        if repair:
            mesh.tets[neg] = mesh.tets[neg][:, [0, 2, 1, 3]]
            repairs.append(f"flipped {neg.size} inverted tets (first index {neg[0]})")
        elif neg.size == len(vol):
            raise MeshError(src, "inverted tets (the whole mesh is inside out)", f"{neg.size} tets")
        else:
            raise MeshError(
                src,
                "mixed orientation: inverted tets",
                f"{neg.size} of {len(vol)} tets, first index {neg[0]}; pass repair=True to flip them",
            )
    face_adjacency(mesh.tets, src)
    return repairs


def quality_report(mesh: TetMesh) -> dict:
    """Tet quality: count, min/max volume, worst radius ratio (1 = regular, 0 = flat) and dihedral."""
    p = mesh.tet_points
    vol = signed_volumes(p)
    areas, unit = face_areas_normals(p)  # (T, 4), (T, 4, 3)
    inradius = 3.0 * vol / areas.sum(1)
    # circumradius from the standard formula |a^2 (b x c) + b^2 (c x a) + c^2 (a x b)| / (12 V)
    a, b, c = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]
    num = (
        (a * a).sum(1)[:, None] * cross3(b, c)
        + (b * b).sum(1)[:, None] * cross3(c, a)
        + (c * c).sum(1)[:, None] * cross3(a, b)
    )
    circum = np.linalg.norm(num, axis=1) / np.maximum(12.0 * np.abs(vol), 1e-300)
    ratio = 3.0 * inradius / circum
    pairs = [(i, j) for i in range(4) for j in range(i + 1, 4)]
    dihedral = np.stack(
        [np.degrees(np.pi - np.arccos(np.clip((unit[:, i] * unit[:, j]).sum(1), -1, 1))) for i, j in pairs],
        axis=1,
    )
    return {
        "tets": int(len(vol)),
        "vertices": int(len(mesh.verts)),
        "volume_m3": float(vol.sum()),
        "min_tet_volume_m3": float(vol.min()),
        "max_tet_volume_m3": float(vol.max()),
        "worst_radius_ratio": float(ratio.min()),
        "mean_radius_ratio": float(ratio.mean()),
        "min_dihedral_deg": float(dihedral.min()),
        "max_dihedral_deg": float(dihedral.max()),
    }
