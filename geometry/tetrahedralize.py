"""Tetrahedralization of a solid (Sect. 5.1) with a kept mesher, and the quality it must reach.

- Procedural shapes are meshed by Netgen from their exact solid (geometry.occ_solids); a shape
  without one (the teaching tet) from its surface mesh; a user's surface mesh from its triangles.
  A procedural shape's accepted mesh is read back from the build cache by the shape's own state
  (`_solid_key`), without importing Netgen or making the solid.
- Anisotropic objects with a `layer_axis` use the paper's layered Delaunay sampling
  (geometry.layered_delaunay): their vertices must lie in layers, which no kept mesher offers. Its
  slivers (worst dihedral about 1 degree) are reported, not refused: it is opt-in, for studies.
- Every mesh is oriented positive, stripped of unused vertices, given a region (material slot) per
  tet from its centroid, measured (`quality_report` plus the volume error against the solid) and
  refused with a named error when it falls outside `QUALITY_BOUNDS`: slivers make the SPH
  gradients (Eq. 7-8) and the cuts (Sect. 6) fragile.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.errors import ConfigError, MeshError
from geometry.build_cache import cached_arrays, digest, mesher_version, tets_valid
from geometry.layered_delaunay import layered_delaunay
from geometry.netgen_mesher import CURVATURE_SAFETY, GRADING, SolidMesher, mesh_surface
from geometry.occ_solids import has_occ_solid, occ_solid
from geometry.tetmesh import TetMesh, quality_report, signed_volumes

MAX_TETS = 2_000_000  # refuse resolutions whose tet estimate exceeds this (memory, build time)
TOO_THIN = 0.2  # refuse a part thinner than this x the resolution: its tets could only be flat
TETS_PER_CUBE = 6.0  # tets per h^3 of solid volume that Netgen makes (measured: 4.9 to 6.5)
# A surface mesh's tries in turn (`_mesh_surface`): the fraction of the target tet size, and Netgen's
# volume optimisation passes (`optsteps3d`; None: Netgen's default, 3). Measured on shapes from
# `trimesh.creation`: a torus (60/18 mm) at 12 mm had a worst dihedral angle of 4.9 degrees, 5.2 with 10
# passes; a rod (8 mm radius) at 6 mm 3.8, 13.1 with 10 passes (finer sizes alone did not help:
# 2.4-5.3); a cone's 96 triangles got no tets at 12 mm, and tets at 10.8 mm.
SURFACE_TRIES = ((1.0, None), (1.0, 10), (0.9, 10), (0.8, 10))
QUALITY_BOUNDS = {  # what a mesh must reach to be simulated (checked by `check_quality`)
    "min_dihedral_deg": 5.0,  # smallest dihedral angle, degrees
    "worst_radius_ratio": 0.05,  # 3 r_in / r_circ, 1 = regular tet, 0 = flat
    "volume_error": 0.05,  # |tet volume / solid volume - 1|
}


def check_quality(report: dict, name: str) -> None:
    """Refuse a mesh whose report falls outside QUALITY_BOUNDS, naming the figure and the bound."""
    for key, bound in QUALITY_BOUNDS.items():
        if key not in report:  # the volume error needs a known solid volume
            continue
        value = report[key]
        ok = abs(value) <= bound if key == "volume_error" else value >= bound
        if not ok:
            rule = f"|x| <= {bound:g}" if key == "volume_error" else f">= {bound:g}"
            raise MeshError(
                name,
                f"tet quality {key} = {value:.4g} is outside the bound ({rule})",
                "use a finer resolution, or repair the surface (--repair)",
            )


def _estimate_tets(shape, h: float) -> float:
    lo, hi = shape.bounds()
    return TETS_PER_CUBE * float(np.prod(hi - lo)) / h**3


def _single_tet(shape, h: float):
    """The teaching tet at a resolution of at least its edge: itself, one tet (as the paper draws it)."""
    corners = getattr(shape, "corners", None)
    if corners is None or len(corners) != 4:
        return None
    if h < np.linalg.norm(corners[1] - corners[0]):
        return None
    return corners.copy(), np.arange(4, dtype=np.int64)[None]


def _finish(shape, verts, tets, name: str, reference_volume, extras: dict, h: float):
    """Orient, drop unused vertices, assign regions and measure: (mesh, report)."""
    flip = signed_volumes(verts[tets]) < 0
    tets[flip] = tets[flip][:, [0, 2, 1, 3]]
    used, inverse = np.unique(tets, return_inverse=True)
    verts = verts[used]
    tets = inverse.reshape(-1, 4)
    mesh = TetMesh(verts, tets, shape.region(verts[tets].mean(1)), source=name)
    report = quality_report(mesh)
    report.update(extras, resolution_m=h)
    if reference_volume:
        report.update(reference_volume_m3=reference_volume, volume_error=report["volume_m3"] / reference_volume - 1)
    return mesh, report


def _describe(value) -> bytes:
    """Exact bytes of a shape's state (its attributes, recursively: arrays by dtype, shape and content)."""
    if isinstance(value, np.ndarray):
        return f"{value.dtype.str}{value.shape}".encode() + np.ascontiguousarray(value).tobytes()
    if isinstance(value, (list, tuple)):
        return b"[" + b",".join(_describe(v) for v in value) + b"]"
    if hasattr(value, "__dict__"):
        return type(value).__name__.encode() + b"{" + b",".join(
            k.encode() + b"=" + _describe(v) for k, v in sorted(vars(value).items())) + b"}"
    return repr(value).encode()


