"""The build cache (geometry/build_cache.py) beyond Netgen's tets (test_geometry_mesher.py): a shape's
accepted mesh by its own state (Sect. 5.1), the boundary spheres' candidate search (Sect. 5.3) and the
WPCA kernels (Sect. 4.1). A cached build gives the same objects bit for bit, and a run whose objects
were built before imports neither scipy nor Netgen before its first frame."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from geometry.boundary import build_boundary_particles
from geometry.build import build_object
from geometry.build_cache import CACHE_ENV

ROOT = Path(__file__).resolve().parents[2]


def _spheres(ps, cache: bool):
    return build_boundary_particles(ps.centroid, ps.radius, ps.mass, ps.body, ps.surface, 4,
                                    rest_verts=ps.rest_verts, free_faces=ps.links < 0, cache=cache)


def _same(a, b) -> bool:
    return all(np.array_equal(getattr(a, f), getattr(b, f))
               for f in ("position", "radius", "mass", "body", "member_start", "members"))


def test_cached_groups_give_the_spheres_of_the_search_whatever_the_cache_holds(tmp_path, monkeypatch):
    ps = build_object("sphere", resolution=0.02).particles
    reference = _spheres(ps, cache=False)
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    assert _same(_spheres(ps, cache=True), reference)  # a miss: searched and stored
    entries = list((tmp_path / "boundary").glob("*.npz"))
    assert len(entries) == 1
    assert _same(_spheres(ps, cache=True), reference)  # a hit
    moved = replace(ps, centroid=ps.centroid + 1e-3)  # other points: another entry
    _spheres(moved, cache=True)
    assert len(list((tmp_path / "boundary").glob("*.npz"))) == 2
    entries[0].write_bytes(b"not an npz")  # unreadable: searched again
    assert _same(_spheres(ps, cache=True), reference)
    with np.load(entries[0]) as data:  # readable but group 0 missing (not a grouping): grouped again
        gid = data["gid"]
    np.savez(entries[0], gid=gid + 1)
    assert _same(_spheres(ps, cache=True), reference)
    monkeypatch.setenv(CACHE_ENV, "off")
    assert _same(_spheres(ps, cache=True), reference)


def test_an_event_searches_without_the_cache(tmp_path, monkeypatch):
    """Only whole objects at their build are kept (`cache=True`): the pieces of an event are new every time."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    ps = build_object("sphere", resolution=0.02).particles
    _spheres(ps, cache=False)
    assert not (tmp_path / "boundary").exists()


def test_a_world_builds_no_object_spheres_it_does_not_use():
    bare = build_object("sphere", resolution=0.02, boundary=False)
    assert bare.boundary is None and "boundary_particles" not in bare.report
    full = build_object("sphere", resolution=0.02)
    assert full.report["boundary_particles"] == len(full.boundary) > 0
    assert np.array_equal(full.particles.centroid, bare.particles.centroid)


_START = """
import sys
sys.path.insert(0, '.')
from core.runtime import init_taichi
init_taichi('cpu', 'f32', 1)
from scenes.loader import load_scene
from sim.world import World
import render.session, render.draw_process, render.surface_blocks, render.scene_data
w = World(load_scene('pot'), warm_events=False)  # the warm-up's pieces are not run by the build
print(sorted(m for m in sys.modules if m.split('.')[0] in ('scipy', 'netgen')))
from geometry.boundary_groups import _kernel
print('grouping kernel made:', _kernel.cache_info().currsize)
"""


@pytest.mark.skipif(sys.platform != "linux", reason="runs the scene in a subprocess")
def test_a_drawn_runs_build_imports_no_scipy_or_netgen_once_its_objects_were_built(tmp_path):
    """scipy.spatial costs a start 0.45 s, Netgen 0.15 s and the grouping kernel 50 ms; with the objects
    cached, neither the build nor the drawing process's modules import them or make it (the warm-up
    does, sim/warm_up.py: what of it runs before the first frame is bounded by START_WARM_S)."""
    env = {**os.environ, CACHE_ENV: str(tmp_path)}
    runs = [subprocess.run([sys.executable, "-c", _START], cwd=ROOT, capture_output=True, text=True, env=env,
                           timeout=300) for _ in range(2)]
    for r in runs:
        assert r.returncode == 0, r.stderr
    assert "'scipy.spatial'" in runs[0].stdout and "'netgen.occ'" in runs[0].stdout  # built, cache filled
    assert runs[1].stdout.strip().splitlines()[-2:] == ["[]", "grouping kernel made: 0"], runs[1].stdout


def test_cached_wpca_kernels_are_the_computed_ones(tmp_path, monkeypatch):
    from sph.kernel import kernel_wpca

    x = build_object("sphere", resolution=0.02).particles.centroid
    reference = kernel_wpca(x, 0.04, axis_scale=(2.0, 2.0, 1.0))
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    for _ in range(2):  # a miss, then a hit
        assert np.array_equal(kernel_wpca(x, 0.04, axis_scale=(2.0, 2.0, 1.0), cache=True), reference)
    other = kernel_wpca(x, 0.04, axis_scale=(0.5, 0.5, 1.0), cache=True)  # another parameter: another entry
    assert np.array_equal(other, kernel_wpca(x, 0.04, axis_scale=(0.5, 0.5, 1.0)))
    assert not np.array_equal(other, reference)
    assert len(list((tmp_path / "kernels").glob("*.npz"))) == 2


@pytest.mark.parametrize("kind, params, h", [("lathe", dict(profile=[[0.05, 0.0], [0.09, 0.08], [0.06, 0.2]],
                                                             thickness=0.008), 0.01),
                                             ("sphere", dict(radius=0.02), 0.012)])
def test_a_shape_read_by_its_parameters_is_the_mesh_netgen_makes(tmp_path, monkeypatch, kind, params, h):
    """A procedural shape's accepted mesh is kept under the shape's own state: the same tets, regions and
    quality report as Netgen on a fresh solid (the ball's first try fails the bounds), for a hit and a
    miss, and another parameter is another entry."""
    import geometry.netgen_mesher as ng
    from geometry.build import make_shape
    from geometry.tetrahedralize import tetrahedralize

    monkeypatch.setenv(CACHE_ENV, "off")
    ref_mesh, ref_report = tetrahedralize(make_shape(kind, params), h)
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    first = tetrahedralize(make_shape(kind, params), h)
    monkeypatch.setattr(ng.SolidMesher, "__init__", lambda *a: pytest.fail("a hit makes no solid"))
    again = tetrahedralize(make_shape(kind, params), h)
    for mesh, report in (first, again):
        assert np.array_equal(mesh.verts, ref_mesh.verts) and np.array_equal(mesh.tets, ref_mesh.tets)
        assert np.array_equal(mesh.tet_region, ref_mesh.tet_region)
        assert report == ref_report
    assert ref_report["curvature_safety"] == (3.0 if kind == "sphere" else 2.0)
    monkeypatch.undo()
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    other = {**params, "radius": 0.021} if kind == "sphere" else {**params, "thickness": 0.009}
    entries = len(list((tmp_path / "tets").glob("*.npz")))
    tetrahedralize(make_shape(kind, other), h)
    assert len(list((tmp_path / "tets").glob("*.npz"))) > entries
