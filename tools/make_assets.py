"""Regenerate the models in assets/ from the project's own geometry code (all CC0, see assets/README.md).

    python tools/make_assets.py [--out assets] [--check]

Each model is a closed, outward-oriented triangle surface written in a common format with an
explicit length unit (the unit a scene declares with `units = ...`). Unions and cavities are
exact booleans from manifold3d (via trimesh), so the surfaces are manifold and self-intersection
free; the figurine's surface is Netgen's mesh of its exact solid. `--check` regenerates into a
temporary folder and fails when a stored model's volume or face count differs (the models are
data, but they must stay reproducible from this script).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from geometry.occ_solids import occ_solid  # noqa: E402
from geometry.shapes import Figurine, lathe  # noqa: E402

SECTIONS = 96  # facets around a solid of revolution

MM, CM = 1000.0, 100.0  # file units per metre


def _revolved(profile_m, wall_m, scale: float):
    mesh = lathe(profile_m, wall_m).reference_mesh(sections=SECTIONS)
    mesh.apply_scale(scale)
    return mesh


def cube():
    """A 100 mm cube (mm): the mesher-quality reference of issue 18."""
    import trimesh

    return trimesh.creation.box(extents=[100.0, 100.0, 100.0])


def pot():
    """The paper's pot (Fig. 7), 200 mm tall with an 8 mm wall (mm)."""
    return _revolved([[0.05, 0.0], [0.09, 0.08], [0.06, 0.2]], 0.008, MM)


def vase():
    """A bottle vase with a narrow neck, 30 cm tall, 6 mm wall (cm)."""
    profile = [[0.045, 0.0], [0.07, 0.06], [0.075, 0.13], [0.05, 0.2], [0.022, 0.25], [0.025, 0.3]]
    return _revolved(profile, 0.006, CM)


def mug():
    """A mug with a ring handle (mm): a cylinder with a cavity, union a torus, 95 mm tall."""
    import trimesh

    body = trimesh.creation.cylinder(radius=40.0, height=95.0, sections=SECTIONS)
    body.apply_translation([0.0, 0.0, 47.5])
    cavity = trimesh.creation.cylinder(radius=35.0, height=95.0, sections=SECTIONS)
    cavity.apply_translation([0.0, 0.0, 47.5 + 6.0])  # 6 mm floor, open top
    handle = trimesh.creation.torus(major_radius=24.0, minor_radius=5.5, major_sections=48, minor_sections=16)
    handle.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))  # ring in x-z
    handle.apply_translation([52.0, 0.0, 50.0])
    solid = trimesh.boolean.difference([trimesh.boolean.union([body, handle], engine="manifold"), cavity],
                                       engine="manifold")
    # stand the mug up along y (the project's up axis)
    solid.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    return solid


def figurine():
    """The paper's pet (Fig. 11), 0.18 m tall (m, as glTF requires): the surface Netgen meshes on the
    exact union of the Figurine's ellipsoids, triangles about 6 mm."""
    import netgen.meshing as meshing
    import netgen.occ as occ
    import trimesh

    meshing.SetMessageImportance(0)
    geometry = occ.OCCGeometry(occ_solid(Figurine(0.2)))
    ng = geometry.GenerateMesh(maxh=0.006, perfstepsend=meshing.MeshingStep.MESHSURFACE)
    faces = ng.Elements2D().NumPy()["nodes"][:, :3].astype(np.int64) - 1  # Netgen counts from 1
    mesh = trimesh.Trimesh(np.array(ng.Coordinates()), faces)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


MODELS = {  # file name: (builder, unit of the file's coordinates)
    "cube_100mm.stl": (cube, "mm"),
    "pot.obj": (pot, "mm"),
    "vase.ply": (vase, "cm"),
    "mug.stl": (mug, "mm"),
    "figurine.glb": (figurine, "m"),
}


def write_all(out: Path) -> dict[str, tuple[float, int]]:
    """Write every model into `out`; returns {name: (volume in file units^3, faces)}."""
    out.mkdir(parents=True, exist_ok=True)
    summary = {}
    for name, (build, _unit) in MODELS.items():
        mesh = build()
        mesh.merge_vertices()
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0, name
        tmp = out / (name + ".tmp" + Path(name).suffix)
        mesh.export(tmp)
        tmp.replace(out / name)
        summary[name] = (float(mesh.volume), len(mesh.faces))
    return summary


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(ROOT / "assets"))
    p.add_argument("--check", action="store_true", help="fail when assets/ differs from a fresh build")
    args = p.parse_args(argv)
    if not args.check:
        for name, (vol, faces) in write_all(Path(args.out)).items():
            print(f"{name:16s} {faces:7d} faces  volume {vol:.6g} {MODELS[name][1]}^3")
        return 0
    import trimesh

    with tempfile.TemporaryDirectory() as tmp:
        fresh = write_all(Path(tmp))
    bad = []
    for name, (vol, faces) in fresh.items():
        stored = trimesh.load(ROOT / "assets" / name, force="mesh")
        if len(stored.faces) != faces or abs(stored.volume - vol) > 1e-6 * abs(vol):
            bad.append(name)
    print("assets match" if not bad else "assets differ from tools/make_assets.py: " + ", ".join(bad))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
