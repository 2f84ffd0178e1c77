"""Cracks that the particles cannot tell apart are one crack (Sect. 5.2's cutting, at the resolution it has).

Algorithm 1 gives one crack per fired group, and a crack that reaches another material starts a new
analysis there (Sect. 6); groups loaded by the same stress (a disc struck on its rim: every group's
tension runs across the same diameter), or two analyses at neighbouring crossings, give crack planes a
degree or two apart through nearly the same point. Cut as two planes, the wedge between them is thinner
than a particle: every tet in it is cut twice and the slivers between the planes lose all their links,
tens of one-particle "fragments" that are the discretisation, not the material (they made the Tai Chi
scene's count swing from 16 to 303 between tet sizes of 7.8 and 8.6 mm). A crack plane is resolved to a
particle's size, so a crack whose region lies within one tet edge of an earlier crack's plane (this
event's, or one its body was cut by before) over its whole reach is put on that plane: the same cut
where they overlap, the new crack's region beyond it; where one of the event's regions holds the other
(their sides part by less than an edge), they are one crack, the holder. A plane is cut once
where it can be: cut again, the children of its first cut would be cut into slivers where their
vertices were snapped onto it.

Two half-discs of one analysis (the same point) whose planes and sides both lie within the analysis'
own angular accuracy (DIRECTION_ACCURACY_DEG: its crack directions scatter by up to 8-12 degrees about
the exact field's on a uniform pane, docs/notes_cracks.md section 7) are the same crack found twice, by
two groups loaded by the same tension: the longer one is kept. Cut as two, the wedge between them is
thinner than a particle out to e / sin(angle) from the point (8.6 cm for 8 degrees at 12 mm tets: a
slate crossing of the Tai Chi freed five slivers there), however far the regions reach.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from geometry.cutting import Crack

DIRECTION_ACCURACY_DEG = 10.0  # deg: how far one analysis' crack directions scatter (module doc)


def _coincides(crack: Crack, other: Crack, edge: float) -> bool:
    """The region of `crack` lies within `edge` (m) of the plane of `other`, and the two regions can meet."""
    cos = min(abs(float(np.dot(crack.normal, other.normal))), 1.0)
    offset = abs(float(np.dot(crack.point - other.point, other.normal)))
    reach = math.sqrt(1.0 - cos * cos) * crack.r_outer  # how far the tilt takes the region's rim off the plane
    meet = float(np.linalg.norm(crack.point - other.point)) <= crack.r_outer + other.r_outer
    return offset + reach < edge and meet


def _on_plane(crack: Crack, other: Crack) -> Crack:
    """`crack` moved onto the plane of `other`: its normal (turned to `crack`'s side: a normal's sign only
    orients the plane, and the analysis' own orientation is kept), its point projected (the other's point
    itself when they share it, so both planes are the same to the bit: the signed distances are negated
    exactly)."""
    n = other.normal if float(np.dot(crack.normal, other.normal)) >= 0.0 else -other.normal
    p = crack.point - float(np.dot(crack.point - other.point, n)) * n
    if np.array_equal(crack.point, other.point):
        p = other.point
    return replace(crack, point=p, normal=n)


def _holder(crack: Crack, other: Crack, edge: float) -> Crack | None:
    """Of `crack` put on the plane of `other` (this event's) and `other`, the one whose region holds the
    other's to within `edge` (full discs; half-discs whose sides part by less than `edge` over the larger
    radius; a half-disc in a full disc), when both carry the same shatter zone (one analysis, stopped at
    the same crossing or not at all); None where both regions must be cut."""
    if crack.shatter != other.shatter:
        return None
    big, small = (crack, other) if crack.r_outer > other.r_outer else (other, crack)
    if big.side is not None:
        if small.side is None:
            return None
        cos = float(np.dot(big.side, small.side))
        if cos <= 0.0 or math.sqrt(max(0.0, 1.0 - cos * cos)) * big.r_outer >= edge:
            return None
    return _longer(big, small)


def _longer(a: Crack, b: Crack) -> Crack:
    """The longer of two cracks that are one, carrying the larger of their shatter radii."""
    big, small = (a, b) if a.r_outer >= b.r_outer else (b, a)
    return replace(big, r_inner=max(big.r_inner, small.r_inner), r_crush=max(big.r_crush, small.r_crush))


def _found_twice(crack: Crack, other: Crack) -> bool:
    """Half-discs of one analysis (the same point and shatter zone) whose normals and sides both lie
    within DIRECTION_ACCURACY_DEG: the same crack (module doc)."""
    if crack.side is None or other.side is None or crack.shatter != other.shatter:
        return False
    if not np.array_equal(crack.point, other.point):
        return False
    cos = math.cos(math.radians(DIRECTION_ACCURACY_DEG))
    return abs(float(np.dot(crack.normal, other.normal))) > cos and float(np.dot(crack.side, other.side)) > cos


def merge_coincident(cracks: Sequence[Crack], edges: Sequence[float], history: Sequence[Crack] = ()) -> list[Crack]:
    """The event's cracks with each put on the plane of the first earlier crack (of `history`, then of
    this event) that it coincides with within its tet edge `edges[k]` (m: the particle nearest its
    point), and the two one crack where that crack is one of this event's and one region holds the other,
    or where the two are one analysis' crack found twice (module doc). The order is kept; cracks that
    coincide with nothing are returned unchanged."""
    kept: list[Crack] = []
    for crack, edge in zip(cracks, edges):
        twice = next((k for k, other in enumerate(kept) if _found_twice(crack, other)), None)
        if twice is not None:
            kept[twice] = _longer(kept[twice], crack)
            continue
        joined = None
        for k, other in [(None, h) for h in history] + list(enumerate(kept)):  # k: index in kept, None: history
            if _coincides(crack, other, float(edge)):
                crack = _on_plane(crack, other)
                joined = None if k is None else _holder(crack, other, float(edge))
                if joined is not None:
                    kept[k] = joined
                break
        if joined is None:
            kept.append(crack)
    return kept
