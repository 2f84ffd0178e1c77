"""Slivers: cuts within 1e-9 of a vertex, an edge or a face of an irregular tet mesh, and 50 fracture
events on one body in a World. Volumes stay positive (every child at least the guaranteed fraction
of its parent) and conserved, fragment surfaces stay closed, masses and bodies stay consistent."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.cutting import Crack
from geometry.fragments import apply_cracks
from geometry.subdivision import min_child_volume_ratio
from scenes.loader import scene_from_dict
from sim.world import World
from tests.stability.helpers import GLASS, material
from tests.unit.test_cut_links import check_links
from tests.unit.test_cut_meshes import delaunay_block, particles
from tests.unit.test_fragments_box import check_surfaces

OFFSETS = [0.0, 1e-9, -1e-9, 3e-10]  # m (the block is 1 m wide): on the feature and just off it


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def feature_crack(verts: np.ndarray, rng: np.random.Generator, k: int) -> tuple[str, Crack]:
    """A full-disc crack through (or within 1e-9 m of) a vertex (k % 3 == 0), an edge (1) or a face (2)
    of a tet (verts: (T, 4, 3)) away from the mesh boundary; offsets cycle through OFFSETS."""
    c = verts.mean(1)
    lo, hi = c.min(0), c.max(0)
    inner = np.flatnonzero(np.all((c > lo + 0.2 * (hi - lo)) & (c < hi - 0.2 * (hi - lo)), 1))
    t = verts[rng.choice(inner) if inner.size else rng.integers(len(verts))]
    kind = ("vertex", "edge", "face")[k % 3]
    if kind == "vertex":
        p, n = t[0], unit(rng.normal(size=3))
    elif kind == "edge":
        p, n = 0.5 * (t[0] + t[1]), unit(np.cross(t[1] - t[0], rng.normal(size=3)))
    else:
        p, n = t[:3].mean(0), unit(np.cross(t[1] - t[0], t[2] - t[0]))
    off = OFFSETS[(k // 3) % len(OFFSETS)]
    return f"{kind}{off:+.0e}", Crack(point=p + off * n, normal=n, r_outer=10.0)


def check_volumes(ps, total: float) -> None:
    alive = ps.alive
    assert ps.volume[alive].min() > 0.0
    assert abs(ps.volume[alive].sum() - total) <= 1e-12 * total
    kids = np.flatnonzero(ps.parent >= 0)
    if kids.size:
        assert np.all(ps.volume[kids] >= min_child_volume_ratio() * ps.volume[ps.parent[kids]] * (1 - 1e-9))


@pytest.mark.parametrize("mode", ["basic", "subdivision"])
def test_cuts_within_1e9_of_vertices_edges_and_faces(mode):
    ps = particles(delaunay_block(5, 5, 5, jitter=0.3, seed=11))
    total = float(ps.volume.sum())
    rng = np.random.default_rng(5)
    for k in range(24):
        label, crack = feature_crack(ps.rest_verts, rng, k)
        out, rep = apply_cracks(ps, [crack], mode=mode)
        check_volumes(out, total)
        check_links(out)
        check_surfaces(out, rep.labels)
        if mode == "subdivision":
            # an exact plane cut of a convex block leaves exactly two pieces
            assert rep.n_fragments == 2, label


def box_world() -> World:
    raw = {
        "scene": {"name": "slivers", "effects": ["rigid", "fracture", "subdivision"], "frames": 1,
                  "gravity": [0.0, 0.0, 0.0]},
        "materials": [material("glass", GLASS, 2500.0)],
        "objects": [{"name": "box", "shape": {"type": "box", "size": [0.1, 0.08, 0.06]}, "material": "glass",
                     "resolution": 0.02, "position": [0.0, 0.5, 0.0], "angular_velocity": [0.5, -0.2, 0.1]}],
    }
    return World(scene_from_dict(raw, "slivers"))


@pytest.mark.slow
def test_fifty_events_on_one_body():
    """50 fracture events (sim.fracture_stage.cut_body), each cutting the largest fragment near a vertex,
    an edge or a face (within 1e-9 m), half of them half-discs; then ten rigid steps."""
    from sim.fracture_stage import cut_body

    w = box_world()
    try:
        ps0 = w.particles
        total_v = float(ps0.volume.sum())
        m0 = w.mass_balance()["initial_kg"]
        rng = np.random.default_rng(8)
        for event in range(50):
            ps = w.particles
            bodies = [b for b in w.bodies if ps.alive[ps.body == b].any()]
            body = max(bodies, key=lambda b: ps.volume[ps.alive & (ps.body == b)].sum())
            _, crack = feature_crack(ps.rest_verts[ps.alive & (ps.body == body)], rng, event)
            if event % 2:
                crack = Crack(point=crack.point, normal=crack.normal, r_outer=rng.uniform(0.01, 0.05),
                              side=rng.normal(size=3))
            cut_body(w, body, [crack], dict(frame=w.frame, body=body))
            w.surface_version += 1
            ps = w.particles
            check_volumes(ps, total_v)
            bal = w.mass_balance()
            assert abs(bal["error_kg"]) <= 4e-16 * m0
            st = w.rigid.body_state()
            live = np.unique(ps.body[ps.alive])
            assert np.all(st.alive[live])
            assert sum(w.rigid.body_mass(int(b)) for b in live) == pytest.approx(ps.mass[ps.alive].sum(), rel=1e-13)
            for k in ("x", "q", "v", "w"):
                assert np.all(np.isfinite(getattr(st, k)[st.alive]))
            if event % 10 == 9:
                labels = np.where(ps.alive, ps.body, -1).astype(np.int64)
                check_surfaces(ps, labels)
                check_links(ps)
        assert w.fragment_count() > 10
        for _ in range(10):  # the fragments move on (spinning, no gravity): finite, nothing flung
            w.rigid.step(1.0 / 240.0)
        st = w.rigid.body_state()
        assert all(np.all(np.isfinite(getattr(st, k)[st.alive])) for k in ("x", "q", "v", "w"))
        assert np.abs(st.v[st.alive]).max() < 1.0  # rest + spin 0.5 rad/s: no fragment shot away
        assert (w.particles.kind == 1).sum() > len(ps0.volume)  # subdivision happened
    finally:
        w.release()
