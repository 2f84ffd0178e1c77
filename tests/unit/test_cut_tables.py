"""Subdivision tables and single-tet splits (Sect. 5.2, Fig. 4): counts, volumes, orientation,
sides, the snap rule's minimum volume, and conformity of two neighbouring cut tets."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from geometry.cutting import Crack, signed_distance
from geometry.subdivision import (
    SNAP_REL,
    face_keys,
    face_points,
    min_child_volume_ratio,
    snapped_signs,
    split_tets,
)
from geometry.subdivision_tables import CASE_22, CASE_31, CASE_E, CASE_V, CHILD_COUNT, TABLES, sign_case
from geometry.tetmesh import TET_FACES, signed_volumes

SETTINGS = settings(
    max_examples=150, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)


def test_sign_table_has_the_papers_16_cases():
    cases = []
    for signs in itertools.product([1, -1], repeat=4):
        s = np.array([signs])
        cases.append(int(sign_case((s > 0).sum(1), (s == 0).sum(1), (s < 0).sum(1))[0]))
    assert cases.count(-1) == 2  # all + or all -
    assert cases.count(CASE_31) == 8
    assert cases.count(CASE_22) == 6
    # with snapped (zero) vertices: 81 patterns
    allp = np.array(list(itertools.product([1, 0, -1], repeat=4)))
    c = sign_case((allp > 0).sum(1), (allp == 0).sum(1), (allp < 0).sum(1))
    assert (c == CASE_V).sum() == 4 * 3 * 2  # zero position x lone position x lone sign
    assert (c == CASE_E).sum() == 6 * 2  # zero pair x which of the other two is +
    assert CHILD_COUNT == {CASE_31: 14, CASE_22: 20, CASE_V: 5, CASE_E: 2}


def _reference_split(case_signs, t=0.4):
    """Split the unit reference tet with given signs (zeros on the plane) and distances."""
    verts = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]])
    sign = np.array([case_signs])
    d = np.where(sign > 0, t, np.where(sign < 0, -(1 - t), 0.0)).astype(float)
    return verts, split_tets(verts, d, sign)


def test_parent_faces_are_split_by_the_sign_rule():
    """Each parent face is split as its own three signs say (the rule that makes neighbours
    conform), and its pieces tile it: 1-vs-2 -> 5 pieces, (0,+,-) -> 2, 3-1 bottom -> 3."""
    for signs in [(1, -1, -1, -1), (1, 1, -1, -1), (1, 0, -1, -1), (1, 0, 0, -1), (-1, 1, 1, 1)]:
        verts, sp = _reference_split(signs)
        s = np.array(signs)
        faces = face_points(sp.verts)
        parent_faces = verts[0][TET_FACES]
        for k in range(4):
            fs = s[TET_FACES[k]]
            pieces = faces[sp.face_tag == k]
            if (fs > 0).sum() and (fs < 0).sum():
                expect = 2 if (fs == 0).any() else 5
            elif (s[k] != 0) and np.all(fs == -s[k]) and (s == 0).sum() == 0:
                expect = 3  # the bottom face of a '3-1' tet
            else:
                expect = 1
            assert len(pieces) == expect, (signs, k)
            area = 0.5 * np.cross(pieces[:, 1] - pieces[:, 0], pieces[:, 2] - pieces[:, 0])
            pf = parent_faces[k]
            parea = 0.5 * np.cross(pf[1] - pf[0], pf[2] - pf[0])
            np.testing.assert_allclose(area.sum(0), parea, atol=1e-15)  # same orientation, same area


def test_minimum_child_volume_bound_is_attained():
    """The stated bound snap_rel^3 / 2 is reached by a '2-2' tet with all cut parameters at the
    limits, so it is the exact minimum of the scheme, not a loose estimate."""
    delta = SNAP_REL
    verts = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]])
    # V0 at +delta, V1 at +(1-delta), V2 V3 at -(1-delta)... choose d giving t02=t03=delta, t12=t13=1-delta
    d = np.array([[delta, 1 - delta, -(1 - delta), -(1 - delta)]]) * 1.0
    d[0, 1] = (1 - delta) ** 2 / delta  # t12 = d1 / (d1 - d2) = 1 - delta
    sign = np.array([[1, 1, -1, -1]])
    sp = split_tets(verts, d, sign)
    ratio = signed_volumes(sp.verts) / signed_volumes(verts)[0]
    assert abs(ratio.min() - min_child_volume_ratio(delta)) < 1e-12


@st.composite
def tet_and_plane(draw, near_vertex: bool):
    pts = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=12, max_size=12))).reshape(4, 3)
    vol = signed_volumes(pts[None])[0]
    edge = np.linalg.norm(pts[:, None] - pts[None], axis=2).max()
    assume(edge > 1e-3 and abs(vol) > 0.005 * edge**3)
    if vol < 0:
        pts = pts[[0, 2, 1, 3]]
    n = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3)))
    assume(np.linalg.norm(n) > 1e-3)
    n = n / np.linalg.norm(n)
    if near_vertex:
        v = draw(st.integers(0, 3))
        d = pts @ n
        ext = d.max() - d.min()
        rel = draw(
            st.sampled_from([0.0, 1e-15, -1e-15, 1e-9, -1e-9, 1e-4, -1e-4, 0.03, -0.03, 0.049, 0.051, -0.06])
        )
        p = pts[v] + rel * ext * n
    else:
        w = np.array(draw(st.lists(st.floats(0.01, 1.0), min_size=4, max_size=4)))
        p = (w / w.sum()) @ pts
    return pts, Crack(point=p, normal=n, r_outer=10.0)


def _check_single_split(pts, crack):
    verts = pts[None]
    d = signed_distance(crack, verts)
    sign, snapped = snapped_signs(d, verts, SNAP_REL)
    sp = split_tets(verts, d, sign)
    case = int(sp.case[0])
    V = signed_volumes(verts)[0]
    S = d.max() - d.min()
    if case < 0:
        assert len(sp.verts) == 0
        # uncut: after snapping, every vertex on one side or on the plane
        assert not ((sign > 0).any() and (sign < 0).any())
        return case
    assert len(sp.verts) == CHILD_COUNT[case]
    if not snapped.any():
        assert case in (CASE_31, CASE_22)
    vol = signed_volumes(sp.verts)
    assert abs(vol.sum() - V) <= 1e-12 * V
    assert np.all(vol > 0.0)
    assert vol.min() >= min_child_volume_ratio(SNAP_REL) * V * (1.0 - 1e-9)
    # every child on one side of the plane; snapped vertices may stick out by their |d|
    slack = (np.abs(d[snapped]).max() if snapped.any() else 0.0) + 1e-12 * S
    cd = signed_distance(crack, sp.verts)  # (C, 4)
    assert np.all(cd * sp.side[:, None] >= -slack)
    cc = signed_distance(crack, sp.verts.mean(1))
    if snapped.any():
        assert np.all(cc * sp.side >= -slack)
    else:
        assert np.all(cc * sp.side > 0.0)  # centroids strictly on their side
    return case


@SETTINGS
@given(tet_and_plane(near_vertex=False))
def test_split_random_tet_and_plane(tp):
    _check_single_split(*tp)


@SETTINGS
@given(tet_and_plane(near_vertex=True))
def test_split_plane_near_a_vertex(tp):
    _check_single_split(*tp)


def test_all_cases_reached():
    rng = np.random.default_rng(3)
    seen = set()
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    for v in range(4):
        for rel in (0.0, 0.3):
            for _ in range(20):
                n = rng.normal(size=3)
                n /= np.linalg.norm(n)
                p = pts[v] if rel == 0.0 else pts.mean(0) + rng.uniform(-0.2, 0.2, 3)
                seen.add(_check_single_split(pts, Crack(point=p, normal=n, r_outer=10.0)))
    p = (pts[0] + pts[1]) / 2  # through an edge: case 'E' when the plane contains the edge
    n = np.cross(pts[1] - pts[0], pts[2] + pts[3] - 2 * pts[0] + np.array([0.3, -0.7, 0.2]))
    seen.add(_check_single_split(pts, Crack(point=p, normal=n, r_outer=10.0)))
    assert {CASE_31, CASE_22, CASE_V, CASE_E} <= seen


@st.composite
def two_tets_and_plane(draw):
    """Two positive tets sharing face (a, b, c), apexes on opposite sides, and a plane cutting it."""
    abc = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=9, max_size=9))).reshape(3, 3)
    nrm = np.cross(abc[1] - abc[0], abc[2] - abc[0])
    area = np.linalg.norm(nrm)
    size = np.linalg.norm(abc[:, None] - abc[None], axis=2).max()
    assume(size > 1e-2 and area > 0.05 * size**2)
    nrm /= area
    cen = abc.mean(0)
    h1, h2 = draw(st.floats(0.2, 1.0)), draw(st.floats(0.2, 1.0))
    off1 = np.array(draw(st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3)))
    off2 = np.array(draw(st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3)))
    d1 = cen + h1 * size * nrm + off1 * size
    d2 = cen - h2 * size * nrm + off2 * size
    t1 = np.array([abc[0], abc[1], abc[2], d1])
    t2 = np.array([abc[0], abc[1], abc[2], d2])
    tets = np.stack([t1, t2])
    vol = signed_volumes(tets)
    assume(np.all(np.abs(vol) > 1e-3 * size**3))
    tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
    n = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3)))
    assume(np.linalg.norm(n) > 1e-3)
    w = np.array(draw(st.lists(st.floats(0.01, 1.0), min_size=3, max_size=3)))
    p = (w / w.sum()) @ abc
    return tets, Crack(point=p, normal=n, r_outer=10.0)


@SETTINGS
@given(two_tets_and_plane())
def test_neighbours_split_their_shared_face_identically(tc):
    """Conformity: both tets cut -> the pieces of the shared face carry identical bits."""
    tets, crack = tc
    d = signed_distance(crack, tets)
    sign, _ = snapped_signs(d, tets, SNAP_REL)
    sp = split_tets(tets, d, sign)
    assume((sp.case >= 0).all())
    shared = []
    for t in range(2):
        # the face of tet t made of the shared vertices: the one opposite its apex
        apex = int(np.flatnonzero(np.all(np.abs(tets[t] - tets[1 - t][:, None]).sum(2) > 0, axis=0))[0])
        mine = (sp.parent == t)[:, None] & (sp.face_tag == apex)
        shared.append(np.sort(face_keys(face_points(sp.verts)[mine])))
    assert len(shared[0]) == len(shared[1])
    assert np.array_equal(shared[0], shared[1])


def test_tables_are_consistent():
    for tab in TABLES.values():
        # every child face is interior (shared by two children), on the cut, or in a parent face
        ids = tab.children[:, TET_FACES]  # (C, 4, 3)
        keys = [tuple(sorted(f)) for f in ids.reshape(-1, 3).tolist()]
        counts = {k: keys.count(k) for k in keys}
        flat_tag = tab.face_tag.ravel()
        for key, tag in zip(keys, flat_tag, strict=True):
            if tag >= 0:
                assert counts[key] == 1
            else:
                assert counts[key] == 2
