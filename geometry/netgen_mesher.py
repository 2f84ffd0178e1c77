"""The kept tet mesher: Netgen (`netgen-mesher` on PyPI, LGPL-2.1), the mesher the paper used.

Two inputs (Sect. 5.1 starts from either):
- an exact OpenCASCADE solid (`geometry.occ_solids`), for procedural shapes: curved faces are
  meshed from the true geometry;
- a closed triangle surface (a user's mesh file, validated by `geometry.mesh_io`), handed to
  Netgen's STL front end, which rebuilds a surface mesh at the target size from it.

Netgen is deterministic for the same input and runs single-threaded here (no task manager is
started), so a scene builds the same tets on every machine, and its output is kept on disk
(`geometry.build_cache`): the second build of an object reads its tets instead of meshing.
Why Netgen and not fTetWild, TetGen or gmsh: docs/decisions.md, "Tet mesher".
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from core.errors import MeshError
from geometry.build_cache import cache_key, cached_tets

GRADING = 0.3  # Netgen's mesh-size grading (0 = uniform, 1 = free growth away from small features)
# Netgen's curvature safety (elements per radius of curvature; Netgen's default is 2), tried in turn
# until the mesh meets the quality bounds (geometry.tetrahedralize): a 4 cm ball at 2 cm tets gets
# 107 tets, a worst radius ratio of 0.047 and 9.4 % of its volume missing at 2, and 284 tets, 0.43
# and 4.4 % at 3; a 4 mm wire at 12 mm passes at 2 with 3.3k tets (11k at 3).
CURVATURE_SAFETY = (2.0, 3.0, 4.0)
WORKER = Path(__file__).with_name("netgen_worker.py")  # Netgen on a surface, in a process of its own


def _quiet(meshing) -> None:
    meshing.SetMessageImportance(0)


def _arrays(ng_mesh, name: str) -> tuple[np.ndarray, np.ndarray]:
    verts = np.array(ng_mesh.Coordinates(), dtype=np.float64)
    tets = ng_mesh.Elements3D().NumPy()["nodes"][:, :4].astype(np.int64) - 1  # Netgen counts from 1
    if len(tets) == 0:
        raise MeshError(name, "the mesher produced no tets", "the solid is empty or not closed")
    return verts, tets


def _failed(name: str, exc: Exception | str) -> MeshError:
    return MeshError(
        name,
        f"the tet mesher (Netgen) failed: {str(exc).strip() or type(exc).__name__}",
        "check the surface with `main.py check FILE`, try --repair, or another resolution",
    )


def _brep_text(solid) -> bytes:
    """The solid's exact OpenCASCADE description (BRep text), read before any meshing touches it."""
    with tempfile.TemporaryDirectory(prefix="anisofrac-brep-") as tmp:
        path = os.path.join(tmp, "solid.brep")
        solid.WriteBrep(path)
        with open(path, "rb") as f:
            return f.read()


class SolidMesher:
    """Netgen on one `netgen.occ` solid at target edge length `size` (m), one curvature safety after
    another (`mesh`), each result read from the tet cache when it is there.

    Netgen's result depends on what was meshed on the same solid object before (its surface
    triangulation is kept: the 4 cm ball at safety 3 gets 285 tets after a try at 2, 304 on a fresh
    solid), so a cache key holds the safeties tried before, and a miss first replays on the solid the
    tries that hits skipped: a cached build is bit-identical to an uncached one."""

    def __init__(self, solid, size: float, name: str):
        self.solid, self.size, self.name = solid, float(size), name
        self.description = _brep_text(solid)  # before the first GenerateMesh changes the solid
        self.tried: list[float] = []  # safeties asked for so far, in order
        self.meshed: list[float] = []  # safeties Netgen actually ran on this solid (a prefix of `tried`)

    def _generate(self, safety: float):
        import netgen.meshing as meshing
        import netgen.occ as occ

        _quiet(meshing)
        try:
            ng_mesh = occ.OCCGeometry(self.solid).GenerateMesh(maxh=self.size, grading=GRADING,
                                                                curvaturesafety=safety)
        except Exception as exc:  # Netgen raises its own NgException; every failure is the mesher's
            raise _failed(self.name, exc) from None
        self.meshed.append(safety)
        return ng_mesh

    def mesh(self, curvature_safety: float = CURVATURE_SAFETY[0]) -> tuple[np.ndarray, np.ndarray]:
        """(verts (V, 3) m, tets (T, 4)) at this curvature safety, after the ones asked for before."""
        safety = float(curvature_safety)
        before = list(self.tried)
        self.tried.append(safety)

        def generate():
            for earlier in before[len(self.meshed):]:  # what cache hits skipped, in order
                self._generate(earlier)
            return _arrays(self._generate(safety), self.name)

        key = cache_key("occ-solid", self.description, maxh=self.size, grading=GRADING, curvaturesafety=safety,
                        tried_before=tuple(before))
        return cached_tets(key, generate)


def mesh_surface(vertices: np.ndarray, faces: np.ndarray, size: float, name: str,
                 optimise: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Tets inside a closed, outward-oriented triangle surface (m) at target edge length `size` (m), by
    Netgen in a process of its own (geometry/netgen_worker.py: some of Netgen's failures on valid
    surfaces abort the process that runs it); `optimise`: Netgen's volume optimisation passes
    (`optsteps3d`; None: its default)."""
    import trimesh

    vertices = np.ascontiguousarray(vertices, np.float64)
    faces = np.ascontiguousarray(faces, np.int64)

    def generate():
        surface = trimesh.Trimesh(vertices, faces, process=False)
        with tempfile.TemporaryDirectory(prefix="anisofrac-mesher-") as tmp:
            path, out = os.path.join(tmp, "surface.stl"), os.path.join(tmp, "tets.npz")
            surface.export(path)  # Netgen's surface front end reads STL (float32 is ample at mm scale)
            extra = [] if optimise is None else [str(int(optimise))]
            done = subprocess.run([sys.executable, str(WORKER), path, out, repr(float(size)), repr(GRADING), *extra],
                                  capture_output=True, text=True)
            if done.returncode != 0:
                raise _failed(name, _worker_failure(done.returncode, done.stderr))
            with np.load(out) as got:
                verts, tets = got["verts"], got["tets"]
        if len(tets) == 0:
            raise MeshError(name, "the mesher produced no tets", f"Netgen could not fill the surface at {size:.3g} m: "
                            "try another resolution")
        return verts, tets

    options = {} if optimise is None else {"optsteps3d": int(optimise)}  # the default's key as before
    key = cache_key("stl-surface", vertices.tobytes() + faces.tobytes(), maxh=float(size), grading=GRADING, **options)
    return cached_tets(key, generate)


def _worker_failure(code: int, stderr: str) -> str:
    """What a Netgen worker that exited with `code` said: its last line, or the signal that ended it."""
    lines = [line for line in stderr.strip().splitlines() if line.strip()]
    if code < 0:
        return f"it crashed ({signal.Signals(-code).name})"
    return lines[-1] if lines else f"exit status {code}"


__all__ = ["GRADING", "SolidMesher", "mesh_surface"]
