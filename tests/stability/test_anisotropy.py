"""Extreme kernel anisotropy: axis ratios 1, 10 and 100 requested through the scene's kernel table.

What is clamped (sph/kernel.py, scenes/config.py): WPCA's own shape (the neighbourhood's standard
deviations) is clamped to a longest/shortest axis ratio of `kernel.max_ratio` (schema: 1 to 20,
default 4) and its volume kept at that of the isotropic kernel (det G = 1/h^3); `kernel.axis_scale`
then multiplies the axes without a further clamp, within the schema's 0.01 to 100 per axis. So a
requested ratio is honoured exactly; the elastic time step follows the shortest axis.
Criteria: finite, positive definite kernels; finite gradient weights; a few hundred elastic steps
after a random kick stay finite with the total energy within 5% (undamped velocity Verlet).
"""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import ConfigError
from scenes.loader import load_scene, scene_from_dict
from sim.guards import check_neighbourhoods
from sim.world import World
from sph.kernel import kernel_grad_np, kernel_w_np, kernel_wpca
from tests.stability.helpers import material

RATIOS = [1.0, 10.0, 100.0]


def axis_ratios(G: np.ndarray) -> np.ndarray:
    ev = np.linalg.eigvalsh(G)
    assert np.all(np.isfinite(ev)) and ev.min() > 0.0
    return ev[:, -1] / ev[:, 0]


