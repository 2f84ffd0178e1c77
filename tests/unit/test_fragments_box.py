"""Fragments and their surfaces: exact splits of a box, long cut sequences, closed surfaces."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from geometry.cutting import Crack, segment_crosses
from geometry.fragments import apply_cracks, fragment_labels, fragment_volumes
from geometry.subdivision import min_child_volume_ratio
from geometry.surface import edge_imbalance, enclosed_volumes, fragment_surfaces
from tests.unit.test_cut_links import check_links
from tests.unit.test_cut_meshes import delaunay_block, kuhn_box, particles


def check_surfaces(ps, labels, rel: float = 1e-9) -> None:
    """Closed, consistently oriented surfaces enclosing each fragment's tet volume."""
    surf = fragment_surfaces(ps, labels)
    assert surf.open_edges == 0
    assert edge_imbalance(surf.faces) == 0
    vol = fragment_volumes(ps, labels)
    enc = enclosed_volumes(surf)
    assert len(enc) == len(vol)
    assert np.all(np.abs(enc - vol) <= rel * vol + 1e-15 * vol.sum())
    # no degenerate triangle
    v = surf.verts[surf.faces]
    area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    assert area.min() > 0.0


def test_box_cut_through_its_middle():
    """Adaptive mode splits the box exactly in halves (a plane through the centre of a box splits
    it into equal volumes); basic mode's error is measured and printed."""
    ps = particles(kuhn_box(5, 5, 5, jitter=0.1, seed=11))
    crack = Crack(point=[0.5, 0.5, 0.5], normal=[0.05, 0.03, 1.0], r_outer=2.0)
    out, rep = apply_cracks(ps, [crack], mode="subdivision")
    assert rep.subdivision[0].snapped_vertices == 0  # precondition: no vertex near the plane
    assert rep.n_fragments == 2
    vol = fragment_volumes(out, rep.labels)
    assert np.all(np.abs(vol - 0.5) <= 1e-9 * 0.5)
    check_surfaces(out, rep.labels)
    check_links(out)
    basic, brep = apply_cracks(ps, [crack], mode="basic")
    assert brep.n_fragments == 2
    bvol = fragment_volumes(basic, brep.labels)
    err = float(np.abs(bvol - 0.5).max() / 0.5)
    print(
        f"\nbox 5x5x5 cells (750 tets) cut through its middle: fragment volume error "
        f"adaptive {np.abs(vol - 0.5).max() / 0.5:.2e}, basic {err:.2e}"
    )
    assert 1e-4 < err < 0.2  # basic mode follows the tets: a visible but bounded error
    check_surfaces(basic, brep.labels)


def test_plane_through_a_vertex_layer_snaps_to_the_faces():
    """A plane through (or within the snap distance of) a layer of vertices is not subdivided:
    the cut follows the mesh faces, in both modes, and the split is exact."""
    ps = particles(kuhn_box(4, 4, 4))
    for z in (0.5, 0.5 + 1e-10, 0.5 - 1e-7):
        crack = Crack(point=[0.5, 0.5, z], normal=[0, 0, 1], r_outer=2.0)
        for mode in ("basic", "subdivision"):
            out, rep = apply_cracks(ps, [crack], mode=mode)
            assert len(out) == len(ps)  # no children
            vol = fragment_volumes(out, rep.labels)
            assert rep.n_fragments == 2
            assert np.all(np.abs(vol - 0.5) <= 1e-9)
            check_surfaces(out, rep.labels)


def test_fifty_random_cuts_through_a_750_tet_block():
    ps = particles(kuhn_box(5, 5, 5, jitter=0.2, seed=3))
    assert len(ps) == 750
    total = ps.volume.sum()
    rng = np.random.default_rng(2024)
    history: list[Crack] = []
    for it in range(50):
        side = rng.normal(size=3) if rng.random() < 0.6 else None
        crack = Crack(
            point=rng.uniform(0.1, 0.9, 3),
            normal=rng.normal(size=3),
            r_outer=rng.uniform(0.15, 0.9),
            side=side,
        )
        ps, rep = apply_cracks(ps, [crack], mode="subdivision", history=history)
        history.append(crack)
        alive = ps.alive
        assert abs(ps.volume[alive].sum() - total) <= 1e-9 * total
        assert ps.volume[alive].min() > 0.0
        kids = np.flatnonzero(ps.parent >= 0)
        assert np.all(ps.volume[kids] >= min_child_volume_ratio() * ps.volume[ps.parent[kids]] * (1 - 1e-9))
        if it % 10 == 9:
            check_surfaces(ps, rep.labels)
    check_links(ps)
    # no link crosses any of the 50 cracks
    i, k = np.nonzero(ps.links >= 0)
    pairs = np.concatenate([np.stack([i, ps.links[i, k]], 1), ps.extra_links])
    for c in history:
        assert not segment_crosses(c, ps.centroid[pairs[:, 0]], ps.centroid[pairs[:, 1]]).any()
    assert rep.n_fragments > 10


