"""The viewer's World actions without a window (viewer/actions.py, overlay.py, app.py):
the crack preview draws discs for a strike above the analysis' threshold speed and none below, and
changes nothing; the sliders' kernel tensors reproduce the World's own and stretch the first axis;
a strike cuts and records an event; a shot ball flies in a straight line; the frame logic runs."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import tomllib

from core.runtime import float_eps
from render.pick import ray_cast, scene_triangles
from scenes.loader import scene_from_dict
from viewer.actions import (
    Tuning,
    ball_bodies,
    kernel_tensors,
    preview_strike,
    shoot_ball,
    strike,
)
from viewer.overlay import (
    MATERIAL_COLOURS,
    NO_DATA,
    AnalysisValues,
    ViewerScene,
    crack_segments,
    preview_particles,
)

RES = 0.012  # m: tet size of the test plate (about 1,700 particles)
PLATE = dict(
    scene=dict(name="viewer_plate", effects=["rigid", "fracture", "subdivision", "shatter"], gravity=[0.0, 0.0, 0.0]),
    materials=[dict(name="glass", density=2500.0, stiffness=dict(model="isotropic", E=7.0e10, nu=0.22),
                    tensile_strength=4.0e7, toughness=8.0, cracks=3)],
    objects=[dict(name="plate", shape=dict(type="box", size=[0.12, 0.02, 0.12]), material="glass", resolution=RES,
                  position=[0.0, 0.05, 0.0])],
    colliders=[dict(type="plane", normal=[0.0, 1.0, 0.0])],
    camera=dict(eye=[0.2, 0.3, 0.25], target=[0.0, 0.05, 0.0]),
)


def _world():
    from sim.world import World

    return World(scene_from_dict(PLATE))


@pytest.fixture(scope="module")
def plate(taichi_runtime):
    """A World with one breakable plate and its ViewerScene; the top face hit from above."""
    w = _world()
    view = ViewerScene(w)
    tris, bodies = scene_triangles(view.scene)
    hit = ray_cast([0.01, 1.0, 0.005], [0.0, -1.0, 0.0], tris, bodies)
    yield w, view, hit
    view.release()
    w.release()


def test_hit_on_the_plate_top(plate):
    _, _, hit = plate
    np.testing.assert_allclose(hit.point, [0.01, 0.06, 0.005], atol=1e3 * float_eps())
    np.testing.assert_allclose(hit.normal, [0.0, 1.0, 0.0], atol=1e3 * float_eps())
    assert hit.body == 0


def test_preview_discs_above_threshold_none_below(plate):
    """Below the threshold speed no group fires: no disc, no segment; above it every group fires and the
    half-discs, centred at the hit point (within a tet) with unit normals, stay within r_outer. Nothing
    is applied to the World."""
    w, _, hit = plate
    before = (len(w.particles), len(w.events), w.surface_version, w.kernel_G.copy())
    probe = preview_strike(w, hit, 5.0)
    v_th = probe.threshold_speed
    assert np.isfinite(v_th) and v_th > 0.0
    low = preview_strike(w, hit, 0.5 * v_th)
    assert low.cracks == [] and low.r_inner == 0.0
    assert not np.any(low.analysis.fired)
    a, b, c = crack_segments(low.cracks, low.normal)
    assert len(a) == len(b) == len(c) == 0
    high = preview_strike(w, hit, 2.0 * v_th)
    assert len(high.cracks) == len(high.analysis.members) == 3
    a, b, c = crack_segments(high.cracks, high.normal)
    assert len(a) > 0 and a.shape == b.shape == c.shape
    for cr in high.cracks:
        assert np.linalg.norm(cr.point - hit.point) <= RES  # at the impact (Algorithm 1 may move it inside)
        assert abs(np.linalg.norm(cr.normal) - 1.0) < 1e3 * float_eps()
        assert cr.r_outer > 0.0 and cr.side is not None
    reach = max(max(cr.r_outer for cr in high.cracks), high.r_inner)
    assert np.linalg.norm(np.r_[a, b] - hit.point, axis=1).max() <= reach * (1 + 1e-9) + RES
    np.testing.assert_allclose(high.normal, -hit.normal)  # inward
    # group colours: one sphere per analysed particle; below the threshold every group is dimmed
    x, r, col = preview_particles(w, high)
    assert len(x) == len(r) == len(col) == len(high.particle_ids) > 0
    _, _, col_low = preview_particles(w, low)
    assert col_low.max() < col.max()
    after = (len(w.particles), len(w.events), w.surface_version)
    assert after == before[:3] and np.array_equal(w.kernel_G, before[3])


def test_colour_modes_paint_the_analysed_region(plate):
    """Stress mode paints the faces over the analysed particles and leaves the rest grey; material mode
    paints every plate face with material 0's colour."""
    w, view, hit = plate
    pre = preview_strike(w, hit, 20.0)
    view.data = AnalysisValues.from_analysis(len(w.particles), pre.particle_ids, pre.analysis)
    view.colour_mode = "stress"
    view.refresh()
    n = 3 * view.scene.n_tris
    col = view.scene.corner_color.to_numpy()[:n]
    body = view.scene.corner_body.to_numpy()[:n]
    grey = np.all(np.abs(col - NO_DATA) < 1e-6, axis=1)
    assert np.any(~grey & (body == 0)) and np.any(grey & (body == 0))
    view.colour_mode = "material"
    view.refresh()
    col = view.scene.corner_color.to_numpy()[: 3 * view.scene.n_tris]
    body = view.scene.corner_body.to_numpy()[: 3 * view.scene.n_tris]
    np.testing.assert_allclose(col[body == 0], np.broadcast_to(MATERIAL_COLOURS[0], col[body == 0].shape), atol=1e-6)
    view.colour_mode = "fragment"
    view.refresh()


