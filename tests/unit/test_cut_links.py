"""Crack regions, link removal, subdivision bookkeeping and shattering (Sect. 5.2, Fig. 3, 5)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.errors import ConfigError
from geometry.cutting import (
    Crack,
    crossed_link_mask,
    remove_crossed_links,
    remove_links_crossing_any,
    section_meets_region,
    segment_crosses,
    shatter_particles,
    signed_distance,
    triangle_crosses,
)
from geometry.fragments import apply_cracks, fragment_labels
from geometry.particles import KIND_PHYSICAL, KIND_SUBDIVIDED, ParticleSet, build_particles
from geometry.subdivision import SNAP_REL, subdivide
from geometry.surface import edge_imbalance, fragment_surfaces
from geometry.tetmesh import TET_FACES, TetMesh
from tests.unit.test_cut_meshes import DENSITY, kuhn_box, particles

SETTINGS = settings(
    max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)


@pytest.fixture(scope="module")
def block() -> ParticleSet:
    return particles(kuhn_box(4, 4, 4, jitter=0.2, seed=7))


def check_links(ps: ParticleSet) -> None:
    """Links symmetric, only between alive particles, across coinciding faces; extras canonical."""
    L = ps.links
    i, k = np.nonzero(L >= 0)
    j = L[i, k]
    assert ps.alive[i].all() and ps.alive[j].all()
    back = L[j] == i[:, None]
    assert np.all(back.sum(1) == 1), "face links not symmetric"
    kj = np.argmax(back, 1)
    fi = np.sort(ps.rest_verts[i][np.arange(len(i))[:, None], TET_FACES[k]].reshape(-1, 3, 3), axis=1)
    fj = np.sort(ps.rest_verts[j][np.arange(len(j))[:, None], TET_FACES[kj]].reshape(-1, 3, 3), axis=1)
    assert np.array_equal(np.sort(fi.reshape(len(i), -1), 1), np.sort(fj.reshape(len(j), -1), 1))
    ex = ps.extra_links
    if len(ex):
        assert np.all(ex[:, 0] < ex[:, 1])
        assert len(np.unique(ex, axis=0)) == len(ex)
        assert ps.alive[ex].all()
    assert np.all(ps.links[~ps.alive] < 0)


def crossing_point_inside(crack: Crack, a: np.ndarray, b: np.ndarray, margin: float) -> np.ndarray:
    """Independent formula: segment a-b crosses the plane inside the region by at least margin."""
    da = (a - crack.point) @ crack.normal
    db = (b - crack.point) @ crack.normal
    opposite = da * db < 0
    den = np.where(opposite, db - da, 1.0)
    x = (db[:, None] * a - da[:, None] * b) / den[:, None]
    q = x - crack.point
    inside = np.linalg.norm(q, axis=1) < crack.r_outer - margin
    if crack.side is not None:
        inside &= q @ crack.side > margin
    return opposite & inside


# ---------------------------------------------------------------------------------------------


def test_crack_validation():
    with pytest.raises(ConfigError, match="normal"):
        Crack(point=[0, 0, 0], normal=[0, 0, 0], r_outer=1.0)
    with pytest.raises(ConfigError, match="r_outer"):
        Crack(point=[0, 0, 0], normal=[0, 0, 1], r_outer=-1.0)
    with pytest.raises(ConfigError, match="r_inner"):
        Crack(point=[0, 0, 0], normal=[0, 0, 1], r_outer=1.0, r_inner=float("nan"))
    with pytest.raises(ConfigError, match="side"):
        Crack(point=[0, 0, 0], normal=[0, 0, 1], r_outer=1.0, side=[0, 0, 2])
    with pytest.raises(ConfigError, match="point"):
        Crack(point=[0, 0], normal=[0, 0, 1], r_outer=1.0)
    c = Crack(point=[0, 0, 0], normal=[0, 0, 2], r_outer=1.0, side=[1, 0, 1])
    np.testing.assert_allclose(c.normal, [0, 0, 1])
    np.testing.assert_allclose(c.side, [1, 0, 0])
    assert Crack(point=[0, 0, 0], normal=[0, 0, 1], r_outer=1.0, side=[0, 0, 0]).full_disc


def test_segment_crosses_half_disc():
    c = Crack(point=[0, 0, 0], normal=[0, 0, 1], r_outer=1.0, side=[1, 0, 0])
    a = np.array([[0.5, 0, 1], [-0.5, 0, 1], [0.5, 0, 1], [2, 0, 1], [0.5, 0.5, -1], [0, 0.2, 1]])
    b = np.array([[0.5, 0, -1], [-0.5, 0, -1], [0.5, 0, 2], [2, 0, -1], [0.5, 0.5, 3], [0, 0.2, -1]])
    expect = [True, False, False, False, True, True]
    assert list(segment_crosses(c, a, b)) == expect
    assert list(segment_crosses(c, b, a)) == expect


@SETTINGS
@given(st.integers(0, 10_000))
def test_segment_rule_is_symmetric_and_matches_independent_formula(seed):
    rng = np.random.default_rng(seed)
    side = rng.normal(size=3) if seed % 3 else None
    c = Crack(point=rng.normal(size=3), normal=rng.normal(size=3), r_outer=rng.uniform(0.3, 2), side=side)
    a = rng.normal(size=(400, 3)) * 1.5
    b = a + rng.normal(size=(400, 3))
    got = segment_crosses(c, a, b)
    assert np.array_equal(got, segment_crosses(c, b, a))
    assert np.all(got[crossing_point_inside(c, a, b, 1e-9)])
    far_out = ~crossing_point_inside(c, a, b, -1e-9)  # outside even with a margin
    assert not np.any(got & far_out)


def _sample_region_hit(c: Crack, pts: np.ndarray) -> np.ndarray:
    q = pts - c.point
    ok = np.linalg.norm(q, axis=-1) <= c.r_outer
    if c.side is not None:
        ok &= q @ c.side >= 0
    return ok


@SETTINGS
@given(st.integers(0, 10_000))
def test_triangle_and_section_tests_agree_with_sampling(seed):
    rng = np.random.default_rng(seed)
    side = rng.normal(size=3) if seed % 2 else None
    c = Crack(
        point=rng.normal(size=3) * 0.3, normal=rng.normal(size=3), r_outer=rng.uniform(0.1, 1), side=side
    )
    # triangles: sample the cut segment densely
    tri = rng.normal(size=(60, 3, 3))
    got = triangle_crosses(c, tri)
    d = signed_distance(c, tri)
    for m in range(len(tri)):
        pos = d[m] > 0
        if pos.all() or (~pos).all():
            assert not got[m]
            continue
        lone = int(np.flatnonzero(pos)[0]) if pos.sum() == 1 else int(np.flatnonzero(~pos)[0])
        others = [v for v in range(3) if v != lone]
        ends = [
            tri[m, lone] + d[m, lone] / (d[m, lone] - d[m, o]) * (tri[m, o] - tri[m, lone]) for o in others
        ]
        s = np.linspace(0, 1, 4001)[:, None]
        pts = ends[0] + s * (ends[1] - ends[0])
        q = pts - c.point
        margin = 2e-3 * np.linalg.norm(ends[1] - ends[0]) + 1e-9
        inside_strict = np.linalg.norm(q, axis=1) < c.r_outer - margin
        near = np.linalg.norm(q, axis=1) <= c.r_outer + margin
        if c.side is not None:
            inside_strict &= q @ c.side > margin
            near &= q @ c.side >= -margin
        if inside_strict.any():
            assert got[m]
        if not near.any():
            assert not got[m]
    # tet sections: sample the section polygon (convex hull of the edge points)
    tets = rng.normal(size=(60, 4, 3)) * 0.7
    got = section_meets_region(c, tets)
    d = signed_distance(c, tets)
    for m in range(len(tets)):
        pos = d[m] > 0
        if pos.all() or (~pos).all():
            assert not got[m]
            continue
        pts_e = np.array(
            [
                tets[m, i] + d[m, i] / (d[m, i] - d[m, j]) * (tets[m, j] - tets[m, i])
                for i in range(4)
                for j in range(i + 1, 4)
                if pos[i] != pos[j]
            ]
        )
        w = rng.dirichlet(np.ones(len(pts_e)), size=20000)
        samp = np.concatenate([w @ pts_e, pts_e])
        size = np.linalg.norm(pts_e.max(0) - pts_e.min(0))
        if _sample_region_hit(c, samp).any():
            assert got[m]
        shrunk = Crack(point=c.point, normal=c.normal, r_outer=c.r_outer + 0.05 * size, side=None)
        if not _sample_region_hit(shrunk, samp).any():
            assert not got[m]


# ---------------------------------------------------------------------------------------------


def test_children_attributes_and_bookkeeping(block):
    crack = Crack(point=[0.5, 0.5, 0.5], normal=[0.2, 0.1, 1.0], r_outer=0.35, side=[1, 0, 0])
    ps, rep = subdivide(block, crack)
    assert rep.subdivided > 0 and rep.children == len(ps) - len(block)
    assert sum(rep.cases.values()) + rep.uncut_by_snap == rep.candidates
    n0 = len(block)
    ch = np.arange(n0, len(ps))
    par = ps.parent[ch]
    assert np.array_equal(np.unique(par), np.sort(rep.parents))
    assert np.all(ps.kind[ch] == KIND_SUBDIVIDED) and np.all(ps.kind[:n0] == KIND_PHYSICAL)
    assert not ps.alive[rep.parents].any() and ps.alive[ch].all()
    np.testing.assert_allclose(ps.mass[ch] / ps.volume[ch], DENSITY, rtol=1e-12)
    np.testing.assert_allclose(ps.centroid[ch], ps.rest_verts[ch].mean(1), rtol=0, atol=0)
    np.testing.assert_allclose(ps.radius[ch], np.cbrt(3 * ps.volume[ch] / (4 * np.pi)), rtol=1e-14)
    assert np.array_equal(ps.body[ch], block.body[par]) and np.array_equal(
        ps.material[ch], block.material[par]
    )
    # per parent: children volumes sum to the parent's
    sums = np.bincount(par, weights=ps.volume[ch], minlength=n0)[rep.parents]
    np.testing.assert_allclose(sums, block.volume[rep.parents], rtol=1e-12)
    assert rep.min_volume_ratio >= 0.5 * SNAP_REL**3
    check_links(ps)
    # the input was not modified
    assert block.alive.all() and len(block.extra_links) == 0
    # without link removal, the body stays one piece and its surface is the original boundary
    lab = fragment_labels(ps)
    assert lab.max() == 0
    surf = fragment_surfaces(ps, lab)
    v = surf.verts[surf.faces]
    area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1).sum()
    assert abs(area - 6.0) < 1e-12 and edge_imbalance(surf.faces) == 0


def test_a_subdivided_particle_is_not_subdivided_again(block):
    crack = Crack(point=[0.5, 0.5, 0.5], normal=[0.2, 0.1, 1.0], r_outer=1.0)
    ps, rep1 = subdivide(block, crack)
    ps2, rep2 = subdivide(ps, crack)
    assert rep1.subdivided > 0 and rep2.subdivided == 0 and len(ps2) == len(ps)
    # another crack through the children: they keep their kind, basic removal applies to them
    crack2 = Crack(point=[0.5, 0.5, 0.5], normal=[1.0, 0.1, 0.05], r_outer=1.0)
    ps3, rep3 = apply_cracks(ps, [crack2], mode="subdivision")
    kids = np.arange(len(block), len(ps))
    assert np.all(ps3.parent[len(ps) :] < len(block))  # only physical parents
    assert ps3.alive[kids].all()
    check_links(ps3)


def test_fig5a_bottom_face_meets_three_children():
    """A '3-1' tet whose bottom face neighbour is not cut: the neighbour's face meets the three
    bottom pieces -> three extra links (Fig. 5a); everything stays one closed piece."""
    verts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, 1.0], [0.3, 0.3, -1.0]])
    tets = np.array([[0, 1, 2, 3], [0, 2, 1, 4]])
    ps = build_particles(TetMesh(verts, tets), DENSITY)
    assert ps.links[0, 3] == 1
    crack = Crack(point=[0.3, 0.3, 0.5], normal=[0.05, 0.02, 1.0], r_outer=5.0)
    ps2, rep = subdivide(ps, crack)
    assert rep.cases == {"3-1": 1} and rep.children == 14
    assert rep.new_extra_links == 3
    ex = ps2.extra_links
    assert np.all(ex[:, 0] == 1)
    assert np.all(ps2.links[1] == -1)  # its only neighbour face is now covered by extra links
    check_links(ps2)
    assert fragment_labels(ps2).max() == 0
    surf = fragment_surfaces(ps2, fragment_labels(ps2))
    assert edge_imbalance(surf.faces) == 0
    # only the outer boundary: the shared face is covered (cancelled) on both sides
    v = surf.verts[surf.faces]
    area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1).sum()
    tri = verts[tets][:, [1, 2, 3]], verts[tets][:, [0, 1, 3]], verts[tets][:, [0, 2, 3]]
    outer = sum(
        0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum() for t in tri
    )
    assert abs(area - outer) < 1e-12
    ps3, _ = remove_crossed_links(ps2, crack)
    lab = fragment_labels(ps3)
    assert lab.max() == 1  # the top tet is cut off


def test_links_removed_in_subdivision_mode_are_the_faces_in_the_plane(block):
    """With no snapped vertex, the removed links are exactly the links across faces lying in the
    crack plane (the region spans the block)."""
    crack = Crack(point=[0.5, 0.5, 0.375], normal=[0.06, 0.03, 1.0], r_outer=2.0)  # between vertex layers
    ps, rep = subdivide(block, crack)
    assert rep.snapped_vertices == 0 and rep.subdivided > 0
    d = signed_distance(crack, ps.rest_verts)  # (N, 4)
    i, k = np.nonzero(ps.links >= 0)
    face_d = np.abs(d[i[:, None], TET_FACES[k]]).max(1)
    in_plane = face_d <= 1e-12
    after, n = remove_crossed_links(ps, crack)
    removed = after.links[i, k] < 0
    assert in_plane.sum() > 0 and np.array_equal(removed, in_plane)
    assert n == in_plane.sum() // 2
    # and half-disc cracks remove only links across faces in the plane
    half = Crack(point=[0.5, 0.5, 0.375], normal=[0.06, 0.03, 1.0], r_outer=0.3, side=[0, 1, 0])
    ps, rep = subdivide(block, half)
    assert rep.snapped_vertices == 0
    d = signed_distance(half, ps.rest_verts)
    i, k = np.nonzero(ps.links >= 0)
    face_d = np.abs(d[i[:, None], TET_FACES[k]]).max(1)
    after, _ = remove_crossed_links(ps, half)
    removed = after.links[i, k] < 0
    assert removed.any() and np.all(face_d[removed] <= 1e-12)
    assert len(after.extra_links) == len(ps.extra_links)


@SETTINGS
@given(st.integers(0, 10_000))
def test_links_of_new_children_rechecked_as_crack_by_crack(block, seed):
    """`remove_links_crossing_any` (the earlier cracks against a subdivision's children, found once)
    removes exactly what removing each crack's crossed links in turn removes among the links with a
    marked end, and nothing else."""
    rng = np.random.default_rng(seed)
    point, normal = rng.uniform(0.3, 0.7, 3), rng.normal(size=3)
    ps, rep = subdivide(block, Crack(point=point, normal=normal, r_outer=1.0))
    # the first earlier crack tilted from the new one through its point: it crosses the children's links
    cracks = [Crack(point=point, normal=normal + 0.5 * np.linalg.norm(normal) * rng.normal(size=3), r_outer=1.0)]
    cracks += [Crack(point=rng.uniform(0.2, 0.8, 3), normal=rng.normal(size=3), r_outer=rng.uniform(0.2, 0.8),
                     side=rng.normal(size=3) if rng.random() < 0.5 else None) for _ in range(2)]
    marked = np.zeros(len(ps), dtype=bool)
    marked[rep.first_child:] = True
    marked[rng.choice(rep.first_child, 5, replace=False)] = True  # and some old rows
    expected, n_expected = ps, 0
    for c in cracks:  # crack by crack, each on what the last left, kept to links with a marked end
        face, extra = crossed_link_mask(expected, c)
        L, ex = expected.links, expected.extra_links
        face &= (L >= 0) & (marked[:, None] | marked[np.maximum(L, 0)])
        extra &= marked[ex[:, 0]] | marked[ex[:, 1]] if len(ex) else extra
        links = L.copy()
        links[face] = -1
        n_expected += int(face.sum()) // 2 + int(extra.sum())
        expected = replace(expected, links=links, extra_links=ex[~extra])
    got, n = remove_links_crossing_any(ps, cracks, None, marked)
    assert np.array_equal(got.links, expected.links) and np.array_equal(got.extra_links, expected.extra_links)
    assert n == n_expected > 0
    check_links(got)


@st.composite
def events(draw):
    n = draw(st.integers(1, 3))
    cracks = []
    for _ in range(n):
        p = draw(st.lists(st.floats(0.1, 0.9), min_size=3, max_size=3))
        nrm = draw(
            st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 0.1)
        )
        side = draw(st.one_of(st.none(), st.lists(st.floats(-1, 1), min_size=3, max_size=3)))
        if side is not None and np.linalg.norm(np.cross(side, nrm)) < 0.1 * np.linalg.norm(
            side
        ) * np.linalg.norm(nrm):
            side = None
        r = draw(st.floats(0.1, 1.0))
        cracks.append(
            Crack(point=p, normal=nrm, r_outer=r, side=side, r_inner=draw(st.sampled_from([0.0, 0.12])))
        )
    mode = draw(st.sampled_from(["basic", "subdivision"]))
    return cracks, mode, draw(st.booleans())


@SETTINGS
@given(events())
def test_event_invariants(block, ev):
    """Links symmetric; no remaining link crosses a crack of the event; links away from the
    cracks unchanged; shattered particles have no link; fragment surfaces closed."""
    cracks, mode, shatter = ev
    ps, rep = apply_cracks(block, cracks, mode=mode, shatter=shatter)
    check_links(ps)
    i, k = np.nonzero(ps.links >= 0)
    j = ps.links[i, k]
    pairs = np.concatenate([np.stack([i, j], 1), ps.extra_links])
    for c in cracks:
        bad = crossing_point_inside(c, ps.centroid[pairs[:, 0]], ps.centroid[pairs[:, 1]], 1e-9)
        assert not bad.any()
    # far links unchanged: both tets, and the segment between their centroids, outside every
    # crack's ball (and the particles outside the shatter radius)
    bi, bk = np.nonzero(block.links >= 0)
    bj = block.links[bi, bk]
    keep = np.ones(len(bi), dtype=bool)
    for c in cracks:
        # distance from P to each tet, bounded below through the tet's bounding sphere
        reach = np.linalg.norm(block.rest_verts - block.centroid[:, None], axis=2).max(1)
        dist = np.linalg.norm(block.centroid - c.point, axis=1) - reach
        a, b = block.centroid[bi], block.centroid[bj]
        t = np.clip(np.einsum("ij,ij->i", c.point - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0, 1)
        seg = np.linalg.norm(a + t[:, None] * (b - a) - c.point, axis=1)
        keep &= (dist[bi] > c.r_outer) & (dist[bj] > c.r_outer) & (seg > c.r_outer)
        if shatter:
            r = np.linalg.norm(block.centroid - c.point, axis=1)
            keep &= (r[bi] >= c.r_inner) & (r[bj] >= c.r_inner)
    assert np.array_equal(ps.links[bi[keep], bk[keep]], block.links[bi[keep], bk[keep]])
    if shatter and len(rep.debris):
        assert np.all(ps.links[rep.debris] < 0)
        assert not np.isin(ps.extra_links, rep.debris).any()
    surf = fragment_surfaces(ps, rep.labels)
    assert surf.open_edges == 0 and edge_imbalance(surf.faces) == 0
    assert abs(ps.volume[ps.alive].sum() - block.volume.sum()) <= 1e-12


def test_shatter_removes_all_links_inside_r_inner(block):
    crack = Crack(point=[0.5, 0.5, 0.5], normal=[0, 0, 1], r_outer=0.4, r_inner=0.2)
    ps, debris = shatter_particles(block, crack)
    inside = np.linalg.norm(block.centroid - crack.point, axis=1) < 0.2
    assert np.array_equal(debris, np.flatnonzero(inside)) and debris.size > 0
    assert np.all(ps.links[debris] < 0)
    assert not np.isin(ps.links, debris).any()
    check_links(ps)
    lab = fragment_labels(ps)
    assert len(np.unique(lab[debris])) == debris.size  # each debris particle alone
    assert np.bincount(lab)[lab[debris]].max() == 1


def test_only_touched_bodies_change():
    a = kuhn_box(3, 3, 3, jitter=0.1, seed=1)
    b = TetMesh(a.verts + [2.0, 0, 0], a.tets)
    pa, pb = build_particles(a, DENSITY, body=0), build_particles(b, DENSITY, body=1)
    ps = ParticleSet(
        **{
            f: np.concatenate(
                [
                    getattr(pa, f),
                    np.where(getattr(pb, f) >= 0, getattr(pb, f) + len(pa), -1)
                    if f == "links"
                    else getattr(pb, f),
                ]
            )
            for f in (
                "rest_verts",
                "volume",
                "mass",
                "centroid",
                "radius",
                "material",
                "body",
                "links",
                "kind",
                "parent",
                "alive",
            )
        }
    )
    crack = Crack(point=[1.5, 0.5, 0.5], normal=[0.1, 0.05, 1.0], r_outer=5.0)  # spans both bodies
    out, rep = apply_cracks(ps, [crack], mode="subdivision", bodies=[1])
    assert np.array_equal(out.links[: len(pa)], ps.links[: len(pa)])
    assert np.all(out.body[len(ps) :] == 1)
    assert np.all(rep.labels[: len(pa)] == -1) and rep.n_fragments == 2