def test_labels_match_an_independent_union_find():
    ps = particles(kuhn_box(4, 4, 4, jitter=0.2, seed=5))
    cracks = [
        Crack(point=[0.5, 0.5, 0.5], normal=n, r_outer=0.6, side=s)
        for n, s in (([0, 0, 1], None), ([1, 0.2, 0], [0, 1, 0]), ([0.1, 1, 0.3], [-1, 0, 0]))
    ]
    out, rep = apply_cracks(ps, cracks, mode="subdivision", shatter=False)
    parent = list(range(len(out)))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b in out.link_pairs().tolist():
        parent[find(a)] = find(b)
    roots = [find(a) for a in range(len(out))]
    alive = np.flatnonzero(out.alive)
    lab = rep.labels
    assert np.all(lab[~out.alive] == -1)
    # same partition, labels numbered by smallest member
    for a in alive[:: max(1, len(alive) // 300)]:
        same = np.array([roots[b] == roots[a] for b in alive])
        assert np.array_equal(lab[alive] == lab[a], same)
    firsts = [alive[lab[alive] == f].min() for f in range(rep.n_fragments)]
    assert firsts == sorted(firsts)


@settings(max_examples=12, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 10_000), st.sampled_from(["basic", "subdivision"]))
def test_surfaces_closed_on_an_irregular_delaunay_block(seed, mode):
    ps = particles(delaunay_block(5, 5, 5, seed=seed % 7))
    rng = np.random.default_rng(seed)
    history: list[Crack] = []
    for _ in range(3):
        cracks = [
            Crack(
                point=rng.uniform(0.2, 0.8, 3),
                normal=rng.normal(size=3),
                r_outer=rng.uniform(0.2, 1.0),
                side=rng.normal(size=3) if rng.random() < 0.5 else None,
                r_inner=rng.choice([0.0, 0.1]),
            )
            for _ in range(rng.integers(1, 4))
        ]
        ps, rep = apply_cracks(ps, cracks, mode=mode, shatter=True, history=history)
        history += cracks
    check_links(ps)
    check_surfaces(ps, rep.labels)
    assert rep.labels.max() + 1 == rep.n_fragments
    np.testing.assert_array_equal(fragment_labels(ps), rep.labels)


def box_below_plane(size, normal, point) -> float:
    """Exact volume of box [0, size] with n . (x - point) <= 0 (inclusion-exclusion over corners)."""
    n = np.asarray(normal, dtype=np.float64).copy()
    c = float(n @ np.asarray(point, dtype=np.float64))
    for a in range(3):
        if n[a] < 0:
            c -= n[a] * size[a]
            n[a] = -n[a]
    total = 0.0
    for corner in np.ndindex(2, 2, 2):
        v = np.array(corner) * size
        total += (-1) ** sum(corner) * max(0.0, c - float(n @ v)) ** 3
    return total / (6.0 * n.prod())


@settings(max_examples=15, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 10_000))
def test_adaptive_split_matches_the_exact_box_split(seed):
    """Any plane through the box: adaptive mode reproduces the analytic split (Sect. 5.2: "we can
    obtain the analytical result") exactly when no vertex is snapped (snap_rel = 0 here)."""
    rng = np.random.default_rng(seed)
    ps = particles(kuhn_box(4, 4, 4, jitter=0.2, seed=seed % 5))
    normal = rng.normal(size=3)
    normal[np.abs(normal) < 0.05] = 0.05
    point = rng.uniform(0.3, 0.7, 3)
    crack = Crack(point=point, normal=normal, r_outer=5.0)
    out, rep = apply_cracks(ps, [crack], mode="subdivision", snap_rel=0.0)
    assert rep.n_fragments == 2
    vol = fragment_volumes(out, rep.labels)
    side0 = (out.centroid[rep.labels == 0] - crack.point) @ crack.normal
    below = box_below_plane(np.ones(3), normal, point)
    expect = np.array([below, 1.0 - below]) if side0.max() < 0 else np.array([1.0 - below, below])
    np.testing.assert_allclose(vol, expect, rtol=1e-9)
    check_surfaces(out, rep.labels)


_SURFACES_CHILD = """
import pickle, sys
from geometry.surface import fragment_surfaces
ps, labels = pickle.load(open(sys.argv[1], "rb"))
before = set(sys.modules)
surf = fragment_surfaces(ps, labels)
assert surf.open_edges == 0
print(sorted(m for m in set(sys.modules) - before if m.split(".")[0] == "scipy"))
"""


@pytest.mark.parametrize("cut", [True, False])
def test_fragment_surfaces_import_no_scipy(tmp_path, cut):
    """The drawing process makes the fragments' surfaces (render/draw_process.py): a fresh process
    imports no scipy for them, neither for an intact box (a drawn run's first frame) nor for a cut
    one, whose extra links and hanging vertices take every path (geometry/grid_search.py)."""
    import pickle
    import subprocess
    import sys
    from pathlib import Path

    ps = particles(kuhn_box(4, 4, 4, jitter=0.1, seed=3))
    labels = np.zeros(len(ps), np.int64)
    if cut:
        ps, rep = apply_cracks(ps, [Crack(point=[0.5, 0.5, 0.5], normal=[0.05, 0.03, 1.0], r_outer=2.0)],
                               mode="subdivision")
        labels = rep.labels
        assert len(ps.extra_links) > 0  # the path through the extra links' face groups is taken
    data = tmp_path / "surfaces.pkl"
    data.write_bytes(pickle.dumps((ps, labels)))
    root = Path(__file__).resolve().parents[2]
    child = subprocess.run([sys.executable, "-c", _SURFACES_CHILD, str(data)], cwd=root, capture_output=True,
                           text=True, timeout=300)
    assert child.returncode == 0, child.stderr
    assert child.stdout.strip() == "[]"