def test_kernel_axis_factor(plate):
    """Factor 1 reproduces the World's kernels exactly; factor 2 doubles the first support semi-axis
    (isotropic kernel, unrotated object: G = diag(1/(2h), 1/h, 1/h), h = support x resolution)."""
    w, _, _ = plate
    np.testing.assert_array_equal(kernel_tensors(w, 1.0), w.kernel_G)
    h = w.cfg.materials[0].kernel.support * RES
    G2 = kernel_tensors(w, 2.0)
    np.testing.assert_allclose(G2, np.broadcast_to(np.diag([0.5 / h, 1.0 / h, 1.0 / h]), G2.shape), rtol=1e-12)


def test_tuning_reaches_the_analysis(plate):
    """Sliders act on the next analysis: 5 cracks give 5 groups; a doubled strength doubles the threshold
    speed's force (the threshold speed grows); restoring the defaults restores the kernels."""
    w, _, hit = plate
    base = copy.deepcopy(w.cfg)
    t = Tuning.from_config(base)
    v1 = preview_strike(w, hit, 5.0).threshold_speed
    t.cracks, t.strength_factor, t.axis_factor = 5, 2.0, 1.5
    t.apply(w, base)
    assert w.materials[0].tensile_strength == pytest.approx(2.0 * base.materials[0].tensile_strength)
    p = preview_strike(w, hit, 5.0)
    assert len(p.analysis.members) == 5 and p.threshold_speed > v1
    t.cracks, t.strength_factor, t.axis_factor = 3, 1.0, 1.0
    t.apply(w, base)
    np.testing.assert_array_equal(w.kernel_G, kernel_tensors(w, 1.0))
    assert preview_strike(w, hit, 5.0).threshold_speed == pytest.approx(v1, rel=1e-9)


