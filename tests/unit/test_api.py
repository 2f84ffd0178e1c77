"""The Python API (anisofrac, docs/api.md) against known answers: overrides equal the command line's,
free fall, a preview changes nothing, a strike conserves mass and its pieces are the connected parts
of the links (scipy), readouts agree with each other, images and exported files re-read with their
reference libraries, bad arguments raise ConfigError naming the argument."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

import anisofrac as af
from core.runtime import float_eps
from scenes.loader import load_scene, scene_from_dict
from sim.guards import state_hash

G = 9.81  # m/s^2
PLATE = dict(  # a glass plate on a floor, struck from above (about 600 particles)
    scene=dict(name="api_plate", effects=["rigid", "fracture", "subdivision", "shatter", "debris"]),
    materials=[dict(name="glass", density=2500.0, stiffness=dict(model="isotropic", E=7.0e10, nu=0.22),
                    tensile_strength=4.0e7, toughness=8.0, cracks=4)],
    objects=[dict(name="plate", shape=dict(type="box", size=[0.12, 0.02, 0.12]), material="glass", resolution=0.016,
                  position=[0.0, 0.011, 0.0])],
    colliders=[dict(type="plane", normal=[0.0, 1.0, 0.0])],
)
DROP = dict(  # one unbreakable box in free fall, no collider
    scene=dict(name="api_drop", effects=["rigid"], substeps=2),
    materials=[dict(name="stone", density=2600.0, stiffness=dict(model="isotropic", E=5.0e10, nu=0.25),
                    tensile_strength=1.0e7, toughness=50.0)],
    objects=[dict(name="box", shape=dict(type="box", size=[0.1, 0.1, 0.1]), material="stone", resolution=0.05,
                  position=[0.0, 2.0, 0.0], velocity=[0.5, 1.0, 0.0], breakable=False)],
)


@pytest.fixture
def plate(taichi_runtime):
    with af.Simulation(scene_from_dict(PLATE, "api_plate")) as sim:
        yield sim


def test_overrides_match_the_command_line(taichi_runtime):
    as_dict = af.load_config("glass_r3", {"materials.glass.cracks": 5, "objects.ball.velocity": [0.0, 0.0, -3.0],
                                          "materials.glass.kernel": {"mode": "isotropic", "support": 2.0},
                                          "objects.pane.static": True})
    as_text = load_scene("glass_r3", ["materials.glass.cracks=5", "objects.ball.velocity=[0.0, 0.0, -3.0]",
                                      'materials.glass.kernel={mode = "isotropic", support = 2.0}',
                                      "objects.pane.static=true"])
    assert as_dict == as_text
    assert as_dict.materials[0].cracks == 5 and as_dict.objects[1].velocity == [0.0, 0.0, -3.0]


@pytest.mark.parametrize("call, key", [
    (lambda: af.load_config("no_such_scene"), "scene"),
    (lambda: af.load_config("glass_r3", {"materials.glass.cracks": 0}), "materials[0].cracks"),
    (lambda: af.load_config("glass_r3", {"materials.glass.toughness": -1.0}), "materials[0].toughness"),
    (lambda: af.load_config("glass_r3", {"objects.nothing.position": [0, 0, 0]}), "objects"),
    (lambda: af.load_config("glass_r3", 42), "overrides"),
    (lambda: af.load("glass_r3", seed=-1), "load.seed"),
    (lambda: af.load("x" * 300), "scene"),  # no usable file name: not an OSError
    (lambda: af.load(42), "load.scene"),
    (lambda: af.load(af.load_config("glass_r3"), {"materials.glass.cracks": 5}), "load.overrides"),
])
def test_bad_arguments_name_the_problem(taichi_runtime, call, key):
    with pytest.raises(af.ConfigError) as err:
        call()
    assert key in str(err.value)


def test_free_fall(taichi_runtime):
    """Centre of mass under gravity: y = y0 + v0 t - g t^2 / 2 up to the symplectic-Euler lag
    g h t / 2 < g dt t / 2; x moves at v0 exactly. Built by `load` from a SceneConfig."""
    with af.load(scene_from_dict(DROP, "api_drop")) as sim:
        (b0,) = sim.bodies()
        sim.step(30)
        (b,) = sim.bodies()
        t = sim.time
        assert t == pytest.approx(30 * sim.dt)
        eps = 64 * float_eps()  # the precision in use
        assert b.velocity[1] == pytest.approx(1.0 - G * t, abs=eps * (1.0 + G * t) * 30)
        y_cont = b0.position[1] + 1.0 * t - 0.5 * G * t * t
        assert 0.0 <= y_cont - b.position[1] <= 0.5 * G * sim.dt * t + eps * 2.0 * 30
        assert b.position[0] - b0.position[0] == pytest.approx(0.5 * t, rel=1e-5)
        assert b.mass == pytest.approx(2600.0 * 0.1**3, rel=1e-5) and not b.breakable


def test_preview_changes_nothing_and_strike_breaks(plate):
    sim = plate
    top = sim.surface_point("plate", [0.0, -1.0, 0.0])
    assert top[1] == pytest.approx(0.021, abs=1e-6)  # the plate's top face
    before = state_hash(sim.world)
    pre = sim.preview("plate", top, [0.0, -1.0, 0.0])
    assert state_hash(sim.world) == before and sim.pieces()["total"] == 1
    assert np.isfinite(pre.threshold_speed) and pre.threshold_speed > 1.0
    assert not pre.fired.any() and not pre.cracks  # 1 m/s is below the threshold
    v = 2.0 * pre.threshold_speed
    hot = sim.preview("plate", top, [0.0, -v, 0.0])
    assert hot.fired.all() and len(hot.cracks) == 4 and state_hash(sim.world) == before
    strength = sim.config.materials[0].tensile_strength
    assert np.array_equal(hot.fired, hot.peak_tension > strength)  # Rankine on the peak member tension
    assert pre.peak_tension.max() < strength
    m0 = sim.particles().mass.sum()
    record = sim.strike("plate", top, [0.0, -v, 0.0])
    assert record is not None and record["cracks"] == 4 and sim.events()[-1] is record
    event_stages = {"fracture.analysis", "fracture.subdivision", "fracture.shatter", "fracture.split"}
    assert event_stages <= set(sim.world.timers.total)  # each timed under its own name (sim/stages.py)
    parts = sim.particles()
    assert parts.mass.sum() == pytest.approx(m0, rel=1e-12)  # mass conserved exactly (float64 host data)
    pieces = sim.pieces()
    assert pieces["total"] >= 4 and pieces["total"] == sim.stats()["table1"]["fragments"]
    # the pieces are the connected parts of the links (an independent count by scipy)
    links = sim.links()
    n = len(sim.world.particles)
    graph = coo_matrix((np.ones(len(links)), (links[:, 0], links[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    assert len(np.unique(label[parts.id])) == pieces["total"]
    # every link joins two particles of one piece, and face links are mutual
    ps = sim.world.particles
    i, k = np.nonzero(ps.links >= 0)
    j = ps.links[i, k]
    live = ps.alive[i] & ps.alive[j]
    assert all(i_ in ps.links[j_] for i_, j_ in zip(i[live], j[live]))
    assert np.all(parts.body[np.isin(parts.id, links)] >= 0)


def test_particle_kinds_partition_the_store(plate):
    sim = plate
    top = sim.surface_point("plate", [0.0, -1.0, 0.0])
    sim.strike("plate", top, [0.0, -30.0, 0.0])
    every = sim.particles()
    phys, sub = sim.particles("physical"), sim.particles("subdivided")
    assert len(phys) + len(sub) == len(every) and len(sub) > 0
    assert set(phys.id) | set(sub.id) == set(every.id)
    # children fill their parent exactly (Sect. 5.2: subdivision conserves volume)
    allp = sim.particles(include_replaced=True)
    vol = dict(zip(allp.id, allp.volume))
    roots = np.unique(sub.parent)
    for p in roots[:20]:
        kids = allp.id[allp.parent == p]
        assert sum(vol[c] for c in kids) == pytest.approx(vol[p], rel=1e-9)
    assert np.all(np.isfinite(every.x[every.body >= 0]))
    assert np.allclose(every.verts_ref.mean(axis=1), every.x_ref, atol=1e-12)  # a tet's centroid
    deb = sim.debris()
    assert np.array_equal(np.sort(deb["particle"]), np.sort(every.id[every.body < 0]))
    with pytest.raises(af.ConfigError, match="particles.kind"):
        sim.particles("boundary")


def test_boundary_particles_belong_to_live_bodies(plate):
    bp = plate.boundary_particles()
    ids = {b.id for b in plate.bodies()}
    assert len(bp["x"]) == plate.stats()["table1"]["boundary_particles"]
    assert set(np.unique(bp["body"])) <= ids and np.all(bp["radius"] > 0.0)
    lo, hi = bp["x"].min(0), bp["x"].max(0)
    assert np.all(lo >= [-0.07, -0.01, -0.07]) and np.all(hi <= [0.07, 0.03, 0.07])  # inside the plate's box


def test_strike_arguments(plate):
    top = plate.surface_point("plate", [0.0, -1.0, 0.0])
    bad = [(top, [0.0, 0.0, 0.0], "strike.velocity"), ([0.0, np.nan, 0.0], [0, -1, 0], "strike.point"),
           (top, [1.0, 2.0], "strike.velocity"), (top + [0.5, 0.0, 0.0], [0, -1, 0], "strike.point")]
    for point, velocity, key in bad:
        with pytest.raises(af.ConfigError, match=key):
            plate.strike("plate", point, velocity)
    with pytest.raises(af.ConfigError, match="preview.point"):  # off the body: it would crack nothing, silently
        plate.preview("plate", top + [0.2, 0.0, 0.0], [0.0, -1.0, 0.0])
    with pytest.raises(af.ConfigError, match="body_of.name"):
        plate.strike("nothing", top, [0.0, -1.0, 0.0])
    with pytest.raises(af.ConfigError, match="strike.body"):
        plate.strike(99, top, [0.0, -1.0, 0.0])
    with pytest.raises(af.ConfigError, match="step.frames"):
        plate.step(0)


def test_render_and_export_reread(plate, tmp_path):
    import meshio
    import trimesh
    from PIL import Image

    sim = plate
    img = sim.render(160, 120)
    assert img.shape == (120, 160, 3) and img.dtype == np.uint8 and img.std() > 5.0
    away = sim.render(160, 120, camera=dict(eye=[0.0, 0.3, 0.5], target=[0.0, 0.3, 1.5]))
    assert np.abs(away.astype(int) - img.astype(int)).mean() > 5.0  # the plate is out of that view
    with pytest.raises(af.ConfigError, match="render.camera"):
        sim.render(160, 120, camera=dict(eye=[0, 0, 1]))
    sim.strike("plate", sim.surface_point("plate", [0.0, -1.0, 0.0]), [0.0, -30.0, 0.0])
    obj = sim.export(tmp_path / "state.obj")
    mesh = trimesh.load(obj, process=False)
    verts, faces, _ = sim.fragment_mesh()
    assert len(mesh.faces) == len(faces) and np.allclose(mesh.vertices, verts, atol=1e-6)
    vtu = meshio.read(sim.export(tmp_path / "state.vtu"))
    parts = sim.particles()
    tracked = np.all(np.isfinite(parts.x), axis=1)
    assert len(vtu.points) == tracked.sum()
    assert vtu.point_data["mass"].sum() == pytest.approx(parts.mass[tracked].sum(), rel=1e-12)
    png = np.asarray(Image.open(sim.export(tmp_path / "state.png")).convert("RGB"))
    assert np.array_equal(png, sim.render())
    with pytest.raises(af.ConfigError, match="export.path"):
        sim.export(tmp_path / "state.stl")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["state.obj", "state.png", "state.vtu"]  # no temporaries


def test_close_frees_the_world(taichi_runtime):
    sim = af.Simulation(scene_from_dict(DROP, "api_drop"))
    sim.render(64, 48)
    assert sim.world.allocations
    sim.close()
    assert not sim.world.allocations and not sim._views