def _solid_key(shape, h: float) -> str:
    """The build cache's key of a shape's accepted Netgen mesh: its exact state, the code that turns it into
    a solid (shapes.py, occ_solids.py), the mesher's parameters and version, and the quality bounds."""
    here = Path(__file__).parent
    code = b"".join((here / f).read_bytes() for f in ("shapes.py", "occ_solids.py"))
    return digest("shape-solid", mesher_version(), _describe(shape) + code, maxh=h, grading=GRADING,
                  safeties=CURVATURE_SAFETY, bounds=sorted(QUALITY_BOUNDS.items()))


def _mesh_exact_solid(shape, h: float, name: str):
    """Netgen on the exact solid, with more elements per radius of curvature until the bounds are met.

    The accepted try is kept in the build cache under the shape's own state (`_solid_key`), so a second
    build reads it without importing Netgen (0.15 s) or making the solid; a first one meshes as before
    (each try through the tet cache keyed by the solid's BRep)."""

    def mesh_solid() -> dict:
        solid = occ_solid(shape)
        mesher = SolidMesher(solid, h, name)
        for k, safety in enumerate(CURVATURE_SAFETY):
            verts, tets = mesher.mesh(safety)
            _, report = _finish(shape, verts, tets.copy(), name, float(solid.mass), {}, h)  # Netgen's own kept
            try:
                check_quality(report, name)
            except MeshError:
                if k == len(CURVATURE_SAFETY) - 1:
                    raise
                continue
            return dict(verts=verts, tets=tets, safety=np.float64(safety), volume=np.float64(solid.mass))

    def valid(hit: dict) -> bool:
        return tets_valid(hit) and float(hit["safety"]) in CURVATURE_SAFETY and float(hit["volume"]) > 0.0

    got = cached_arrays("tets", _solid_key(shape, h), ("verts", "tets", "safety", "volume"), mesh_solid, valid)
    extras = dict(mesher="netgen (exact solid)", curvature_safety=float(got["safety"]))
    return _finish(shape, got["verts"].astype(np.float64), got["tets"].astype(np.int64), name,
                   float(got["volume"]), extras, h)


def _mesh(shape, h: float, name: str, seed: int, layer_axis, layer_spacing):
    """(mesh, report) from the right mesher."""
    if layer_axis is not None:
        verts, tets, counts = layered_delaunay(shape, h, seed, layer_axis, layer_spacing)
        return _finish(shape, verts, tets, name, None, dict(mesher="layered Delaunay (Sect. 5.1)", **counts), h)
    single = _single_tet(shape, h)
    if single is not None:
        return _finish(shape, *single, name, None, dict(mesher="single tet"), h)
    if has_occ_solid(shape):
        return _mesh_exact_solid(shape, h, name)
    return _mesh_surface(shape, h, name)