def test_strength_slider_reaches_turned_materials(taichi_runtime):
    """The Tai Chi disc is turned and its slate anisotropic, so the analysis reads a turned copy of the
    slate (World.object_material): the strength slider reaches that copy too, and its cleavage."""
    from sim.world import World

    raw = tomllib.loads((Path(__file__).resolve().parents[2] / "scenes" / "taichi.toml").read_text())
    w = World(scene_from_dict(raw, "taichi"))
    try:
        base = copy.deepcopy(w.cfg)
        slate = w.material_index["black_slate"]
        assert w.object_material(0, slate) is not w.materials[slate]
        t = Tuning.from_config(base)
        t.strength_factor = 0.5
        t.apply(w, base)
        turned = w.object_material(0, slate)
        assert turned.tensile_strength == pytest.approx(0.5 * base.materials[slate].tensile_strength, rel=1e-12)
        expected = 0.5 * base.materials[slate].cleavage["tensile_strength"]
        assert turned.cleavage.tensile_strength == pytest.approx(expected, rel=1e-12)
    finally:
        w.release()


def test_strike_and_ball(taichi_runtime):
    """A strike above the threshold cuts the plate (an event with the viewer's flag, more bodies); the
    analysis values follow the new particles; a ball shot sideways (no gravity, nothing in its way)
    moves by v dt in one frame and keeps the kernel table in step with the particles."""
    w = _world()
    try:
        view = ViewerScene(w)
        tris, bodies = scene_triangles(view.scene)
        hit = ray_cast([0.01, 1.0, 0.005], [0.0, -1.0, 0.0], tris, bodies)
        pre = preview_strike(w, hit, 5.0)
        n_before, v_th = len(w.particles), pre.threshold_speed
        data = AnalysisValues.from_analysis(n_before, pre.particle_ids, pre.analysis)
        version = w.surface_version
        rec = strike(w, hit, 2.0 * v_th)
        assert rec is not None and rec["viewer_strike"] and w.events[-1] is rec
        assert rec["cracks"] == 3 and rec["fragments"] >= 2 and w.surface_version == version + 1
        assert len(data.values(w.particles, "stress")) == len(w.particles) > n_before
        assert len(w.kernel_G) == len(w.particles)
        x0 = np.array([0.5, 0.3, 0.0])
        bid = shoot_ball(w, x0, [1.0, 0.0, 0.0], 3.0)
        assert ball_bodies(w) == [bid] and not w.bodies[bid].breakable
        assert len(w.kernel_G) == len(w.particles)
        c0 = w.rigid.body_state().x[bid].copy()
        w.step_frame()
        c1 = w.rigid.body_state().x[bid]
        np.testing.assert_allclose(c1 - c0, [3.0 * w.dt_frame, 0.0, 0.0], atol=1e-9)
        view.refresh()  # the ball is drawn: its body owns triangles
        assert np.any(view.scene.corner_body.to_numpy()[: 3 * view.scene.n_tris] == bid)
        view.release()
    finally:
        w.release()


def test_viewer_frames_without_a_window(taichi_runtime):
    """The viewer's frame logic with a script and no window (paused: the rigid step is not compiled): a
    strike at the default aim breaks the plate, the toggles put particles and lines into the scene, and
    a reset rebuilds the World."""
    from viewer.app import Viewer
    from viewer.script import parse_script

    script = parse_script("pause@0,set@0:speed=30,toggle@0:preview,toggle@0:kernels,hover@0,strike@1,"
                          "toggle@2:particles,toggle@2:links,colour@2:stress,reset@4")
    v = Viewer(scene_from_dict(PLATE), width=320, height=240, script=script)
    try:
        seen = []
        for _ in range(5):
            v.prepare_frame()
            ps = v.world.particles
            live = int(np.sum(ps.alive & (ps.body >= 0))) + v.world.rigid.n_spheres
            seen.append((len(v.world.events), v.view.scene.n_particles, v.view.scene.n_lines, live))
            v.frame += 1
        assert seen[0][0] == 0 and seen[0][1] > 0 and seen[0][2] > 0  # preview groups, discs and kernels
        assert seen[1][0] == 1 and v.message  # the strike event
        assert seen[2][1] >= seen[2][3] > 0 and seen[2][2] > 0  # every live particle and sphere is drawn
        assert seen[4][0] == 0 and len(v.world.events) == 0  # reset: a fresh World
    finally:
        v.view.release()
        v.world.release()
