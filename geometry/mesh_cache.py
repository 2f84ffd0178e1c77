"""A disk cache of the kept mesher's raw output (Sect. 5.1's tetrahedralization), keyed by its input.

Netgen is deterministic, so the tets of one solid at one size never change; meshing them again costs
0.2-4 s per object and, when two processes mesh at once on this 2-core machine, 5-8x more (measured:
a 0.5 m pane at 2.5 cm, 0.25 s alone, 1.9 s with a second process meshing; the extra time is user
time inside Netgen, not waiting). A sweep builds the same objects in every task, so it pays this on
every point. The cache stores Netgen's vertices and tets before anything of ours touches them
(orientation, regions and quality are recomputed from them), keyed by a SHA-256 of the input's exact
description (the OpenCASCADE solid's BRep text, or the surface's triangles), the target size, the
mesher's parameters and Netgen's version: a changed input or a new Netgen is a new key.

Location: `$ANISOFRAC_CACHE_DIR/tets/` when that variable is set (`off` turns the cache off), else
`$XDG_CACHE_HOME/anisofrac/tets/` (default `~/.cache/anisofrac/tets/`). Entries are written under a
temporary name and renamed; one that cannot be read is meshed again and rewritten.
"""

from __future__ import annotations

import hashlib
import io
import os
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from core.output import atomic_write_bytes

CACHE_ENV = "ANISOFRAC_CACHE_DIR"


def cache_dir() -> Path | None:
    """The folder that holds cached tets, or None when the cache is off."""
    root = os.environ.get(CACHE_ENV)
    if root is not None:
        return None if root.strip().lower() in ("", "off", "0", "none") else Path(root) / "tets"
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(xdg) / "anisofrac" / "tets"


def mesher_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("netgen-mesher")
    except PackageNotFoundError:  # a Netgen built from source: its module's own stamp
        import netgen

        return str(getattr(netgen, "__version__", "unknown"))


def cache_key(kind: str, description: bytes, **params) -> str:
    """SHA-256 of the input kind, its exact description, the mesher's parameters and its version."""
    h = hashlib.sha256()
    h.update(f"{kind}\0{mesher_version()}\0{sorted(params.items())!r}\0".encode())
    h.update(description)
    return h.hexdigest()


def _read(path: Path) -> tuple[np.ndarray, np.ndarray] | None:
    try:
        with np.load(path, allow_pickle=False) as data:
            verts, tets = data["verts"], data["tets"]
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError):
        return None
    if verts.ndim != 2 or verts.shape[1] != 3 or tets.ndim != 2 or tets.shape[1] != 4 or len(tets) == 0:
        return None
    if tets.min() < 0 or tets.max() >= len(verts):
        return None
    return verts.astype(np.float64), tets.astype(np.int64)


def cached_tets(key: str, mesh: Callable[[], tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """The (verts (V, 3) m, tets (T, 4)) stored under `key`, or `mesh()`'s, stored for the next time.
    A cache folder that cannot be written only costs the saving."""
    folder = cache_dir()
    if folder is None:
        return mesh()
    path = folder / f"{key}.npz"
    hit = _read(path) if path.is_file() else None
    if hit is not None:
        return hit
    verts, tets = mesh()
    buf = io.BytesIO()
    np.savez(buf, verts=verts, tets=tets)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, buf.getvalue())
    except OSError:
        pass
    return verts, tets


__all__ = ["CACHE_ENV", "cache_dir", "cache_key", "cached_tets", "mesher_version"]