def kicked_energy(eff, steps: int = 300, seed: int = 0) -> tuple[float, np.ndarray]:
    """Kick every free particle with a random zero-mean velocity (1 cm/s); (E0, totals every 50 steps)."""
    x0 = eff.positions()
    v = 1e-2 * np.random.default_rng(seed).standard_normal(x0.shape)
    v -= v.mean(0)
    eff.set_state(x0, v)
    e0 = eff.energies()["total"]
    es = []
    for _ in range(steps // 50):
        eff.step(50)
        assert np.all(np.isfinite(eff.positions())) and np.all(np.isfinite(eff.velocities()))
        es.append(eff.energies()["total"])
    return e0, np.array(es)


@pytest.mark.parametrize("ratio", RATIOS)
def test_fixed_kernel_ratio_is_honoured_and_stable(ratio):
    """The wire's kernel (axes fixed along the wire) with axis_scale [ratio, 1, 1]."""
    cfg = load_scene("wire", ["objects.wire.shape.length=0.12", "scene.elastic_damping=0",
                              f"materials.soft_wire.kernel.axis_scale=[{ratio},1,1]"])
    w = World(cfg)
    try:
        r = axis_ratios(w.kernel_G)
        assert np.allclose(r, ratio, rtol=1e-9)
        assert np.all(np.isfinite(w.elastic.sph.nbr_d.to_numpy()))  # gradient weights d_ij (Eq. 10)
        check_neighbourhoods(w.elastic)
        e0, es = kicked_energy(w.elastic)
        assert np.abs(es - e0).max() < 0.05 * e0
    finally:
        w.release()


@pytest.mark.parametrize("k_r", [1.0, 4.0, 20.0])
def test_wpca_ratio_is_clamped_and_axis_scale_applied_after(k_r):
    """A nearly flat point set (two layers 0.1 mm apart, 1 cm spacing): WPCA's ratio hits the clamp k_r
    exactly inside the sheet, det G = 1/h^3; axis_scale (1, 1, 1/s) then multiplies it by s."""
    d = 0.01
    g = np.arange(10) * d
    X, Y, Z = np.meshgrid(g, g, [0.0, 1e-4], indexing="ij")
    x = np.stack([X.ravel(), Y.ravel(), Z.ravel()], 1)
    x[:, :2] += np.random.default_rng(3).uniform(-0.05, 0.05, (len(x), 2)) * d
    h = 2.5 * d
    G = kernel_wpca(x, h, k_r=k_r)
    r = axis_ratios(G)
    assert r.max() <= k_r * (1 + 1e-9)
    inner = np.all((x[:, :2] > 3 * d) & (x[:, :2] < 6 * d), axis=1)
    assert np.allclose(r[inner], k_r, rtol=1e-9)
    assert np.allclose(np.linalg.det(G) * h**3, 1.0, rtol=1e-9)
    for s in RATIOS:
        Gs = kernel_wpca(x, h, k_r=k_r, axis_scale=(1.0, 1.0, 1.0 / s))
        rs = axis_ratios(Gs)
        assert np.allclose(rs, r * s, rtol=1e-9)
        # kernel and gradient finite on every pair within the isotropic radius
        i, j = np.nonzero(np.linalg.norm(x[:, None] - x[None], axis=2) < h)
        rij = x[j] - x[i]
        assert np.all(np.isfinite(kernel_w_np(rij, Gs[i]))) and np.all(np.isfinite(kernel_grad_np(rij, Gs[i])))


def wpca_plate(scale) -> dict:
    """An elastic 10 x 10 x 1 cm plate at 1 cm with WPCA kernels (minor axis = the plate normal)."""
    return {
        "scene": {"name": "plate", "effects": ["elastic", "wpca"], "frames": 1, "gravity": [0.0, 0.0, 0.0]},
        "materials": [material("soft", {"model": "isotropic", "E": 1e8, "nu": 0.3}, 1000.0,
                               kernel={"mode": "wpca", "support": 2.0, "axis_scale": list(scale)})],
        "objects": [{"name": "plate", "shape": {"type": "pane", "size": [0.1, 0.1, 0.01]}, "material": "soft",
                     "resolution": 0.01}],
    }


def _plate_steps(scale) -> None:
    w = World(scene_from_dict(wpca_plate(scale), "plate"))
    try:
        r = axis_ratios(w.kernel_G)
        assert np.all(np.isfinite(w.elastic.sph.nbr_d.to_numpy()))
        e0, es = kicked_energy(w.elastic, steps=200)
        assert np.abs(es - e0).max() < 0.05 * e0
        return r
    finally:
        w.release()


@pytest.mark.parametrize("ratio", [1.0, 10.0, pytest.param(100.0, marks=pytest.mark.slow)])
def test_wpca_plate_stretched_along_its_surface(ratio):
    r = _plate_steps((ratio, ratio, 1.0))
    assert r.max() <= 4.0 * ratio * (1 + 1e-9)  # the clamp (max_ratio 4) times the requested factor


@pytest.mark.parametrize("minor", [0.5, 0.35])  # the plate is one tet thick: 0.3 already sees coplanar neighbours
def test_wpca_plate_shrunk_across_a_little(minor):
    _plate_steps((1.0, 1.0, minor))


@pytest.mark.xfail(strict=True, reason="sph/corotated.py: with WPCA kernels shrunk across a plate one particle "
                   "spacing thick (axis_scale minor 0.1: 6 of 989 particles at order 0; 0.01: 752), particles whose "
                   "neighbours are all coplanar fall back to the plain gradient with a rank-deficient F and their "
                   "corotated forces grow: energy x450 in 200 steps (0.1), NaN (0.01), also at a tenth of the "
                   "step. sim.guards.check_neighbourhoods refuses such an effect at build time.")
@pytest.mark.parametrize("ratio", [10.0, 100.0])
def test_wpca_plate_shrunk_across(ratio):
    _plate_steps((1.0, 1.0, 1.0 / ratio))


@pytest.mark.parametrize("minor", [0.1, 0.01])
def test_neighbourhood_guard_refuses_the_unstable_plates(minor):
    # the World runs the guard when it builds the elastic effect
    with pytest.raises(ConfigError) as info:
        World(scene_from_dict(wpca_plate((1.0, 1.0, minor)), "plate"))
    assert "neighbours in three dimensions" in str(info.value) and "particles have none" in str(info.value)
    w = World(scene_from_dict(wpca_plate((1.0, 1.0, 0.35)), "plate"))  # stable (tested above): accepted
    try:
        check_neighbourhoods(w.elastic)
    finally:
        w.release()


@pytest.mark.parametrize("key,value,allowed", [
    ("kernel.axis_scale", "[1000,1,1]", "<= 100"),
    ("kernel.axis_scale", "[1,1,0.001]", ">= 0.01"),
    ("kernel.max_ratio", "25", "<= 20"),
])
def test_anisotropy_beyond_the_schema_is_refused(key, value, allowed):
    with pytest.raises(ConfigError) as info:
        load_scene("pot_aniso_high", [f"materials.porcelain.{key}={value}"])
    assert f"materials[0].{key}" in str(info.value) and allowed in str(info.value)
