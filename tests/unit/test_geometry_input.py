"""Mesh input: every bad file gets its named error; good files in every format load in metres."""

from __future__ import annotations

import subprocess
import sys

import meshio
import numpy as np
import pytest
import trimesh

from core.errors import ConfigError, MeshError
from geometry.build import build_object
from geometry.mesh_io import load_surface_mesh, load_tet_mesh
from geometry.shapes import Box
from geometry.tetrahedralize import tetrahedralize

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]


def write_obj(path, vertices, faces) -> str:
    with open(path, "w") as f:
        for v in vertices:
            f.write("v " + " ".join(repr(float(c)) for c in v) + "\n")
        for t in faces:
            f.write("f " + " ".join(str(int(i) + 1) for i in t) + "\n")
    return str(path)


def cube():
    m = trimesh.creation.box(extents=(2.0, 1.0, 1.0))
    return np.asarray(m.vertices), np.asarray(m.faces)


@pytest.mark.parametrize("ext", ["obj", "stl", "ply", "glb"])
def test_surface_formats_load_in_declared_units(tmp_path, ext):
    path = tmp_path / f"cube.{ext}"
    trimesh.creation.box(extents=(20.0, 10.0, 10.0)).export(path)
    mesh = load_surface_mesh(str(path), units="mm")
    assert np.ptp(mesh.vertices, axis=0) == pytest.approx([0.02, 0.01, 0.01])
    assert mesh.trimesh().volume == pytest.approx(2e-6)


def test_surface_mesh_file_is_tetrahedralized(tmp_path):
    path = write_obj(tmp_path / "cube.obj", *cube())
    geo = build_object(path, resolution=0.25, units="m")
    # corners and sharp edges are sampled, so the hull is the box up to peeled surface slivers
    assert geo.mesh.volume == pytest.approx(2.0, rel=1e-3)
    assert geo.report["physical_particles"] == len(geo.particles)


@pytest.mark.parametrize("ext", ["msh", "vtu", "vtk", "mesh"])
def test_tet_formats_round_trip(tmp_path, ext):
    mesh, _ = tetrahedralize(Box((0.2, 0.1, 0.05)), 0.02)
    path = tmp_path / f"box.{ext}"
    kw = {"file_format": "gmsh22", "binary": False} if ext == "msh" else {}
    meshio.write(str(path), meshio.Mesh(mesh.verts * 100.0, [("tetra", mesh.tets)]), **kw)
    loaded, repairs = load_tet_mesh(str(path), units="cm")
    assert repairs == []
    assert loaded.volume == pytest.approx(0.2 * 0.1 * 0.05, rel=1e-9)
    assert len(loaded.tets) == len(mesh.tets)


def expect_mesh_error(path, units, problem, repair=False):
    with pytest.raises(MeshError) as info:
        load_surface_mesh(str(path), units=units, repair=repair)
    assert problem in str(info.value)
    assert str(path) in str(info.value)
    return info.value


def test_missing_empty_and_corrupt_files(tmp_path):
    expect_mesh_error(tmp_path / "nope.obj", "m", "file not found")
    (tmp_path / "empty.obj").write_text("")
    expect_mesh_error(tmp_path / "empty.obj", "m", "file is empty")
    (tmp_path / "bad.glb").write_bytes(b"glTF\x02\x00\x00\x00garbage-bytes-that-are-not-a-mesh")
    expect_mesh_error(tmp_path / "bad.glb", "m", "unreadable")
    (tmp_path / "text.obj").write_text("this is not a mesh\n")
    expect_mesh_error(tmp_path / "text.obj", "m", "no faces")
    (tmp_path / "x.xyz").write_text("1 2 3\n")
    expect_mesh_error(tmp_path / "x.xyz", "m", "unsupported surface format")


def test_nan_coordinates_name_the_first_vertex(tmp_path):
    v, f = cube()
    v[5, 1] = np.nan
    err = expect_mesh_error(write_obj(tmp_path / "nan.obj", v, f), "m", "non-finite")
    assert "first index 5" in str(err)


