"""Adaptive subdivision of the tets a crack cuts (Sect. 5.2, Fig. 4-5, Algorithm 2).

Each physical particle (never one already subdivided) whose tet the crack region cuts is replaced
by children made with the tables of `geometry.subdivision_tables`: the vertex sign table gives the
case ('3-1' -> 14 children, '2-2' -> 20), the tables give the points and children. The parent is
marked dead (alive = False, no links); children take its density, material and body.

Snap rule. Let d be the signed distances of a tet's vertices to the plane and S = max d - min d
its extent across the plane. A vertex is *snapped* (treated as lying on the plane, sign 0, and
left where it is) when |d| < snap_rel * S_max, S_max being the largest S over the cut candidates
that share the vertex (vertices are identified by exact coordinates, so the decision is the same
in every tet around the vertex: a per-tet rule would break conformity). The cut surface then runs
through the snapped vertex: a tet with a snapped lone vertex is not cut; otherwise the lower cases
'V' (5 children) and 'E' (2 children) of the tables apply. Every unsnapped vertex has
|d| >= snap_rel * S, so every cut parameter t lies in [snap_rel, 1 - snap_rel] and (shown in
docs/notes_fracture.md) every child has volume >= snap_rel^3 / 2 of its parent's (5e-7 for the
default 0.01; the bound is attained). Children lie on one side of the cut surface, which deviates
from the plane by less than snap_rel * S_max at snapped vertices (and not at all elsewhere); the
price is a volume error of the split near snapped vertices (measured in bench/bench_fracture.py).

Conformity. Two neighbouring cut tets split their shared face identically (the split depends only
on the signs of the face's vertices) and compute its points from the same data in the same order:
an edge point from its two end points sorted lexicographically (x = a + t (b - a), t = d_a / (d_a
- d_b)), a vertex mean from its points sorted lexicographically and summed left to right. So the
shared child faces carry identical bits and are linked by exact key matching.

Relinking ("link the new particles correctly based on coplanar situation"). Children faces are
linked (face links) to coinciding faces of sibling children, and of children of a neighbouring
cut tet when the two parents were linked across that face (a link an earlier crack removed stays
removed). A child face lying in
a parent face whose old neighbour is not subdivided now either coincides with the neighbour's face
(face link) or covers part of it: then child and neighbour get an extra link (the unbalanced cases
of Fig. 5), and the neighbour's face-link slot is cleared. Old extra links of a parent are handed
to the children whose faces overlap the partner's face (2D overlap test in the face plane).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from core.arrays import cross3, unique_rows
from core.errors import ConfigError, MeshError
from geometry.cutting import Bodies, Crack, body_mask, lex_less, section_meets_region, signed_distance
from geometry.particles import KIND_PHYSICAL, KIND_SUBDIVIDED, ParticleSet
from geometry.subdivision_tables import CASE_NAMES, PARITY_SWAP, TABLES, sign_case
from geometry.tetmesh import TET_FACES, signed_volumes

SNAP_REL = 0.01  # -: snap distance as a fraction of the largest extent S of the tets at a vertex


def min_child_volume_ratio(snap_rel: float = SNAP_REL) -> float:
    """Guaranteed lower bound of child volume / parent volume for a snap fraction (notes: Sect. 2)."""
    return 0.5 * snap_rel**3


# ---------------------------------------------------------------------------------------------
# canonical point arithmetic


def _sort_points(pts: list[np.ndarray]) -> list[np.ndarray]:
    """Sort 3 or 4 point arrays (..., 3) lexicographically per point (a fixed sorting network)."""
    pts = list(pts)
    net = {3: [(0, 1), (1, 2), (0, 1)], 4: [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)]}[len(pts)]
    for i, j in net:
        sw = lex_less(pts[j], pts[i])[..., None]
        pts[i], pts[j] = np.where(sw, pts[j], pts[i]), np.where(sw, pts[i], pts[j])
    return pts


def canonical_mean(pts: list[np.ndarray]) -> np.ndarray:
    """Vertex mean of 3 or 4 points (each (..., 3)), the same bits for any order of the inputs."""
    s = _sort_points(pts)
    acc = s[0] + s[1]
    for p in s[2:]:
        acc = acc + p
    return acc / float(len(s))


def canonical_edge_point(a: np.ndarray, b: np.ndarray, da: np.ndarray, db: np.ndarray) -> np.ndarray:
    """Crossing of edge a-b (each (M, 3)) with the plane, from the lexicographically smaller end."""
    sw = lex_less(b, a)
    a2 = np.where(sw[:, None], b, a)
    b2 = np.where(sw[:, None], a, b)
    da2 = np.where(sw, db, da)
    db2 = np.where(sw, da, db)
    t = da2 / (da2 - db2)
    return a2 + t[:, None] * (b2 - a2)


def face_keys(tri: np.ndarray) -> np.ndarray:
    """(M,) void keys of triangles (M, 3, 3): equal iff the same three points (any order)."""
    s = _sort_points([tri[:, 0], tri[:, 1], tri[:, 2]])
    k = np.ascontiguousarray(np.concatenate(s, axis=1) + 0.0)  # + 0.0 turns -0.0 into 0.0
    return k.view(np.dtype((np.void, 72))).ravel()


def point_ids(x: np.ndarray) -> np.ndarray:
    """(M,) int: the same id for points (M, 3) with identical coordinates."""
    k = np.ascontiguousarray(x + 0.0).view(np.dtype((np.void, 24))).ravel()
    _, inv = np.unique(k, return_inverse=True)
    return inv.ravel()


# ---------------------------------------------------------------------------------------------
# splitting tets


@dataclass
class SplitResult:
    """Children of a batch of cut tets (indices refer to the batch)."""

    verts: np.ndarray  # (C, 4, 3) m: child vertices, positively oriented
    parent: np.ndarray  # (C,) int: index of the parent in the batch
    side: np.ndarray  # (C,) int: +1 on the plane's positive side, -1 on the negative side
    face_tag: np.ndarray  # (C, 4) int: parent face (TET_FACES index) child face j lies in, or -1
    face_on_cut: np.ndarray  # (C, 4) bool: child face j lies on the cut surface
    case: np.ndarray  # (T,) int: case id per batch tet (-1 = not cut)


def _role_perm(case: int, sign: np.ndarray) -> np.ndarray:
    """Even permutation (M, 4) putting the vertices of tets of one case in canonical order."""
    npos = (sign > 0).sum(1, keepdims=True)
    if case == 0:  # '3-1': the lone vertex first
        lone_sign = np.where(npos == 1, 1, -1)
        key = (sign != lone_sign).astype(np.int64)
    elif case == 1:  # '2-2': vertex 0's side first
        key = (sign != sign[:, :1]).astype(np.int64)
    elif case == 2:  # 'V': lone strict vertex, the zero, the pair
        lone_sign = np.where(npos == 1, 1, -1)
        key = np.where(sign == 0, 1, np.where(sign == lone_sign, 0, 2))
    else:  # 'E': positive, zeros, negative
        key = np.where(sign > 0, 0, np.where(sign == 0, 1, 2))
    perm = np.argsort(key * 4 + np.arange(4), axis=1, kind="stable")
    # parity of each permutation (count inversions), then swap a same-role pair when odd
    inv = np.zeros(len(perm), dtype=np.int64)
    for i in range(4):
        for j in range(i + 1, 4):
            inv += perm[:, i] > perm[:, j]
    odd = inv % 2 == 1
    a, b = PARITY_SWAP[case]
    perm[odd, a], perm[odd, b] = perm[odd, b], perm[odd, a].copy()
    return perm


def split_tets(verts: np.ndarray, d: np.ndarray, sign: np.ndarray) -> SplitResult:
    """Split tets (T, 4, 3) with vertex distances d (T, 4) and snapped signs (T, 4) in {-1, 0, 1}.

    Tets whose signs do not contain both + and - produce no children. Vectorised per case.
    """
    n_pos = (sign > 0).sum(1)
    n_neg = (sign < 0).sum(1)
    n_zero = 4 - n_pos - n_neg
    case = sign_case(n_pos, n_zero, n_neg)
    out_v, out_p, out_s, out_t, out_c, out_order = [], [], [], [], [], []
    for c, tab in TABLES.items():
        idx = np.flatnonzero(case == c)
        if idx.size == 0:
            continue
        perm = _role_perm(c, sign[idx])
        v = np.take_along_axis(verts[idx], perm[:, :, None], axis=1)
        dv = np.take_along_axis(d[idx], perm, axis=1)
        sv = np.take_along_axis(sign[idx], perm, axis=1)
        pts: list[np.ndarray | None] = [None] * tab.n_points
        for i in range(4):
            pts[i] = v[:, i]
        for e, (i, j) in enumerate(tab.edges):
            pts[4 + e] = canonical_edge_point(v[:, i], v[:, j], dv[:, i], dv[:, j])
        for k in (3, 4):  # the table's means of k points at once: each point's arithmetic is the same
            if means := [(pid, members) for pid, members in tab.means if len(members) == k]:
                mean = canonical_mean([np.stack([pts[members[q]] for _, members in means]) for q in range(k)])
                for g, (pid, _) in enumerate(means):
                    pts[pid] = mean[g]
        P = np.stack(pts, axis=1)  # (m, n_points, 3)
        nc = len(tab.children)
        out_v.append(P[:, tab.children].reshape(-1, 4, 3))
        out_p.append(np.repeat(idx, nc))
        s0 = np.where(sv[:, 0] > 0, 1, -1)
        out_s.append((s0[:, None] * tab.child_side[None, :]).ravel())
        tag = np.where(tab.face_tag[None] >= 0, perm[:, np.maximum(tab.face_tag, 0)], -1)  # (m, nc, 4)
        out_t.append(tag.reshape(-1, 4))
        out_c.append(np.broadcast_to(tab.face_on_cut, (len(idx), nc, 4)).reshape(-1, 4))
        out_order.append(np.repeat(idx, nc) * 32 + np.tile(np.arange(nc), len(idx)))
    if not out_v:
        z = np.zeros(0, dtype=np.int64)
        return SplitResult(np.zeros((0, 4, 3)), z, z, np.zeros((0, 4), np.int64), np.zeros((0, 4), bool), case)
    order = np.argsort(np.concatenate(out_order), kind="stable")  # children grouped by parent
    return SplitResult(
        verts=np.concatenate(out_v)[order],
        parent=np.concatenate(out_p)[order],
        side=np.concatenate(out_s)[order],
        face_tag=np.concatenate(out_t)[order],
        face_on_cut=np.concatenate(out_c)[order],
        case=case,
    )


def snapped_signs(d: np.ndarray, verts: np.ndarray, snap_rel: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertex signs (T, 4) in {-1, 0, 1} after the snap rule, and the (T, 4) snapped mask.

    `verts` (T, 4, 3) identifies shared vertices by exact coordinates.
    """
    extent = d.max(1) - d.min(1)
    if len(d) == 0:
        return np.zeros(d.shape, np.int64), np.zeros(d.shape, bool)
    ids = point_ids(verts.reshape(-1, 3))
    s_max = np.zeros(ids.max() + 1)
    np.maximum.at(s_max, ids, np.repeat(extent, 4))
    snapped = np.abs(d) < snap_rel * s_max[ids].reshape(d.shape)
    sign = np.where(snapped, 0, np.where(d > 0, 1, -1))
    return sign, snapped


