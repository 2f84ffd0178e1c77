"""Crack regions and link removal (Sect. 5.2, Fig. 3b-c; shattering from Sect. 4.2).

A crack (Algorithm 1 of the paper gives one per group) is the part of a plane (point P, unit
normal n) within `r_outer` of P, restricted to the half-plane (x - P) . side >= 0 of its group's
in-plane direction `side` (a half-disc); `side = None` gives the full disc. `r_inner > 0` marks the
shatter radius: every particle whose rest centroid lies within it loses all its links (debris).
A crack from an impact analysis also carries its `ShatterField`, the shatter energy's spread around
P, so that each particle is freed by its own size (a smaller particle needs a higher energy density)
and by the crack faces it opens (geometry/freeing.py); r_inner is then the radius within which
particles of the reference size, inside a zone of freed ones, are freed.

Link-removal rule (both modes, one rule for face links and extra links): the link between
particles i and j is removed when the segment joining their rest centroids crosses the crack
plane (the centroids lie strictly on opposite sides, a centroid exactly on the plane counting as
the negative side) at a point inside the crack region. The crossing point is computed from the
two centroids in a canonical (lexicographic) order, so the rule is symmetric to the bit. After
adaptive subdivision every child lies on one side of the cut surface, so for the children of the
cut tets this removes exactly the links across faces lying in the cut surface whose crossing point
is inside the region (all of them when the region spans the tets); see docs/notes_fracture.md.

Everything here is vectorised numpy in float64 (geometry is host-side and exact conformity of
cut points needs f64); no Python loop runs per particle.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, replace

import numpy as np

from core.arrays import cross3
from core.errors import ConfigError
from geometry.freeing import freed_particles
from geometry.particles import ParticleSet, tet_edge

Bodies = Iterable[int] | int | None  # body ids an operation touches (None = every body)


def _vec3(value, key: str) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ConfigError(key, value, "three finite numbers")
    return a


GRAINS_PER_PARTICLE = 4  # grains a crushed tet splits into (its centroid split, geometry/pulverise.py)
# -: a grain's u_limit (~ 1 / edge) is GRAINS^(1/3) times its particle's, so its level is GRAINS^(1/9) times
GRAIN_LEVEL = GRAINS_PER_PARTICLE ** (1.0 / 9.0)


@dataclass(frozen=True)
class ShatterField:
    """The shatter energy U spread around P by the poly6 kernel of support h (sph/cracks.py step 8):
    u(d) = 315/(64 pi h^9) (h^2 - d^2)^3 U / w. Inside a zone of freed particles, a particle of tet edge
    e is freed where u exceeds its own u_limit = G_c A / (2 V) ~ 1/e (elsewhere by the faces it opens,
    `energy_ratio` and geometry/freeing.py), i.e. within

        d^2 < h^2 (1 - level (edge / e)^(1/3)),   level = (64 pi h^9 u_limit(edge) w / (315 U))^(1/3) / h^2,

    `edge` the reference particle's (the one nearest P). Quarter-volume grains need 4^(1/3) that
    energy density (level x 4^(1/9)): subdivision mode crushes a physical particle where they break
    free. Every particle within `r_plug` (a striker's plug) is freed and crushed; none beyond `cap`
    (a crack stopped at another material)."""

    support: float  # m: h, the spread's support (the analysed kernel's radius)
    level: float  # -: see above; >= 1 where the reference particle is not freed (inf: no energy)
    edge: float  # m: tet edge of the reference particle
    r_plug: float = 0.0  # m
    cap: float = math.inf  # m

    def __post_init__(self) -> None:
        for key in ("support", "level", "edge", "r_plug", "cap"):
            v = float(getattr(self, key))
            if not (v >= 0.0 and not math.isnan(v)) or (key not in ("level", "cap") and math.isinf(v)):
                raise ConfigError(f"shatter.{key}", getattr(self, key), "a value >= 0 (finite but level and cap)")
            object.__setattr__(self, key, v)

    def radius2(self, volume: np.ndarray, grains: bool = False) -> np.ndarray:
        """(K,) m^2: squared radius within which particles of these volumes (K,) m^3 are freed (or,
        `grains`, crushed into quarter grains)."""
        e = np.maximum(tet_edge(volume), 1e-300)
        level = self.level * (GRAIN_LEVEL if grains else 1.0) * np.cbrt(self.edge / e)
        r2 = np.maximum(self.support**2 * (1.0 - np.minimum(level, 1.0)), self.r_plug**2)
        return np.minimum(r2, self.cap**2)

    def energy_ratio(self, dist2: np.ndarray, volume: np.ndarray) -> np.ndarray:
        """(K,) -: u / u_limit of particles of these volumes (K,) m^3 at squared distances (K,) m^2
        from P, ((1 - d^2/h^2) / (level (edge / e)^(1/3)))^3 (> 1 within `radius2`); 0 beyond the
        support or the cap."""
        level = self.level * np.cbrt(self.edge / np.maximum(tet_edge(volume), 1e-300))
        s = np.clip(1.0 - dist2 / self.support**2, 0.0, None) if self.support > 0.0 else np.zeros(len(dist2))
        with np.errstate(divide="ignore"):
            ratio = np.where(np.isfinite(level), (s / level) ** 3, 0.0)
        return np.where(dist2 < self.cap**2, ratio, 0.0)

    def radius(self, volume: float, grains: bool = False) -> float:
        """m: the radius for one particle volume."""
        return float(np.sqrt(self.radius2(np.array([volume]), grains)[0]))


@dataclass(frozen=True)
class Crack:
    """A planar crack region: half-disc (or disc) of radius r_outer around P in the plane (P, n)."""

    point: np.ndarray  # (3,) m: P, the analysed contact point
    normal: np.ndarray  # (3,) -: unit normal of the crack plane (normalised on construction)
    r_outer: float  # m: crack radius (Eq. 11)
    side: np.ndarray | None = None  # (3,) -: unit in-plane direction of the group, None = full disc
    r_inner: float = 0.0  # m: shatter radius (0 = no shattering)
    r_crush: float = 0.0  # m: radius within r_inner that subdivision mode crushes into finer grains (0 = none)
    shatter: ShatterField | None = None  # per particle size (r_inner, r_crush: the reference size's); None: radii
    source: str = field(default="crack", compare=False)  # name for error messages

    def __post_init__(self) -> None:
        src = self.source
        p = _vec3(self.point, f"{src}.point")
        n = _vec3(self.normal, f"{src}.normal")
        norm = float(np.linalg.norm(n))
        if not norm > 0.0:
            raise ConfigError(f"{src}.normal", self.normal, "a non-zero vector")
        n = n / norm
        r = float(self.r_outer)
        if not (np.isfinite(r) and r > 0.0):
            raise ConfigError(f"{src}.r_outer", self.r_outer, "a finite radius > 0 m")
        ri = float(self.r_inner)
        if not (np.isfinite(ri) and ri >= 0.0):
            raise ConfigError(f"{src}.r_inner", self.r_inner, "a finite radius >= 0 m")
        side = None
        if self.side is not None:
            s = _vec3(self.side, f"{src}.side")
            s_len = float(np.linalg.norm(s))
            if s_len > 0.0:
                s_in = s - np.dot(s, n) * n
                s_in_len = float(np.linalg.norm(s_in))
                if s_in_len <= 1e-6 * s_len:
                    raise ConfigError(f"{src}.side", self.side, "a direction not parallel to the normal")
                side = s_in / s_in_len
        object.__setattr__(self, "point", p)
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "r_outer", r)
        rc = float(self.r_crush)
        if not (np.isfinite(rc) and 0.0 <= rc <= ri):
            raise ConfigError(f"{src}.r_crush", self.r_crush, f"a finite radius in [0, r_inner = {ri:g}] m")
        object.__setattr__(self, "r_inner", ri)
        object.__setattr__(self, "r_crush", rc)
        object.__setattr__(self, "side", side)

    @property
    def full_disc(self) -> bool:
        return self.side is None


# ---------------------------------------------------------------------------------------------
# geometric predicates


def signed_distance(crack: Crack, x: np.ndarray) -> np.ndarray:
    """(...,) m: signed distance of points (..., 3) to the crack plane.

    Written component by component (no BLAS reduction) so that the same point always gives the
    same bits, whichever array it sits in: the cut points of neighbouring tets depend on it.
    """
    p, n = crack.point, crack.normal
    return (x[..., 0] - p[0]) * n[0] + (x[..., 1] - p[1]) * n[1] + (x[..., 2] - p[2]) * n[2]


def _dot3(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    return a[..., 0] * v[0] + a[..., 1] * v[1] + a[..., 2] * v[2]


def in_region(crack: Crack, x: np.ndarray) -> np.ndarray:
    """(...,) bool: the projection of points (..., 3) onto the plane lies in the crack region."""
    q = x - crack.point
    q = q - _dot3(q, crack.normal)[..., None] * crack.normal
    inside = (q[..., 0] ** 2 + q[..., 1] ** 2 + q[..., 2] ** 2) <= crack.r_outer**2
    if crack.side is not None:
        inside &= _dot3(q, crack.side) >= 0.0
    return inside


def lex_less(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(...,) bool: point a (..., 3) is lexicographically smaller than point b."""
    return (a[..., 0] < b[..., 0]) | (
        (a[..., 0] == b[..., 0])
        & ((a[..., 1] < b[..., 1]) | ((a[..., 1] == b[..., 1]) & (a[..., 2] < b[..., 2])))
    )


def segment_crosses(crack: Crack, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(M,) bool: segment a-b (each (M, 3)) crosses the plane at a point inside the region.

    Symmetric in a and b to the bit (the crossing point is computed from the lexicographically
    smaller end). A point exactly on the plane counts as the negative side.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    swap = lex_less(b, a)[..., None]
    a, b = np.where(swap, b, a), np.where(swap, a, b)
    da, db = signed_distance(crack, a), signed_distance(crack, b)
    crosses = (da > 0.0) != (db > 0.0)
    out = np.zeros(crosses.shape, dtype=bool)
    if crosses.any():
        a, b, da, db = a[crosses], b[crosses], da[crosses], db[crosses]
        t = da / (da - db)
        out[crosses] = in_region(crack, a + t[..., None] * (b - a))
    return out


def _inplane_segment_meets_region(crack: Crack, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(M,) bool: segment a-b lying in the crack plane meets the (closed) half-disc region."""
    n = crack.normal
    qa = a - crack.point
    qa = qa - _dot3(qa, n)[..., None] * n
    qb = b - crack.point
    qb = qb - _dot3(qb, n)[..., None] * n
    u = qb - qa
    A = np.einsum("...i,...i->...", u, u)
    B = 2.0 * np.einsum("...i,...i->...", qa, u)
    C = np.einsum("...i,...i->...", qa, qa) - crack.r_outer**2
    disc = B * B - 4.0 * A * C
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(np.maximum(disc, 0.0))
        t0 = np.where(A > 0, (-B - sq) / (2.0 * A), 0.0)
        t1 = np.where(A > 0, (-B + sq) / (2.0 * A), 0.0)
    lo = np.maximum(t0, 0.0)
    hi = np.minimum(t1, 1.0)
    hit = np.where(A > 0, (disc >= 0.0) & (lo <= hi), C <= 0.0)
    if crack.side is not None:
        sa = _dot3(qa, crack.side)
        su = _dot3(u, crack.side)
        lo_c = np.where(A > 0, lo, 0.0)
        hi_c = np.where(A > 0, hi, 0.0)
        hit &= np.maximum(sa + lo_c * su, sa + hi_c * su) >= 0.0
    return hit


def triangle_crosses(crack: Crack, tri: np.ndarray) -> np.ndarray:
    """(M,) bool: the crack region cuts triangle (M, 3, 3): the plane separates its vertices
    (strictly) and the cut segment meets the region. A triangle lying in the plane or only
    touching it counts as not crossed."""
    d = signed_distance(crack, tri)  # (M, 3)
    pos = d > 0.0
    npos = pos.sum(1)
    cut = (d.max(1) > 0.0) & (d.min(1) < 0.0)
    # the lone vertex (the one whose side differs from the other two, with d == 0 on the
    # negative side) and the two cut edges from it
    lone_is_pos = npos == 1
    lone = np.where(lone_is_pos, np.argmax(pos, 1), np.argmin(pos, 1))
    o1 = (lone + 1) % 3
    o2 = (lone + 2) % 3
    r = np.arange(len(tri))
    pl, p1, p2 = tri[r, lone], tri[r, o1], tri[r, o2]
    dl, d1, d2 = d[r, lone], d[r, o1], d[r, o2]
    with np.errstate(invalid="ignore", divide="ignore"):
        t1 = np.where(cut, dl / (dl - d1), 0.0)
        t2 = np.where(cut, dl / (dl - d2), 0.0)
    x1 = pl + t1[:, None] * (p1 - pl)
    x2 = pl + t2[:, None] * (p2 - pl)
    return cut & _inplane_segment_meets_region(crack, x1, x2)


def section_polygons(
    crack: Crack, verts: np.ndarray, d: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Plane section of tets (M, 4, 3): (M, 4, 3) polygon corners in cyclic order (a triangle
    repeats its last corner) and (M,) bool 'the plane separates the tet's vertices'."""
    if d is None:
        d = signed_distance(crack, verts)
    pos = d > 0.0
    npos = pos.sum(1)
    straddle = (npos > 0) & (npos < 4)
    # role order: 3-1 -> (lone, o, o, o); 2-2 -> (p, p, q, q)
    lone_pos = npos == 1
    key = np.where(
        (npos == 2)[:, None],
        (~pos).astype(np.int64),
        np.where(lone_pos[:, None], (~pos).astype(np.int64), pos.astype(np.int64)),
    )
    perm = np.argsort(key * 4 + np.arange(4), axis=1)
    v = np.take_along_axis(verts, perm[:, :, None], axis=1)
    dv = np.take_along_axis(d, perm, axis=1)

    def edge(i: int, j: int) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.where(straddle, dv[:, i] / (dv[:, i] - dv[:, j]), 0.0)
        t = np.nan_to_num(t)
        return v[:, i] + t[:, None] * (v[:, j] - v[:, i])

    tri = np.stack([edge(0, 1), edge(0, 2), edge(0, 3), edge(0, 3)], axis=1)
    quad = np.stack([edge(0, 2), edge(1, 2), edge(1, 3), edge(0, 3)], axis=1)
    poly = np.where((npos == 2)[:, None, None], quad, tri)
    return poly, straddle


def section_meets_region(crack: Crack, verts: np.ndarray, d: np.ndarray | None = None) -> np.ndarray:
    """(M,) bool: the crack region meets the plane section of tets (M, 4, 3): the tets the crack
    cuts. Exact test of a convex polygon against the (half-)disc: some polygon edge meets the
    region, or P lies inside the polygon."""
    poly, straddle = section_polygons(crack, verts, d)
    nxt = np.roll(poly, -1, axis=1)
    # the 4 polygon edges of every tet in one call (rows (tet, edge)): each edge's arithmetic as alone
    hit = _inplane_segment_meets_region(crack, poly.reshape(-1, 3), nxt.reshape(-1, 3)).reshape(-1, 4).any(axis=1)
    cr = np.einsum("mij,j->mi", cross3(nxt - poly, crack.point - poly), crack.normal)
    inside = np.all(cr >= 0.0, axis=1) | np.all(cr <= 0.0, axis=1)
    return straddle & (hit | inside)


# ---------------------------------------------------------------------------------------------
# link removal and shattering


def body_mask(ps: ParticleSet, bodies: Bodies) -> np.ndarray:
    """(N,) bool: alive particles of the given bodies (None = every body; body -1, freed debris, is
    in none)."""
    if bodies is None:
        return ps.alive & (ps.body >= 0)
    ids = np.asarray(list(np.atleast_1d(bodies)), dtype=np.int64)
    if len(ids) == 1:  # the usual case (one struck body): a comparison, not a set lookup
        return ps.alive & (ps.body == ids[0])
    return ps.alive & np.isin(ps.body, ids)


def crossed_link_mask(ps: ParticleSet, crack: Crack, bodies: Bodies = None) -> tuple[np.ndarray, np.ndarray]:
    """(N, 4) bool over face-link slots and (E,) bool over extra links: links the crack removes.

    Only the particles of `bodies` are looked at, so a cut costs what the struck body holds, not
    what the whole world holds (the Pots scene has 13 pots).
    """
    sel = body_mask(ps, bodies)
    idx = np.flatnonzero(sel)
    # only links whose centroids lie on opposite sides can cross: filter first (cheap), then
    # run the exact, symmetric segment test on those
    side = np.zeros(len(sel), dtype=bool)
    side[idx] = signed_distance(crack, ps.centroid[idx]) > 0.0
    links = ps.links
    own = links[idx]
    other = np.maximum(own, 0)
    r, k = np.nonzero((own >= 0) & sel[other] & (side[idx][:, None] != side[other]))
    i = idx[r]
    j = own[r, k]
    face = np.zeros(links.shape, dtype=bool)
    face[i, k] = segment_crosses(crack, ps.centroid[i], ps.centroid[j])
    ex = ps.extra_links
    extra = np.zeros(len(ex), dtype=bool)
    if len(ex):
        ok = sel[ex[:, 0]] & sel[ex[:, 1]] & (side[ex[:, 0]] != side[ex[:, 1]])
        extra[ok] = segment_crosses(crack, ps.centroid[ex[ok, 0]], ps.centroid[ex[ok, 1]])
    return face, extra


def remove_crossed_links(ps: ParticleSet, crack: Crack, bodies: Bodies = None) -> tuple[ParticleSet, int]:
    """Remove every face link and extra link the crack crosses (the rule in the module docstring).
    Returns a new ParticleSet (the input is not modified) and the number of links removed."""
    face, extra = crossed_link_mask(ps, crack, bodies)
    return _without(ps, face, extra)


def _without(ps: ParticleSet, face: np.ndarray, extra: np.ndarray) -> tuple[ParticleSet, int]:
    """`ps` without the face-link slots and extra links marked (both slots of a face link marked)."""
    links = ps.links.copy()
    links[face] = -1
    n_removed = int(face.sum()) // 2 + int(extra.sum())
    return replace(ps, links=links, extra_links=ps.extra_links[~extra].copy()), n_removed


def _marked_links(ps: ParticleSet, bodies: Bodies, marked: np.ndarray):
    """The links of `bodies` with an end marked ((N,) bool), each once: face links as their two slots
    (i, k_i) and (j, k_j) (face links are symmetric: j's slot back to i is the one whose entry is i, so
    the marked rows' own slots find every link), and the rows of such extra links."""
    sel = body_mask(ps, bodies)
    rows = np.flatnonzero(sel & marked)
    own = ps.links[rows]
    r, k = np.nonzero((own >= 0) & sel[np.maximum(own, 0)])
    i, j = rows[r], own[r, k]
    once = ~marked[j] | (i < j)  # a link between marked rows is found from both ends: kept from the lower
    i, k, j = i[once], k[once], j[once]
    k_back = np.argmax(ps.links[j] == i[:, None], axis=1)
    ex = ps.extra_links
    e = np.zeros(0, np.int64)
    if len(ex):
        e = np.flatnonzero(sel[ex[:, 0]] & sel[ex[:, 1]] & (marked[ex[:, 0]] | marked[ex[:, 1]]))
    return (i, k), (j, k_back), e


def remove_links_crossing_any(ps: ParticleSet, cracks: list[Crack], bodies: Bodies,
                              marked: np.ndarray) -> tuple[ParticleSet, int]:
    """Remove the links with an end marked ((N,) bool: the children a subdivision just made) that any
    of `cracks` crosses (the earlier cracks, whose cut must stay cut). The links are found once and
    tested against each crack, with the same side and segment tests as `crossed_link_mask` (symmetric
    in the two ends to the bit): the same links go as removing them crack by crack would. (For one crack
    over a whole body `crossed_link_mask`, which filters by side before it lists any link, is 3-4 times
    faster; listing the few marked links once suits many cracks.) Returns a new ParticleSet and how many
    went."""
    (i, ki), (j, kj), e = _marked_links(ps, bodies, marked)
    ex = ps.extra_links
    ends = [(ps.centroid[i], ps.centroid[j]), (ps.centroid[ex[e, 0]], ps.centroid[ex[e, 1]])]
    cut = [np.zeros(len(i), dtype=bool), np.zeros(len(e), dtype=bool)]  # face links, extra links
    for crack in cracks:
        for (a, b), gone in zip(ends, cut):
            apart = (signed_distance(crack, a) > 0.0) != (signed_distance(crack, b) > 0.0)
            gone[apart] |= segment_crosses(crack, a[apart], b[apart])
    face = np.zeros(ps.links.shape, dtype=bool)
    face[i[cut[0]], ki[cut[0]]] = True
    face[j[cut[0]], kj[cut[0]]] = True
    extra = np.zeros(len(ex), dtype=bool)
    extra[e[cut[1]]] = True
    return _without(ps, face, extra)


def shatter_radius2(crack: Crack, volume: np.ndarray, grains: bool = False) -> np.ndarray:
    """(K,) m^2: squared radius around the crack point within which particles of these volumes are
    freed (`grains`: crushed), by the crack's ShatterField, else r_inner (r_crush) for all."""
    if crack.shatter is None:
        return np.full(len(volume), (crack.r_crush if grains else crack.r_inner) ** 2)
    return crack.shatter.radius2(volume, grains)


def shatter_particles(ps: ParticleSet, cracks: Crack | list[Crack],
                      bodies: Bodies = None) -> tuple[ParticleSet, np.ndarray]:
    """Particles the shatter zones of `cracks` (one event's) free lose all their links (debris): by
    the energy each crack's ShatterField puts at their rest centroids, the largest for several, where
    it pays for the faces they open (geometry/freeing.py); every particle within a plug (`r_plug`) or
    a radius-only crack's r_inner.

    Returns a new ParticleSet and the ids of the shattered particles (ascending).
    """
    cracks = [cracks] if isinstance(cracks, Crack) else list(cracks)
    cracks = [c for c in cracks if c.r_inner > 0.0 or c.shatter is not None]
    if not cracks:
        return ps, np.zeros(0, dtype=np.int64)
    idx = np.flatnonzero(body_mask(ps, bodies))
    ratio = np.zeros(len(idx))
    forced = np.zeros(len(idx), dtype=bool)
    for crack in cracks:
        d = ps.centroid[idx] - crack.point
        d2 = np.einsum("ij,ij->i", d, d)
        if crack.shatter is None:
            forced |= d2 < crack.r_inner**2
        else:
            sf = crack.shatter
            ratio = np.maximum(ratio, sf.energy_ratio(d2, ps.volume[idx]))
            forced |= d2 < min(sf.r_plug, sf.cap) ** 2
    near = (ratio > 0.0) | forced
    idx, ratio, forced = idx[near], ratio[near], forced[near]
    debris = np.zeros(len(ps.alive), dtype=bool)
    debris[idx[freed_particles(ps, idx, ratio, forced)]] = True
    links = ps.links.copy()
    links[debris] = -1
    links[(links >= 0) & debris[np.maximum(links, 0)]] = -1
    ex = ps.extra_links
    keep = ~(debris[ex[:, 0]] | debris[ex[:, 1]]) if len(ex) else np.zeros(0, dtype=bool)
    return replace(ps, links=links, extra_links=ex[keep].copy()), np.flatnonzero(debris)