def test_no_faces(tmp_path):
    (tmp_path / "pts.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    expect_mesh_error(tmp_path / "pts.obj", "m", "no faces")


def test_open_surface_is_refused_and_repaired_on_request(tmp_path):
    v, f = cube()
    path = write_obj(tmp_path / "open.obj", v, f[:-1])
    err = expect_mesh_error(path, "m", "open surface")
    assert "3 boundary edges" in str(err)
    fixed = load_surface_mesh(path, units="m", repair=True)
    assert any("filled holes" in r for r in fixed.repairs)
    assert fixed.trimesh().is_watertight


def test_non_manifold_edges(tmp_path):
    v, f = cube()
    # a fin: a third face on an existing edge
    v2 = np.vstack([v, [[5.0, 5.0, 5.0]]])
    f2 = np.vstack([f, [[f[0, 0], f[0, 1], len(v)]]])
    expect_mesh_error(write_obj(tmp_path / "fin.obj", v2, f2), "m", "non-manifold edges")


def test_degenerate_faces(tmp_path):
    v, f = cube()
    v2 = np.vstack([v, v[f[0, 0]] + [0.0, 0.0, 0.0]])
    f2 = np.vstack([f, [[f[0, 0], f[0, 1], f[0, 1]]]])
    err = expect_mesh_error(write_obj(tmp_path / "deg.obj", v2, f2), "m", "degenerate")
    assert "first index 12" in str(err)


def test_inside_out_and_mixed_orientation(tmp_path):
    v, f = cube()
    expect_mesh_error(write_obj(tmp_path / "inv.obj", v, f[:, ::-1]), "m", "inside-out")
    fixed = load_surface_mesh(str(tmp_path / "inv.obj"), units="m", repair=True)
    assert fixed.trimesh().volume == pytest.approx(2.0)
    mixed = f.copy()
    mixed[:3] = mixed[:3, ::-1]
    expect_mesh_error(write_obj(tmp_path / "mixed.obj", v, mixed), "m", "mixed face orientation")


def test_units_must_be_declared(tmp_path):
    path = write_obj(tmp_path / "cube.obj", *cube())
    with pytest.raises(ConfigError, match="units"):
        load_surface_mesh(path, units=None)
    with pytest.raises(ConfigError, match="furlong"):
        load_surface_mesh(path, units="furlong")


def write_tets(path, verts, tets) -> str:
    meshio.write(str(path), meshio.Mesh(verts, [("tetra", tets)]))
    return str(path)


def test_tet_mesh_orientation_errors_and_repair(tmp_path):
    mesh, _ = tetrahedralize(Box((0.2, 0.1, 0.05)), 0.02)
    inverted = mesh.tets[:, [0, 2, 1, 3]]
    with pytest.raises(MeshError, match="inside out"):
        load_tet_mesh(write_tets(tmp_path / "inv.vtu", mesh.verts, inverted), units="m")
    mixed = mesh.tets.copy()
    mixed[7] = mixed[7, [0, 2, 1, 3]]
    path = write_tets(tmp_path / "mixed.vtu", mesh.verts, mixed)
    with pytest.raises(MeshError, match="mixed orientation.*first index 7"):
        load_tet_mesh(path, units="m")
    fixed, repairs = load_tet_mesh(path, units="m", repair=True)
    assert repairs and "flipped 1" in repairs[0]
    assert fixed.volume == pytest.approx(0.2 * 0.1 * 0.05)


def test_zero_volume_and_non_manifold_tets(tmp_path):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]], dtype=float)
    flat = np.array([[0, 1, 2, 3], [0, 1, 4, 2]])  # the second is flat (all z = 0)
    with pytest.raises(MeshError, match="zero-volume tets.*first index 1"):
        load_tet_mesh(write_tets(tmp_path / "flat.vtu", v, flat), units="m")
    v3 = np.vstack([v, [[0.3, 0.3, -1], [0.2, 0.2, 2]]])
    three = np.array([[0, 1, 2, 3], [0, 2, 1, 5], [0, 1, 2, 6]])
    three[2] = three[2, [0, 2, 1, 3]] if np.linalg.det(v3[three[2, 1:]] - v3[three[2, 0]]) < 0 else three[2]
    with pytest.raises(MeshError, match="non-manifold"):
        load_tet_mesh(write_tets(tmp_path / "three.vtu", v3, three), units="m")


def test_check_command_prints_table_and_errors_without_traceback(tmp_path):
    ok = subprocess.run(
        [sys.executable, "main.py", "check", "box", "--resolution", "0.02"],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )
    assert ok.returncode == 0, ok.stderr
    assert "physical particles" in ok.stdout and "boundary particles" in ok.stdout
    bad = subprocess.run(
        [sys.executable, "main.py", "check", str(tmp_path / "missing.obj"), "--units", "m", "--resolution", "0.1"],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )
    assert bad.returncode == 2
    assert "file not found" in bad.stderr and "Traceback" not in bad.stderr