# ---------------------------------------------------------------------------------------------
# coplanar faces


def face_points(verts: np.ndarray) -> np.ndarray:
    """(M, 4, 3, 3): the four outward faces (TET_FACES) of tets (M, 4, 3)."""
    return verts[:, TET_FACES]


def coplanar_overlap(ta: np.ndarray, tb: np.ndarray, rel_tol: float = 1e-9) -> np.ndarray:
    """(M,) bool: coplanar triangles ta, tb (M, 3, 3) share an area (not just an edge or a point).

    Separating-axis test in the plane of ta over the six edge normals; an overlap shorter than
    rel_tol times the longest edge counts as touching.
    """
    n = cross3(ta[:, 1] - ta[:, 0], ta[:, 2] - ta[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    u = ta[:, 1] - ta[:, 0]
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    w = cross3(n, u)
    o = ta[:, 0]
    pa = np.stack([np.einsum("mij,mj->mi", ta - o[:, None], u), np.einsum("mij,mj->mi", ta - o[:, None], w)], -1)
    pb = np.stack([np.einsum("mij,mj->mi", tb - o[:, None], u), np.einsum("mij,mj->mi", tb - o[:, None], w)], -1)
    edges = np.concatenate([np.roll(pa, -1, 1) - pa, np.roll(pb, -1, 1) - pb], axis=1)  # (M, 6, 2)
    axes = np.stack([-edges[..., 1], edges[..., 0]], -1)
    length = np.linalg.norm(edges, axis=2)
    scale = length.max(1)
    axes = axes / np.maximum(length, 1e-300)[..., None]
    proj_a = np.einsum("mkd,mid->mki", axes, pa)  # (M, 6, 3)
    proj_b = np.einsum("mkd,mid->mki", axes, pb)
    overlap = np.minimum(proj_a.max(2), proj_b.max(2)) - np.maximum(proj_a.min(2), proj_b.min(2))
    valid = length > rel_tol * scale[:, None]
    return np.all(np.where(valid, overlap > rel_tol * scale[:, None], True), axis=1)


def coplanar_face_pairs(
    va: np.ndarray, vb: np.ndarray, rel_tol: float = 1e-7
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For tet pairs (M, 4, 3) x (M, 4, 3): the face of a and the face of b that lie in one plane
    with opposite normals and overlap with positive area. Returns (fa, fb, found) each (M,)."""
    fa = face_points(va)  # (M, 4, 3, 3)
    fb = face_points(vb)
    na = cross3(fa[:, :, 1] - fa[:, :, 0], fa[:, :, 2] - fa[:, :, 0])
    na /= np.linalg.norm(na, axis=2, keepdims=True)
    nb = cross3(fb[:, :, 1] - fb[:, :, 0], fb[:, :, 2] - fb[:, :, 0])
    nb /= np.linalg.norm(nb, axis=2, keepdims=True)
    cos = np.einsum("mid,mjd->mij", na, nb)  # (M, 4, 4)
    scale = np.linalg.norm(va.max(1) - va.min(1), axis=1)  # (M,)
    # distance of b's face vertices to a's face plane: (M, 4a, 4b, 3)
    dist = np.einsum("mjvd,mid->mijv", fb, na) - np.einsum("mid,mid->mi", fa[:, :, 0], na)[:, :, None, None]
    flat = np.abs(dist).max(3) <= rel_tol * scale[:, None, None]
    cand = (cos < -1.0 + 1e-6) & flat
    m_idx, ia, ib = np.nonzero(cand)
    ok = coplanar_overlap(fa[m_idx, ia], fb[m_idx, ib]) if m_idx.size else np.zeros(0, bool)
    m_idx, ia, ib = m_idx[ok], ia[ok], ib[ok]
    found = np.zeros(len(va), dtype=bool)
    out_a = np.full(len(va), -1, dtype=np.int64)
    out_b = np.full(len(va), -1, dtype=np.int64)
    # first valid combination per pair
    first = np.unique(m_idx, return_index=True)[1]
    found[m_idx[first]] = True
    out_a[m_idx[first]] = ia[first]
    out_b[m_idx[first]] = ib[first]
    return out_a, out_b, found


# ---------------------------------------------------------------------------------------------
# subdivision of a particle set


@dataclass
class SubdivisionReport:
    """What one crack's subdivision did."""

    candidates: int = 0  # physical tets whose section the crack region meets
    subdivided: int = 0  # tets replaced by children
    children: int = 0  # children made
    snapped_vertices: int = 0  # distinct vertices snapped onto the plane
    uncut_by_snap: int = 0  # candidates left whole because of snapped vertices
    cases: dict = field(default_factory=dict)  # case name -> number of tets
    new_extra_links: int = 0  # unbalanced relations recorded (Fig. 5)
    parents: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # ids of replaced tets
    first_child: int = 0  # id of the first child (children are first_child .. first_child+children-1)
    min_volume_ratio: float = 1.0  # smallest child volume / parent volume


def _join(keys_a: np.ndarray, keys_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All index pairs (ia, ib) with keys_a[ia] == keys_b[ib] (many-to-many, vectorised)."""
    order = np.argsort(keys_b, kind="stable")
    kb = keys_b[order]
    lo = np.searchsorted(kb, keys_a, side="left")
    hi = np.searchsorted(kb, keys_a, side="right")
    cnt = hi - lo
    ia = np.repeat(np.arange(len(keys_a)), cnt)
    within = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    ib = order[np.repeat(lo, cnt) + within]
    return ia, ib


def _cut_tets(ps: ParticleSet, crack: Crack, bodies: Bodies, snap_rel: float, rep: SubdivisionReport):
    """The physical particles the crack region cuts, split by the tables: (candidates, SplitResult),
    or None when nothing is cut (Algorithm 2, lines 1-4: sign test, snap, '3-1' / '2-2' cases)."""
    sel = body_mask(ps, bodies) & (ps.kind == KIND_PHYSICAL)
    ids = np.flatnonzero(sel)
    d_all = signed_distance(crack, ps.rest_verts[ids])
    straddle = (d_all.max(1) > 0.0) & (d_all.min(1) < 0.0)
    ids, d_all = ids[straddle], d_all[straddle]
    meets = section_meets_region(crack, ps.rest_verts[ids], d_all)
    cand, d = ids[meets], d_all[meets]
    rep.candidates = int(cand.size)
    if cand.size == 0:
        return None
    verts = ps.rest_verts[cand]
    sign, snapped = snapped_signs(d, verts, snap_rel)
    rep.snapped_vertices = int(np.unique(point_ids(verts.reshape(-1, 3))[snapped.ravel()]).size)
    split = split_tets(verts, d, sign)
    cut = split.case >= 0
    rep.uncut_by_snap = int((~cut).sum())
    rep.cases = {CASE_NAMES[c]: int((split.case == c).sum()) for c in range(4) if (split.case == c).any()}
    if not cut.any():
        return None
    return cand, split


def _link_siblings(split, n_cand: int, new_ids: np.ndarray, links: np.ndarray, matched: np.ndarray) -> None:
    """(1a) the faces two children of one parent share, from the subdivision tables."""
    first = np.searchsorted(split.parent, np.arange(n_cand))  # first child of each batch tet
    for c, tab in TABLES.items():
        b = np.flatnonzero(split.case == c)
        if b.size == 0 or len(tab.sibling_pairs) == 0:
            continue
        sp = tab.sibling_pairs
        ca = (first[b][:, None] + sp[None, :, 0]).ravel()
        cb = (first[b][:, None] + sp[None, :, 2]).ravel()
        ja = np.tile(sp[:, 1], b.size)
        jb = np.tile(sp[:, 3], b.size)
        links[new_ids[ca], ja] = new_ids[cb]
        links[new_ids[cb], jb] = new_ids[ca]
        matched[ca * 4 + ja] = True
        matched[cb * 4 + jb] = True


def _link_cut_neighbours(ch_faces, ctag, ch_parent, old_links, is_sub, new_ids, links, matched) -> None:
    """(1b) children of two linked parents cut now: coinciding faces in the shared parent face (a
    link an earlier crack removed stays removed: only faces towards a linked neighbour qualify)."""
    nb_of_face = np.where(ctag >= 0, old_links[np.repeat(ch_parent, 4), np.maximum(ctag, 0)], -1)
    cross = np.flatnonzero((nb_of_face >= 0) & is_sub[np.maximum(nb_of_face, 0)])
    if not cross.size:
        return
    keys = face_keys(ch_faces[cross])
    _, inv, cnt = np.unique(keys, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    if cnt.max() > 2:
        raise MeshError("subdivision", "a child face shared by more than two children", f"{int((cnt > 2).sum())} faces")
    order = np.argsort(inv, kind="stable")
    s_inv = inv[order]
    pair = np.flatnonzero(s_inv[1:] == s_inv[:-1])
    fa, fb = cross[order[pair]], cross[order[pair + 1]]
    links[new_ids[fa // 4], fa % 4] = new_ids[fb // 4]
    links[new_ids[fb // 4], fb % 4] = new_ids[fa // 4]
    matched[fa] = True
    matched[fb] = True


def _old_pieces(ps: ParticleSet, parents: np.ndarray, old_links: np.ndarray, is_sub: np.ndarray, old_ex):
    """(2) what lay across each parent face before the cut: (parent, face k) -> (particle x, its face
    j), from the face links and from the extra links whose faces are coplanar (Fig. 5)."""
    p_rows = np.repeat(parents, 4)
    p_face = np.tile(np.arange(4), parents.size)
    p_nb = old_links[parents].ravel()
    nb_ok = (p_nb >= 0) & ~is_sub[np.maximum(p_nb, 0)]
    nb_ok &= ps.alive[np.maximum(p_nb, 0)]
    pc_par, pc_k, pc_x = p_rows[nb_ok], p_face[nb_ok], p_nb[nb_ok]
    pc_j = np.argmax(old_links[pc_x] == pc_par[:, None], axis=1)
    if len(old_ex):
        a_is_par = is_sub[old_ex[:, 0]]
        e_par = np.where(a_is_par, old_ex[:, 0], old_ex[:, 1])
        e_x = np.where(a_is_par, old_ex[:, 1], old_ex[:, 0])
        ok = ~is_sub[e_x] & ps.alive[e_x]
        e_par, e_x = e_par[ok], e_x[ok]
        fk, fj, found = coplanar_face_pairs(ps.rest_verts[e_par], ps.rest_verts[e_x])
        pc_par = np.concatenate([pc_par, e_par[found]])
        pc_k = np.concatenate([pc_k, fk[found]])
        pc_x = np.concatenate([pc_x, e_x[found]])
        pc_j = np.concatenate([pc_j, fj[found]])
    return pc_par, pc_k, pc_x, pc_j


def _link_old_pieces(ps, ch_faces, tag, ch_parent, matched, old, new_ids, links) -> np.ndarray:
    """Unmatched child faces lying in a parent face meet the old piece across it: a face link where
    the faces coincide, an extra link where they only overlap (Fig. 5). Returns the new extra links."""
    pc_par, pc_k, pc_x, pc_j = old
    cf = np.flatnonzero(~matched & (tag.ravel() >= 0))
    cf_key = ch_parent[cf // 4] * 4 + tag.ravel()[cf]
    ia, ib = _join(cf_key, pc_par * 4 + pc_k)
    new_extra = np.zeros((0, 2), dtype=np.int64)
    if ia.size:
        c_face = cf[ia]
        x, xj = pc_x[ib], pc_j[ib]
        tri_c = ch_faces[c_face]
        tri_x = face_points(ps.rest_verts[x])[np.arange(len(x)), xj]
        exact = face_keys(tri_c) == face_keys(tri_x)
        c_id = new_ids[c_face // 4]
        links[c_id[exact], (c_face % 4)[exact]] = x[exact]
        links[x[exact], xj[exact]] = c_id[exact]
        part = ~exact
        if part.any():
            ov = coplanar_overlap(tri_c[part], tri_x[part])
            new_extra = np.stack([c_id[part][ov], x[part][ov]], axis=1)
    if len(new_extra):
        new_extra = unique_rows(np.sort(new_extra, axis=1))
    return new_extra


def with_children(ps: ParticleSet, parents, ch_parent, ch_verts, ch_vol, links, extra) -> ParticleSet:
    """The particle set with the children appended (Sect. 5.2: the parent's density, material, body
    and kernel) and the parents dead."""
    nc = len(ch_verts)
    rho = ps.mass[ch_parent] / ps.volume[ch_parent]
    alive = np.concatenate([ps.alive, np.ones(nc, dtype=bool)])
    alive[parents] = False
    return replace(
        ps,
        rest_verts=np.concatenate([ps.rest_verts, ch_verts]),
        volume=np.concatenate([ps.volume, ch_vol]),
        mass=np.concatenate([ps.mass, rho * ch_vol]),
        centroid=np.concatenate([ps.centroid, ch_verts.mean(axis=1)]),
        radius=np.concatenate([ps.radius, np.cbrt(3.0 * ch_vol / (4.0 * np.pi))]),
        material=np.concatenate([ps.material, ps.material[ch_parent]]),
        body=np.concatenate([ps.body, ps.body[ch_parent]]),
        links=links,
        kind=np.concatenate([ps.kind, np.full(nc, KIND_SUBDIVIDED, dtype=ps.kind.dtype)]),
        parent=np.concatenate([ps.parent, ch_parent.astype(np.int64)]),
        alive=alive,
        extra_links=extra.astype(np.int64).reshape(-1, 2),
    )


def subdivide(
    ps: ParticleSet, crack: Crack, bodies: Bodies = None, snap_rel: float = SNAP_REL
) -> tuple[ParticleSet, SubdivisionReport]:
    """Subdivide every physical particle whose tet the crack region cuts; relink (see module doc).

    Returns a new ParticleSet (children appended after the existing particles, grouped by
    parent; parents marked dead with no links) and a report. The input is not modified.
    """
    if not (0.0 <= snap_rel < 0.5):
        raise ConfigError("fracture.snap_rel", snap_rel, "0 <= snap_rel < 0.5")
    rep = SubdivisionReport(first_child=len(ps))
    found = _cut_tets(ps, crack, bodies, snap_rel, rep)
    if found is None:
        return ps, rep
    cand, split = found
    parents = cand[split.case >= 0]
    ch_parent = cand[split.parent]  # split.parent indexes the batch of candidates
    ch_verts = split.verts
    ch_vol = signed_volumes(ch_verts)
    if np.any(ch_vol <= 0.0):
        raise MeshError("subdivision", "non-positive child volume", f"min {ch_vol.min():.3e} m^3")
    n0, nc = len(ps), len(ch_verts)
    new_ids = n0 + np.arange(nc)
    rep.subdivided, rep.children, rep.parents = int(parents.size), int(nc), parents
    rep.min_volume_ratio = float((ch_vol / ps.volume[ch_parent]).min())

    is_sub = np.zeros(n0 + nc, dtype=bool)
    is_sub[parents] = True
    old_links = ps.links
    links = np.concatenate([old_links, np.full((nc, 4), -1, dtype=np.int64)])
    ex = ps.extra_links
    ex_par = is_sub[ex[:, 0]] | is_sub[ex[:, 1]] if len(ex) else np.zeros(0, bool)
    old = _old_pieces(ps, parents, old_links, is_sub, ex[ex_par])
    # clear every link to or from a parent
    links[parents] = -1
    links[(links >= 0) & is_sub[np.maximum(links, 0)]] = -1

    ch_faces = face_points(ch_verts).reshape(-1, 3, 3)  # (4C, 3, 3)
    matched = np.zeros(4 * nc, dtype=bool)
    _link_siblings(split, len(cand), new_ids, links, matched)
    _link_cut_neighbours(ch_faces, split.face_tag.ravel(), ch_parent, old_links, is_sub, new_ids, links, matched)
    new_extra = _link_old_pieces(ps, ch_faces, split.face_tag, ch_parent, matched, old, new_ids, links)
    rep.new_extra_links = int(len(new_extra))
    keep_ex = ex[~ex_par]
    extra = np.concatenate([keep_ex, new_extra]) if len(new_extra) else keep_ex.copy()
    if len(extra):
        extra = unique_rows(np.sort(extra, axis=1))
    return with_children(ps, parents, ch_parent, ch_verts, ch_vol, links, extra), rep
