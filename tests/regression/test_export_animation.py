"""`--export glb|usd`: the pot run as one animated file, re-read with the reference libraries
(pygltflib for glTF 2.0, pxr from usd-core for USD) and checked against the simulation itself."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import anisofrac as af
from geometry.surface import edge_imbalance
from sim.run import RunOptions

FRAMES = 27  # the pot lands and breaks at frame 21 (a 0.6 m drop at 60 frames/s)


@pytest.fixture(scope="module")
def pot_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("pot_export")
    sim = af.load("pot")
    opts = RunOptions(out=out, frames=FRAMES, renderer="none", video="none", progress=False, until_settled=False,
                      export=("glb", "usd"))
    stats = sim.run_headless(opts)
    yield sim, out, stats
    sim.close()


def _accessor(gltf, index: int) -> np.ndarray:
    acc = gltf.accessors[index]
    view = gltf.bufferViews[acc.bufferView]
    blob = gltf.binary_blob()
    dtype = {5126: np.float32, 5125: np.uint32}[acc.componentType]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[acc.type]
    data = np.frombuffer(blob, dtype=dtype, count=acc.count * width, offset=view.byteOffset + (acc.byteOffset or 0))
    return data.reshape(acc.count, width) if width > 1 else data


def _node_tracks(gltf, node: int) -> dict:
    anim = gltf.animations[0]
    tracks = {}
    for ch in anim.channels:
        if ch.target.node == node:
            s = anim.samplers[ch.sampler]
            tracks[ch.target.path] = (_accessor(gltf, s.input), _accessor(gltf, s.output), s.interpolation)
    return tracks


def enclosed(verts: np.ndarray, tri: np.ndarray) -> float:
    """m^3: the volume a closed triangle surface encloses (divergence theorem, about its mean vertex)."""
    v = verts[tri] - verts.mean(0)
    return float(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6.0)


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(q).apply(v)  # (x, y, z, w), glTF's order


def test_glb_holds_each_piece_once_and_moves_it_like_the_simulation(pot_run):
    import pygltflib

    sim, out, stats = pot_run
    assert stats["exports"] == ["animation.glb", "animation.usd"]
    gltf = pygltflib.GLTF2().load(str(out / "animation.glb"))
    fps = sim.config.scene.fps
    assert len(gltf.nodes) == len(gltf.meshes) == len(gltf.scenes[0].nodes)
    assert len(gltf.animations) == 1
    times = [_accessor(gltf, s.input) for s in gltf.animations[0].samplers]
    assert min(t.min() for t in times) == 0.0
    assert max(t.max() for t in times) == pytest.approx(FRAMES / fps, abs=1e-6)
    assert sim.events(), "the pot must have broken within the exported frames"
    # the pieces alive at the end: one per live body, at the body's pose, with its surface
    verts, faces, label = sim.fragment_mesh()
    live = {b.id: b for b in sim.bodies()}
    ended = {}
    for node_id, node in enumerate(gltf.nodes):
        tracks = _node_tracks(gltf, node_id)
        t_scale, scale, interp = tracks["scale"]
        assert interp == "STEP"
        if scale[-1, 0] == 1.0:  # shown at the end
            body = int(node.name.split("_body_")[1])
            ended[body] = node_id
            t, x, _ = tracks["translation"]
            assert t[-1] == pytest.approx(FRAMES / fps, abs=1e-6)
            assert np.allclose(x[-1], live[body].position, atol=1e-6)
    assert sorted(ended) == sorted(live)
    for body, node_id in ended.items():
        prim = gltf.meshes[gltf.nodes[node_id].mesh].primitives[0]
        local = _accessor(gltf, prim.attributes.POSITION).astype(np.float64)
        tri = _accessor(gltf, prim.indices).reshape(-1, 3)
        tracks = _node_tracks(gltf, node_id)
        world = _rotate(tracks["rotation"][1][-1], local) + tracks["translation"][1][-1]
        mine = verts[label == body]
        assert len(world) == len(mine)
        d, _ = cKDTree(mine).query(world)
        assert d.max() < 1e-5  # m: float32 vertices and quaternions
        # a piece's surface is closed (every edge used in both directions equally, geometry.surface) and
        # holds exactly its particles' tets
        assert edge_imbalance(tri.astype(np.int64)) == 0
        parts = sim.particles()
        assert enclosed(local, tri) == pytest.approx(parts.volume[parts.body == body].sum(), rel=1e-4)


def test_glb_fragments_replace_their_parent_and_volumes_add_up(pot_run):
    import pygltflib

    sim, out, _ = pot_run
    gltf = pygltflib.GLTF2().load(str(out / "animation.glb"))
    fps = sim.config.scene.fps
    shown_at = {}
    volumes = {}
    for node_id, node in enumerate(gltf.nodes):
        t_scale, scale, _ = _node_tracks(gltf, node_id)["scale"]
        start = t_scale[np.argmax(scale[:, 0] == 1.0)]
        end = t_scale[-1] if scale[-1, 0] == 0.0 else None
        shown_at[node_id] = (float(start), end)
        prim = gltf.meshes[node.mesh].primitives[0]
        volumes[node_id] = enclosed(_accessor(gltf, prim.attributes.POSITION).astype(np.float64),
                                    _accessor(gltf, prim.indices).reshape(-1, 3))
    first = [n for n, (s, e) in shown_at.items() if s == 0.0]
    assert len(first) == 1, "the unbroken pot (the scene's one object) is one piece from the first frame"
    event_t = shown_at[first[0]][1]
    assert event_t is not None and 0 < event_t < FRAMES / fps  # replaced when it broke
    assert sum(1 for s, _ in shown_at.values() if s == event_t) >= 2  # by its fragments, from that frame
    # the pieces shown at the end hold the pot's volume, less the shattered particles (debris)
    parts = sim.particles()
    debris = parts.volume[parts.body < 0].sum()
    final = sum(volumes[n] for n, (_, e) in shown_at.items() if e is None)
    assert final + debris == pytest.approx(volumes[first[0]], rel=1e-4)


def test_usd_stage_has_units_axis_time_range_and_the_same_motion(pot_run):
    from pxr import Usd, UsdGeom

    sim, out, _ = pot_run
    stage = Usd.Stage.Open(str(out / "animation.usd"))
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    assert stage.GetStartTimeCode() == 0 and stage.GetEndTimeCode() == FRAMES
    assert stage.GetTimeCodesPerSecond() == sim.config.scene.fps
    pieces = [p for p in stage.GetPrimAtPath("/World").GetChildren()]
    import pygltflib

    gltf = pygltflib.GLTF2().load(str(out / "animation.glb"))
    assert len(pieces) == len(gltf.nodes)
    live = {b.id: b for b in sim.bodies()}
    shown = 0
    for prim in pieces:
        xf = UsdGeom.Xformable(prim)
        vis = UsdGeom.Imageable(prim).GetVisibilityAttr()
        if vis.Get(Usd.TimeCode(FRAMES)) == UsdGeom.Tokens.invisible:
            continue
        shown += 1
        body = prim.GetAttribute("anisofrac:body").Get()
        m = np.array(xf.ComputeLocalToWorldTransform(Usd.TimeCode(FRAMES)))  # row-vector convention
        assert np.allclose(m[3, :3], live[body].position, atol=1e-6)
        mesh = UsdGeom.Mesh(prim.GetChild("mesh"))
        assert len(mesh.GetFaceVertexCountsAttr().Get()) > 0
    assert shown == len(live)
    # a fragment is invisible before it exists
    late = [p for p in pieces if UsdGeom.Imageable(p).GetVisibilityAttr().Get(Usd.TimeCode(0)) == "invisible"]
    assert late, "fragments created by the fracture start hidden"


def test_export_of_a_scene_without_rigid_pieces_is_refused_before_anything_is_written(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "wire"
    r = subprocess.run([sys.executable, "main.py", "run", "wire", "--export", "glb", "--out", str(out)], cwd=root,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "--export" in r.stderr and "rigid" in r.stderr and "Traceback" not in r.stderr
    assert not out.exists()
