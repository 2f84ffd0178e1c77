"""Fragment meshes to OBJ / PLY files (DESIGN.md section 7: fragment meshes on request).

Plain writers (no dependency): OBJ as text, PLY as binary little-endian with float64 vertices so
exported surfaces keep the exact coordinates they were built with. Every file is written to a
temporary name in the target folder and renamed, so an interrupted run never leaves a half-written
file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.errors import ConfigError
from core.output import atomic_write_bytes
from geometry.surface import SurfaceMesh

FORMATS = ("obj", "ply")


def _atomic_write(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, data)


def _check(verts: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    verts = np.asarray(verts, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(faces) and (faces.min() < 0 or faces.max() >= len(verts)):
        raise ConfigError("mesh.faces", f"index range {faces.min()}..{faces.max()}", f"0..{len(verts) - 1}")
    return verts, faces


def obj_bytes(verts: np.ndarray, faces: np.ndarray) -> bytes:
    """Wavefront OBJ text (1-based indices), coordinates with 17 significant digits."""
    verts, faces = _check(verts, faces)
    vlines = "\n".join(" ".join(("v", *(f"{c:.17g}" for c in row))) for row in verts.tolist())
    flines = "\n".join(f"f {a} {b} {c}" for a, b, c in (faces + 1).tolist())
    return (vlines + "\n" + flines + "\n").encode()


def ply_bytes(verts: np.ndarray, faces: np.ndarray) -> bytes:
    """Binary little-endian PLY: double x y z, faces as uchar count + int32 indices."""
    verts, faces = _check(verts, faces)
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment anisofrac fragment surface\n"
        f"element vertex {len(verts)}\nproperty double x\nproperty double y\nproperty double z\n"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode()
    rec = np.empty(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    rec["n"] = 3
    rec["i"] = faces
    return header + verts.astype("<f8").tobytes() + rec.tobytes()


def write_mesh(path: str | Path, verts: np.ndarray, faces: np.ndarray) -> Path:
    """Write one triangle mesh; the format follows the suffix (.obj or .ply)."""
    path = Path(path)
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise ConfigError("export.format", path.suffix, "'.obj' or '.ply'", source=str(path))
    data = obj_bytes(verts, faces) if fmt == "obj" else ply_bytes(verts, faces)
    _atomic_write(path, data)
    return path


def write_fragments(
    folder: str | Path, mesh: SurfaceMesh, fmt: str = "obj", stem: str = "fragment"
) -> list[Path]:
    """One file per fragment: <folder>/<stem>_<label:04d>.<fmt>. Returns the paths written."""
    if fmt not in FORMATS:
        raise ConfigError("export.format", fmt, "'obj' or 'ply'")
    folder = Path(folder)
    out = []
    for label in np.unique(mesh.face_label).tolist():
        v, f = mesh.fragment(int(label))
        out.append(write_mesh(folder / f"{stem}_{int(label):04d}.{fmt}", v, f))
    return out