def _mesh_surface(shape, h: float, name: str):
    """Netgen on a surface at h, then with more optimisation passes and at finer sizes (SURFACE_TRIES)
    where it fails (no tets, a crash) or its mesh misses QUALITY_BOUNDS: Netgen's STL front end fails on
    some valid surfaces at one size and not at a nearby one (geometry/netgen_worker.py). The accepted try
    is kept in the build cache with its tets, so a later build neither repeats the failed tries nor
    imports Netgen; the report names the try used and why the ones before it failed."""
    surface = shape.reference_mesh()
    volume = float(surface.volume)

    def accepted() -> dict:
        failures = []
        for k, (step, passes) in enumerate(SURFACE_TRIES):
            size = h * step
            try:
                verts, tets = mesh_surface(surface.vertices, surface.faces, size, name, passes)
                check_quality(_finish(shape, verts, tets.copy(), name, volume, {}, h)[1], name)
            except MeshError as exc:
                failures.append(f"{size:.4g} m, {passes or 'default'} optimisation passes: {exc.problem}")
                continue
            return dict(verts=verts, tets=tets, attempt=np.int64(k), failures=np.array(failures, dtype=str))
        raise MeshError(name, f"the tet mesher (Netgen) gave no mesh within the bounds at any try "
                        f"({'; '.join(failures)})", "use a finer resolution, or check the surface with "
                        "`main.py check FILE` and try --repair")

    def valid(hit: dict) -> bool:
        return tets_valid(hit) and 0 <= int(hit["attempt"]) < len(SURFACE_TRIES)

    key = digest("surface-accepted", mesher_version(), surface.vertices.tobytes() + surface.faces.tobytes(), maxh=h,
                 grading=GRADING, tries=SURFACE_TRIES, bounds=sorted(QUALITY_BOUNDS.items()))
    got = cached_arrays("tets", key, ("verts", "tets", "attempt", "failures"), accepted, valid)
    step, passes = SURFACE_TRIES[int(got["attempt"])]
    extras = dict(mesher="netgen (surface mesh)", mesher_size_m=h * step, mesher_optimisation_passes=passes)
    if len(got["failures"]):
        extras["mesher_failures"] = [str(f) for f in got["failures"]]
    return _finish(shape, got["verts"].astype(np.float64), got["tets"].astype(np.int64), name, volume, extras, h)


def tetrahedralize(
    shape,
    resolution: float,
    seed: int = 0,
    layer_axis=None,
    layer_spacing: float | None = None,
    max_tets: int = MAX_TETS,
) -> tuple[TetMesh, dict]:
    """Tet mesh of `shape` at target tet size `resolution` (m); returns (mesh, report).

    The report has the quality figures of `quality_report`, the mesher used, the volume error
    against the solid (where the solid's volume is known) and the resolution. The same inputs give
    bit-identical meshes (`seed` only moves the layered sampler's jitter).
    """
    h = float(resolution)
    if not np.isfinite(h) or h <= 0:
        raise ConfigError("resolution", resolution, "a finite tet size > 0 m")
    estimate = _estimate_tets(shape, h)
    if estimate > max_tets:
        lo, hi = shape.bounds()
        smallest = (TETS_PER_CUBE * float(np.prod(hi - lo)) / max_tets) ** (1 / 3)
        raise ConfigError(
            "resolution",
            resolution,
            f">= {smallest:.3g} m for this {float((hi - lo).max()):.3g} m object (about {estimate:.3g} tets "
            f"requested, budget {max_tets})",
        )
    name = getattr(shape, "name", "shape")
    thinnest = float(getattr(shape, "thinnest_wall", shape.thickness)())
    if thinnest < TOO_THIN * h:
        lo, hi = shape.bounds()  # the size tells a file read in the wrong unit (`units`) at a glance
        raise MeshError(name, f"too thin for the resolution: its thinnest part is {thinnest * 1e3:.3g} mm and the tets "
                        f"would be {h * 1e3:.3g} mm wide (the whole object is {float((hi - lo).max()) * 1e3:.3g} mm "
                        f"across)", f"use a resolution <= {thinnest / TOO_THIN:.3g} m")
    mesh, report = _mesh(shape, h, name, seed, layer_axis, layer_spacing)
    if layer_axis is None:  # the layered sampler is the paper's own method: its figures are reported only
        check_quality(report, name)
    return mesh, report


__all__ = ["MAX_TETS", "QUALITY_BOUNDS", "check_quality", "tetrahedralize"]
