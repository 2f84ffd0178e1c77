"""Decomposition tables for adaptive subdivision of a tet cut by a crack plane (Sect. 5.2, Fig. 4).

Every cut tet is first relabelled into a canonical vertex order V0..V3 (an even permutation, so
the canonical tet keeps the parent's positive orientation); the tables below then say which points
to make and which children (4 point ids each, positively oriented) to build from them.

Point kinds:
  ("v", i)        canonical vertex Vi
  ("e", i, j)     the plane's intersection with edge ViVj
  ("m", (a,b,..)) the vertex mean of the listed points (computed in a canonical order, so two
                  neighbouring tets get the same bits: see geometry.subdivision)

Cases, by the snapped vertex signs (+, -, or 0 = "on the plane", see geometry.subdivision):

'3-1' (paper): V0 alone on one side, V1 V2 V3 on the other. Cut points e01 e02 e03. The top tet
  (V0 e01 e02 e03) and the inverted tet (e01 e02 e03 G), G = mean of the bottom face V1V2V3, are
  cut off; G is linked with the bottom vertices, leaving three rectangular pyramids with apex G
  over the side quads (e01 e02 V2 V1), (e02 e03 V3 V2), (e03 e01 V1 V3); each pyramid is split
  into 4 tets by linking the quad's vertex mean M with the apex and the quad's corners.
  1 + 1 + 3 x 4 = 14 children.
'2-2' (paper): V0 V1 on one side, V2 V3 on the other. Cut points e02 e12 e13 e03 form the cut quad;
  Q = its vertex mean. Each side is a triangular prism; Q is linked with all its vertices, which
  gives 2 tets (Q over the prism's end triangles) and 2 rectangular pyramids (Q over the prism's
  side quads, which lie in the parent's faces), each pyramid split into 4 around its quad's vertex
  mean. 2 x (2 + 2 x 4) = 20 children.
'V' (snap, not in the paper): V1 lies on the plane, V0 alone on one side, V2 V3 on the other. Cut
  points e02 e03. Children: the tet (V0 V1 e02 e03) and the pyramid with apex V1 over the quad
  (e02 e03 V3 V2), split into 4 around the quad's vertex mean. 1 + 4 = 5 children.
'E' (snap): V1 V2 lie on the plane, V0 and V3 on opposite sides. Cut point e03. Children:
  (V0 V1 V2 e03) and (e03 V1 V2 V3). 2 children.

How a parent face is split depends only on the signs of its own three vertices (this is what
makes two neighbouring cut tets conforming): one vertex alone on its side -> the triangle at that
vertex plus the remaining quad fanned around its vertex mean (5 triangles); signs (0, +, -) -> two
triangles through the cut point; otherwise unsplit, except the bottom face of a '3-1' tet, which
is fanned around its centroid G (3 triangles): a neighbour that is not cut across that face then
meets three children (Fig. 5a), recorded as extra links.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.tetmesh import TET_FACES, signed_volumes

CASE_NAMES = ("3-1", "2-2", "V", "E")
CASE_31, CASE_22, CASE_V, CASE_E = 0, 1, 2, 3

# ---------------------------------------------------------------------------------------------
# point lists and children in canonical labels (children are oriented below, numerically)
_DEFS: dict[int, dict] = {
    CASE_31: {
        "points": [
            ("v", 0),
            ("v", 1),
            ("v", 2),
            ("v", 3),
            ("e", 0, 1),
            ("e", 0, 2),
            ("e", 0, 3),  # 4 5 6
            ("m", (1, 2, 3)),  # 7: G, centroid of the bottom face (face 0)
            ("m", (4, 5, 2, 1)),  # 8: mean of the side quad in face 3
            ("m", (5, 6, 3, 2)),  # 9: mean of the side quad in face 1
            ("m", (6, 4, 1, 3)),  # 10: mean of the side quad in face 2
        ],
        "top": [(0, 4, 5, 6)],  # on V0's side
        "bottom": [(4, 5, 6, 7)]
        + [
            (7, m, a, b)
            for m, q in ((8, (4, 5, 2, 1)), (9, (5, 6, 3, 2)), (10, (6, 4, 1, 3)))
            for a, b in zip(q, q[1:] + q[:1], strict=True)
        ],
    },
    CASE_22: {
        "points": [
            ("v", 0),
            ("v", 1),
            ("v", 2),
            ("v", 3),
            ("e", 0, 2),
            ("e", 0, 3),
            ("e", 1, 2),
            ("e", 1, 3),  # 4 5 6 7
            ("m", (4, 6, 7, 5)),  # 8: Q, mean of the cut quad e02 e12 e13 e03
            ("m", (6, 7, 3, 2)),  # 9: mean of the quad in face 0 (V2 V3 side)
            ("m", (4, 5, 3, 2)),  # 10: mean of the quad in face 1 (V2 V3 side)
            ("m", (5, 7, 1, 0)),  # 11: mean of the quad in face 2 (V0 V1 side)
            ("m", (4, 6, 1, 0)),  # 12: mean of the quad in face 3 (V0 V1 side)
        ],
        "top": [(8, 0, 4, 5), (8, 1, 6, 7)]
        + [
            (8, m, a, b)
            for m, q in ((12, (4, 6, 1, 0)), (11, (5, 7, 1, 0)))
            for a, b in zip(q, q[1:] + q[:1], strict=True)
        ],
        "bottom": [(8, 2, 4, 6), (8, 3, 5, 7)]
        + [
            (8, m, a, b)
            for m, q in ((9, (6, 7, 3, 2)), (10, (4, 5, 3, 2)))
            for a, b in zip(q, q[1:] + q[:1], strict=True)
        ],
    },
    CASE_V: {
        "points": [
            ("v", 0),
            ("v", 1),
            ("v", 2),
            ("v", 3),
            ("e", 0, 2),
            ("e", 0, 3),  # 4 5
            ("m", (4, 5, 3, 2)),  # 6: mean of the quad in face 1
        ],
        "top": [(0, 1, 4, 5)],
        "bottom": [(1, 6, a, b) for a, b in ((4, 5), (5, 3), (3, 2), (2, 4))],
    },
    CASE_E: {
        "points": [("v", 0), ("v", 1), ("v", 2), ("v", 3), ("e", 0, 3)],
        "top": [(0, 1, 2, 4)],
        "bottom": [(4, 1, 2, 3)],
    },
}

# canonical vertices lying on the cut surface (snapped vertices), per case
_ON_PLANE_VERTS = {CASE_31: (), CASE_22: (), CASE_V: (1,), CASE_E: (1, 2)}
# canonical vertex pair whose swap keeps the case's roles (used to make the relabelling even)
PARITY_SWAP = {CASE_31: (2, 3), CASE_22: (2, 3), CASE_V: (2, 3), CASE_E: (1, 2)}
CHILD_COUNT = {c: len(d["top"]) + len(d["bottom"]) for c, d in _DEFS.items()}  # 14, 20, 5, 2


@dataclass(frozen=True)
class CaseTable:
    """One case of the decomposition, in canonical labels."""

    name: str
    edges: np.ndarray  # (Ne, 2) int: canonical vertex pairs cut by the plane, in point order
    means: list  # [(point id, tuple of point ids)], in an order where inputs exist before use
    n_points: int
    children: np.ndarray  # (C, 4) int: point ids, positively oriented for a positive parent
    child_side: np.ndarray  # (C,) int: +1 on V0's side, -1 on the other side
    face_tag: np.ndarray  # (C, 4) int: canonical parent face that child face j lies in, or -1
    face_on_cut: np.ndarray  # (C, 4) bool: child face j lies on the cut surface
    sibling_pairs: np.ndarray  # (P, 4) int: (child a, face ja, child b, face jb) sharing a face


def _point_faces(points: list) -> list[set]:
    """Parent faces (canonical) each point lies in: face k is opposite vertex k."""
    out: list[set] = []
    for p in points:
        if p[0] == "v":
            out.append({0, 1, 2, 3} - {p[1]})
        elif p[0] == "e":
            out.append({0, 1, 2, 3} - {p[1], p[2]})
        else:
            s = {0, 1, 2, 3}
            for q in p[1]:
                s &= out[q]
            out.append(s)
    return out


def _point_on_cut(case: int, points: list) -> list[bool]:
    out: list[bool] = []
    for p in points:
        if p[0] == "v":
            out.append(p[1] in _ON_PLANE_VERTS[case])
        elif p[0] == "e":
            out.append(True)
        else:
            out.append(all(out[q] for q in p[1]))
    return out


def _reference_points(case: int, points: list) -> np.ndarray:
    """Point coordinates in a reference positive tet with generic (unequal) cut parameters."""
    ref = np.array([[0.0, 0.0, 0.0], [1.0, 0.1, 0.0], [0.2, 1.0, 0.1], [0.1, 0.3, 1.0]])
    t = {(0, 1): 0.37, (0, 2): 0.61, (0, 3): 0.44, (1, 2): 0.29, (1, 3): 0.53}
    xs: list[np.ndarray] = []
    for p in points:
        if p[0] == "v":
            xs.append(ref[p[1]])
        elif p[0] == "e":
            i, j = p[1], p[2]
            xs.append(ref[i] + t[(i, j)] * (ref[j] - ref[i]))
        else:
            xs.append(np.mean([xs[q] for q in p[1]], axis=0))
    return np.array(xs)


def _build(case: int) -> CaseTable:
    d = _DEFS[case]
    points = d["points"]
    children = np.array(d["top"] + d["bottom"], dtype=np.int64)
    side = np.array([1] * len(d["top"]) + [-1] * len(d["bottom"]), dtype=np.int64)
    # orient every child positively (the sign of a child's volume is the same for every cut
    # parameter in (0, 1): the tests check this over random parameters)
    x = _reference_points(case, points)
    vol = signed_volumes(x[children])
    flip = vol < 0
    children[flip] = children[flip][:, [0, 2, 1, 3]]
    assert np.all(np.abs(vol) > 1e-6), f"degenerate child in table {CASE_NAMES[case]}"
    pf = _point_faces(points)
    pc = _point_on_cut(case, points)
    tag = np.full((len(children), 4), -1, dtype=np.int64)
    on_cut = np.zeros((len(children), 4), dtype=bool)
    for c, ch in enumerate(children):
        for j in range(4):
            ids = ch[TET_FACES[j]]
            common = pf[ids[0]] & pf[ids[1]] & pf[ids[2]]
            assert len(common) <= 1
            if common:
                tag[c, j] = next(iter(common))
            on_cut[c, j] = all(pc[i] for i in ids)
    # faces shared by two children: the same three point ids (so the same bits, always)
    seen: dict = {}
    pairs = []
    for c, ch in enumerate(children):
        for j in range(4):
            key = tuple(sorted(ch[TET_FACES[j]].tolist()))
            if key in seen:
                pairs.append((*seen.pop(key), c, j))
            else:
                seen[key] = (c, j)
    assert all(tag[c, j] >= 0 for c, j in seen.values()), "an interior face without a partner"
    edges = np.array([(p[1], p[2]) for p in points if p[0] == "e"], dtype=np.int64)
    means = [(i, tuple(p[1])) for i, p in enumerate(points) if p[0] == "m"]
    return CaseTable(
        name=CASE_NAMES[case],
        edges=edges,
        means=means,
        n_points=len(points),
        children=children,
        child_side=side,
        face_tag=tag,
        face_on_cut=on_cut,
        sibling_pairs=np.array(pairs, dtype=np.int64).reshape(-1, 4),
    )


TABLES: dict[int, CaseTable] = {c: _build(c) for c in _DEFS}


def sign_case(n_pos: np.ndarray, n_zero: np.ndarray, n_neg: np.ndarray) -> np.ndarray:
    """Case id per tet from its counts of +, 0, - vertices; -1 = not cut.

    With no zeros these are the paper's 16 sign patterns: 2 uncut (all + or all -), 8 '3-1'
    and 6 '2-2'. Snapped vertices (0) add the 'V' and 'E' cases.
    """
    case = np.full(n_pos.shape, -1, dtype=np.int64)
    cut = (n_pos > 0) & (n_neg > 0)
    case[cut & (n_zero == 0) & (n_pos != 2)] = CASE_31
    case[cut & (n_zero == 0) & (n_pos == 2)] = CASE_22
    case[cut & (n_zero == 1)] = CASE_V
    case[cut & (n_zero == 2)] = CASE_E
    return case


def table_text() -> str:
    """A plain-text dump of the tables (docs/notes_fracture.md quotes it)."""
    lines = []
    for c, tab in TABLES.items():
        pts = _DEFS[c]["points"]
        lines.append(f"case '{tab.name}': {len(tab.children)} children")
        names = []
        for p in pts:
            if p[0] == "v":
                names.append(f"V{p[1]}")
            elif p[0] == "e":
                names.append(f"e{p[1]}{p[2]}")
            else:
                names.append("mean(" + " ".join(names[q] for q in p[1]) + ")")
        for i, n in enumerate(names):
            lines.append(f"  point {i:2d}: {n}")
        for k, ch in enumerate(tab.children):
            side = "V0 side" if tab.child_side[k] > 0 else "far side"
            tags = ",".join("-" if t < 0 else f"f{t}" for t in tab.face_tag[k])
            lines.append(
                f"  child {k:2d}: ({' '.join(str(int(i)) for i in ch)})  {side}  faces in parent: {tags}"
            )
    return "\n".join(lines)
