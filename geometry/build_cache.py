"""A disk cache of build results that are slow to recompute, keyed by their input: the kept mesher's
raw output (Sect. 5.1's tetrahedralization), the boundary spheres' groups (Sect. 5.3,
geometry/boundary.py) and WPCA kernels (Sect. 4.1, sph/kernel.py).

Netgen is deterministic, so the tets of one solid at one size never change; meshing them again costs
0.2-4 s per object and, when two processes mesh at once on this 2-core machine, 5-8x more (measured:
a 0.5 m pane at 2.5 cm, 0.25 s alone, 1.9 s with a second process meshing; the extra time is user
time inside Netgen, not waiting). A sweep builds the same objects in every task, so it pays this on
every point. The cache stores Netgen's vertices and tets before anything of ours touches them
(orientation, regions and quality are recomputed from them), keyed by a SHA-256 of the input's exact
description (the OpenCASCADE solid's BRep text, or the surface's triangles), the target size, the
mesher's parameters and Netgen's version: a changed input or a new Netgen is a new key. A procedural
shape's accepted mesh is also kept under the shape's own state (geometry/tetrahedralize.py: its
attributes, the source of shapes.py and occ_solids.py, the mesher's parameters and version and the
quality bounds), so that a second build neither imports Netgen (0.15 s) nor makes the solid.

The grouping of a whole object's boundary spheres runs on a k-nearest query (scipy's cKDTree): the
query takes milliseconds, but importing scipy.spatial takes 0.45 s, on the path to a run's first frame,
and the grouping kernel's first launch 50 ms. An object's group ids are kept under a key of the exact
points, radii, group size and reach, scipy's version and the grouping's own version number, so a run
whose objects were built before imports no scipy before its first frame (events, whose pieces are new
every time, group without the cache).
WPCA kernels likewise (0.15 s for each of Pots' 13 pots, 1 s for the pet), with numpy's version.
A miss is never wrong, only slower: anything a key leaves out must not change the result.

Location: `$ANISOFRAC_CACHE_DIR/<kind>/` (kind `tets`, `boundary` or `kernels`) when that variable is
set (`off` turns the cache off), else `$XDG_CACHE_HOME/anisofrac/<kind>/` (default
`~/.cache/anisofrac/`).
Entries are written under a temporary name and renamed; one that cannot be read, or that does not
fit its kind's check, is computed again and rewritten.
"""

from __future__ import annotations

import functools
import hashlib
import io
import os
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from core.output import atomic_write_bytes

CACHE_ENV = "ANISOFRAC_CACHE_DIR"


def cache_dir(kind: str = "tets") -> Path | None:
    """The folder that holds cached entries of `kind` ("tets", "boundary", "kernels"), or None when off."""
    root = os.environ.get(CACHE_ENV)
    if root is not None:
        return None if root.strip().lower() in ("", "off", "0", "none") else Path(root) / kind
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(xdg) / "anisofrac" / kind


@functools.cache
def package_version(name: str) -> str:
    """An installed package's version, read once a process (`importlib.metadata` scans the installed
    distributions on every call: 5 ms, twice for each of Pots' 13 objects); raises
    PackageNotFoundError."""
    from importlib.metadata import version

    return version(name)


def mesher_version() -> str:
    from importlib.metadata import PackageNotFoundError

    try:
        return package_version("netgen-mesher")
    except PackageNotFoundError:  # a Netgen built from source: its module's own stamp
        import netgen

        return str(getattr(netgen, "__version__", "unknown"))


def digest(kind: str, version: str, description: bytes, **params) -> str:
    """SHA-256 of the input kind, the version of what computes it, its parameters and its exact description."""
    h = hashlib.sha256()
    h.update(f"{kind}\0{version}\0{sorted(params.items())!r}\0".encode())
    h.update(description)
    return h.hexdigest()


def cache_key(kind: str, description: bytes, **params) -> str:
    """The tet cache's key: `digest` with the mesher's version."""
    return digest(kind, mesher_version(), description, **params)


def _read(path: Path, names: tuple[str, ...]) -> dict[str, np.ndarray] | None:
    try:
        with np.load(path, allow_pickle=False) as data:
            return {name: data[name] for name in names}
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError):
        return None


def cached_arrays(kind: str, key: str, names: tuple[str, ...], compute: Callable[[], dict[str, np.ndarray]],
                  valid: Callable[[dict[str, np.ndarray]], bool]) -> dict[str, np.ndarray]:
    """The arrays `names` stored under `kind`/`key` when they are there and `valid`, else `compute()`'s
    (a dict of those arrays), stored for the next time. A cache folder that cannot be written only costs
    the saving."""
    folder = cache_dir(kind)
    if folder is None:
        return compute()
    path = folder / f"{key}.npz"
    if path.is_file():
        hit = _read(path, names)
        if hit is not None and valid(hit):
            return hit
    arrays = compute()
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, buf.getvalue())
    except OSError:
        pass
    return arrays


def tets_valid(hit: dict[str, np.ndarray]) -> bool:
    """An entry's `verts` (V, 3) and `tets` (T >= 1, 4) whose indices are vertices."""
    verts, tets = hit["verts"], hit["tets"]
    if verts.ndim != 2 or verts.shape[1] != 3 or tets.ndim != 2 or tets.shape[1] != 4 or len(tets) == 0:
        return False
    return bool(tets.min() >= 0 and tets.max() < len(verts))


def cached_tets(key: str, mesh: Callable[[], tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """The (verts (V, 3) m, tets (T, 4)) stored under `key`, or `mesh()`'s, stored for the next time."""
    got = cached_arrays("tets", key, ("verts", "tets"), lambda: dict(zip(("verts", "tets"), mesh())), tets_valid)
    return got["verts"].astype(np.float64), got["tets"].astype(np.int64)


__all__ = ["CACHE_ENV", "cache_dir", "cache_key", "cached_arrays", "cached_tets", "digest", "mesher_version",
           "tets_valid"]
