"""Bad input gets a clear SandboxError naming what is wrong and where, a non-zero exit without a
traceback from the command line, and no output. Cases already covered elsewhere are listed in
docs/robustness.md (tests/unit/test_geometry_input.py, tests/regression/test_scene_files.py)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import main
from core.errors import ConfigError, MaterialError, MeshError
from geometry.build import build_object
from geometry.mesh_io import load_surface_mesh, load_tet_mesh
from geometry.surface_checks import check_surface_overlap, winding_numbers
from scenes.loader import load_scene, scene_from_dict
from sim.world import World
from tests.stability.test_scale_offset import write_obj

MAIN_RUN = ["run", "--precision", "f64", "--renderer", "none", "--video", "none", "--no-progress"]


def run_main(capsys, scene: str, out, *extra: str) -> tuple[int, str]:
    argv = [MAIN_RUN[0], scene, *MAIN_RUN[1:], "--out", str(out), *extra]
    code = main.main(argv)
    return code, capsys.readouterr().err


# ------------------------------------------------------------------------------------------------ meshes
def mesh_file(path, mesh: trimesh.Trimesh) -> str:
    return write_obj(path, mesh.vertices, mesh.faces)


def overlapping_boxes() -> trimesh.Trimesh:
    a = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    b = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    b.apply_translation([0.05, 0.03, 0.0])
    return trimesh.util.concatenate([a, b])


def folded_box() -> trimesh.Trimesh:
    """A box whose top corners are pulled through the bottom face: a closed, consistently wound surface
    that passes through itself (an inverted pocket)."""
    m = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    v = np.asarray(m.vertices).copy()
    top = v[:, 2] > 0
    v[top & (v[:, 0] > 0), 2] = -0.09
    return trimesh.Trimesh(v, m.faces, process=False)


def test_self_intersecting_surfaces_are_refused(tmp_path):
    """geometry.mesh_io refuses two interpenetrating shells through geometry.surface_checks.check_surface_overlap
    (winding number 2 in the overlap); without it the overlap would become a hole (ray parity)."""
    path = mesh_file(tmp_path / "two.obj", overlapping_boxes())
    with pytest.raises(MeshError) as info:
        load_surface_mesh(path, units="m")
    assert "self-intersecting" in str(info.value) and "winding number 2" in str(info.value)
    with pytest.raises(MeshError, match="self-intersecting"):
        build_object(path, resolution=0.02, units="m")
    fold = folded_box()
    with pytest.raises(MeshError, match="self-intersecting"):
        check_surface_overlap(fold.vertices, fold.faces, "fold")


@pytest.mark.parametrize("make", [
    lambda: trimesh.creation.icosphere(subdivisions=3, radius=0.1),
    lambda: trimesh.creation.torus(0.1, 0.03),
    lambda: trimesh.util.concatenate([trimesh.creation.box(extents=(0.1, 0.1, 0.1)),
                                      trimesh.creation.box(extents=(0.1, 0.1, 0.1)).apply_translation([0.3, 0, 0])]),
    lambda: trimesh.creation.box(extents=(0.4, 0.4, 0.004)),
], ids=["sphere", "torus", "two-disjoint-boxes", "thin-pane"])
def test_overlap_guard_accepts_valid_solids(make):
    m = make()
    check_surface_overlap(m.vertices, m.faces, "ok")


def test_winding_numbers_are_exact_for_a_closed_surface():
    m = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    w = winding_numbers(m.vertices, m.faces, [[0, 0, 0], [0.5, 0.2, 0.1], [2, 0, 0], [0, -3, 1]])
    np.testing.assert_allclose(w, [1, 1, 0, 0], atol=1e-12)


def test_tet_mesh_with_nan_and_bad_indices(tmp_path):
    import meshio

    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], dtype=float)
    t = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])
    bad = v.copy()
    bad[4, 0] = np.nan
    meshio.write(str(tmp_path / "nan.vtu"), meshio.Mesh(bad, [("tetra", t)]))
    with pytest.raises(MeshError, match="non-finite vertex coordinates.*first index 4"):
        load_tet_mesh(str(tmp_path / "nan.vtu"), units="m")
    meshio.write(str(tmp_path / "idx.vtu"), meshio.Mesh(v, [("tetra", np.array([[0, 1, 2, 3], [1, 2, 3, 7]]))]))
    with pytest.raises(MeshError, match="out of range|unreadable"):
        load_tet_mesh(str(tmp_path / "idx.vtu"), units="m")


def budget_scene(**obj) -> dict:
    o = {"name": "big", "material": "m", "resolution": 0.005}
    o.update(obj)
    return {"scene": {"name": "big", "effects": ["rigid"]},
            "materials": [{"name": "m", "density": 1000.0, "stiffness": {"model": "isotropic", "E": 1e9, "nu": 0.3}}],
            "objects": [o]}


def test_size_beyond_the_particle_budget_is_refused_before_sampling(tmp_path):
    """A 10 m mesh at 5 mm would need ~5e10 tets: refused before meshing with the object's key, the
    smallest resolution allowed and the budget (geometry.tetrahedralize.MAX_TETS = 2e6 tets)."""
    path = mesh_file(tmp_path / "big.obj", trimesh.creation.box(extents=(10, 10, 10)))
    for obj in (dict(mesh=path, units="m"), dict(shape={"type": "pane", "size": [100.0, 100.0, 0.01]})):
        with pytest.raises(ConfigError) as info:
            World(scene_from_dict(budget_scene(**obj), "big"))
        msg = str(info.value)
        assert "objects[0].resolution" in msg and "budget 2000000" in msg and "tets requested" in msg


# ------------------------------------------------------------------------------------------------ scenes
BAD_SCENE_VALUES = [
    # (override, key in the message, allowed range in the message)
    ("materials.glass.stiffness.E=0", "E", "> 0"),
    ("materials.glass.stiffness.nu=-1", "nu", "-1 < nu < 0.5"),
    ("materials.glass.stiffness.nu=0.7", "nu", "-1 < nu < 0.5"),
    ("materials.glass.stiffness.E=nan", "materials[0].stiffness.E", "a finite number"),
    ("materials.glass.stiffness.E=inf", "materials[0].stiffness.E", "a finite number"),
    ("materials.glass.density=0", "materials[0].density", ">= 1"),
    ("materials.glass.tensile_strength=0", "materials[0].tensile_strength", "> 0"),
    ("materials.glass.toughness=-1", "materials[0].toughness", "> 0"),
    ("materials.glass.cracks=0", "materials[0].cracks", ">= 1"),
    ("materials.glass.colour=1", "materials[0].colour", "a known key"),
    ("colliders.0.restitution=1.5", "colliders[0].restitution", "<= 1"),
    ("colliders.0.friction=-1", "colliders[0].friction", ">= 0"),
    ("colliders.0.poisson=0.5", "colliders[0].poisson", "<= 0.499"),
    ("colliders.0.normal=[0,0,0]", "colliders[0].normal", "a non-zero vector"),
    ("colliders.0.type=sphere", "colliders[0].type", "one of plane, box"),
    ('objects.ball.position="up"', "objects[1].position", "3 finite numbers"),
    ("objects.ball.velocity=[0,0,-2000]", "objects[1].velocity[2]", ">= -1000"),
    ("objects.pane.resolution=0", "objects[0].resolution", ">= 1e-05"),
    ("scene.fps=0", "scene.fps", ">= 1"),
    ("scene.substeps=0", "scene.substeps", ">= 1"),
    ("scene.gravity=[0,nan,0]", "scene.gravity[1]", "finite"),
    ('scene.effects=["rigid","explosions"]', "scene.effects[1]", "one of rigid, fracture"),
    ('scene.effects=["rigid","elastic"]', None, None),  # refused when the World is built (below)
]


@pytest.mark.parametrize("override,key,allowed", BAD_SCENE_VALUES, ids=[c[0] for c in BAD_SCENE_VALUES])
def test_bad_scene_value_is_named_and_nothing_is_written(tmp_path, capsys, override, key, allowed):
    out = tmp_path / "out"
    code, err = run_main(capsys, "glass_r3", out, "--set", override)
    assert code == 2 and "Traceback" not in err
    assert any(line.startswith("error: ") for line in err.splitlines())
    if key is not None:
        assert key in err and allowed in err and "glass_r3.toml" in err, err
        with pytest.raises(ConfigError):
            load_scene("glass_r3", [override])
    else:
        assert "'elastic' without 'rigid'" in err
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("stiffness,key", [
    ({"model": "orthotropic", "E1": 1e10, "E2": 1e9, "E3": 1e9, "nu12": 4.0, "nu13": 0.3, "nu23": 0.3,
      "G12": 1e9, "G13": 1e9, "G23": 1e9}, "nu12"),  # |nu12| must stay below sqrt(E1/E2) = 3.16
    ({"model": "orthotropic", "E1": 1e10, "E2": 1e10, "E3": 1e10, "nu12": 0.9, "nu13": 0.9, "nu23": 0.9,
      "G12": 1e9, "G13": 1e9, "G23": 1e9}, "(nu12, nu13, nu23)"),  # each in range, compliance not PD
    ({"model": "orthotropic", "E1": 1e10, "E2": -1e9, "E3": 1e9, "nu12": 0.3, "nu13": 0.3, "nu23": 0.3,
      "G12": 1e9, "G13": 1e9, "G23": 1e9}, "E2"),
    ({"model": "transverse", "axis": [0.0, 0.0, 0.0], "E_axial": 1e10, "E_transverse": 1e9, "nu_transverse": 0.3,
      "nu_axial": 0.2, "G_axial": 1e9}, "axis"),
    ({"model": "isotropic", "E": 1e9}, "nu"),  # missing constant
    ({"model": "cubic", "E": 1e9, "nu": 0.3}, "model"),
], ids=["nu12-bound", "not-positive-definite", "negative-E2", "zero-axis", "missing-nu", "unknown-model"])
def test_invalid_elastic_constants_are_named(stiffness, key):
    raw = budget_scene(shape={"type": "box", "size": [0.1, 0.1, 0.1]}, resolution=0.05)
    raw["materials"][0]["stiffness"] = stiffness
    with pytest.raises(MaterialError) as info:
        scene_from_dict(raw, "mats.toml")
    assert f"materials[0].stiffness.{key}" in str(info.value) and "mats.toml" in str(info.value)


# ------------------------------------------------------------------------------------------------ command line
def test_output_folder_that_is_a_file(tmp_path, capsys):
    f = tmp_path / "taken"
    f.write_text("mine")
    code, err = run_main(capsys, "tet_cut_22", f)
    assert code == 2 and "--out" in err and "a file of that name exists" in err and "Traceback" not in err
    assert f.read_text() == "mine"


def test_missing_mesh_of_a_scene_writes_nothing(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text("""
[scene]
name = "s"
effects = ["rigid"]
[[materials]]
name = "m"
density = 1000.0
stiffness = { model = "isotropic", E = 1.0e9, nu = 0.3 }
[[objects]]
name = "o"
mesh = "no_such_mesh.obj"
units = "mm"
material = "m"
""")
    out = tmp_path / "out"
    code, err = run_main(capsys, str(scene), out)
    assert code == 2 and "no_such_mesh.obj: file not found" in err and "Traceback" not in err
    assert not out.exists() or not any(out.iterdir())  # (the empty folder is created before the World)


def test_negative_frame_count_is_refused(tmp_path, capsys):
    code, err = run_main(capsys, "tet_cut_22", tmp_path / "out", "--frames", "-3")
    assert code == 2 and "--frames" in err
