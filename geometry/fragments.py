"""A fracture event on the particle graph, and the fragments it leaves (Sect. 5.2, Algorithm 2).

`apply_cracks` runs the geometry half of one fracture event on the touched bodies: for each crack
in turn, adaptive subdivision of the tets it cuts (mode 'subdivision'; never of a particle already
subdivided), then removal of the links it crosses (both modes: the rule of geometry.cutting);
finally, with `shatter`, every particle within a crack's r_inner of its point loses all its links.
`fragment_labels` gives the connected components of the remaining links (face links and extra
links) of the touched bodies: one label per alive particle, numbered in order of the smallest
particle id of each fragment (deterministic).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from core.errors import ConfigError
from geometry.components import component_labels
from geometry.cutting import (
    Bodies,
    Crack,
    body_mask,
    remove_crossed_links,
    remove_links_crossing_any,
    shatter_particles,
)
from geometry.particles import ParticleSet
from geometry.pulverise import pulverise
from geometry.subdivision import SNAP_REL, SubdivisionReport, subdivide

MODES = ("basic", "subdivision")


@dataclass
class FractureReport:
    """What one event did, crack by crack."""

    mode: str
    subdivision: list[SubdivisionReport] = field(default_factory=list)  # one per crack (subdivision mode)
    removed_links: list[int] = field(default_factory=list)  # links removed by each crack
    debris: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # shattered particle ids
    crushed: int = 0  # grain rows the crushed core added (subdivision mode: 4 per crushed particle)
    labels: np.ndarray | None = None  # (N,) fragment label per particle, -1 = dead or not touched
    n_fragments: int = 0
    # wall-clock seconds per stage (Table 2 of the paper: particle subdivision, crack generation)
    timings: dict = field(default_factory=lambda: {"subdivision_s": 0.0, "links_s": 0.0, "shatter_s": 0.0,
                                                                  "labels_s": 0.0})


def fragment_labels(ps: ParticleSet, bodies: Bodies = None) -> np.ndarray:
    """(N,) int64: connected component of each alive particle of `bodies` (all bodies if None)
    over face links and extra links; -1 for dead particles and particles of other bodies.
    Labels are 0..F-1, numbered by the smallest particle id of each fragment."""
    n = len(ps)
    sel = body_mask(ps, bodies)
    i, k = np.nonzero(ps.links >= 0)
    j = ps.links[i, k]
    rows = [i]
    cols = [j]
    if len(ps.extra_links):
        rows.append(ps.extra_links[:, 0])
        cols.append(ps.extra_links[:, 1])
    r = np.concatenate(rows)
    c = np.concatenate(cols)
    ok = sel[r] & sel[c]
    return component_labels(n, np.flatnonzero(sel), r[ok], c[ok])


def fragment_volumes(ps: ParticleSet, labels: np.ndarray) -> np.ndarray:
    """(F,) m^3: summed tet volume of each fragment."""
    ok = labels >= 0
    return np.bincount(labels[ok], weights=ps.volume[ok], minlength=int(labels.max()) + 1 if ok.any() else 0)


def apply_cracks(
    ps: ParticleSet,
    cracks: list[Crack],
    mode: str = "basic",
    shatter: bool = False,
    bodies: Bodies = None,
    snap_rel: float = SNAP_REL,
    label: bool = True,
    history: list[Crack] | None = None,
) -> tuple[ParticleSet, FractureReport]:
    """One fracture event: cut (and subdivide) with each crack, shatter, label the fragments.

    ps: the particle set (not modified; a new one is returned). bodies: the touched body ids
    (None = every body). mode: 'basic' (link removal only) or 'subdivision' (Algorithm 2).
    history: earlier cracks of these bodies (previous events) whose cut must stay cut.

    Children inherit their parent's relations, but their centroids differ from the parent's, so a
    child's link can cross a crack that its parent's link did not. After each subdivision the
    links of the new children are therefore tested again against the earlier cracks of this
    event and against `history`: the invariant "no link crosses a crack" holds for all of them.
    """
    if mode not in MODES:
        raise ConfigError("fracture.mode", mode, "'basic' or 'subdivision'")
    rep = FractureReport(mode=mode)
    done: list[Crack] = list(history or [])
    clock = time.perf_counter
    debris = np.zeros(0, dtype=np.int64)
    if shatter:
        # shatter first: a particle inside r_inner loses all its links anyway, so it is neither
        # subdivided nor cut (its children would only become more debris); it leaves the bodies
        # while the cracks are cut and gets its own label at the end
        t0 = clock()
        ps, debris = shatter_particles(ps, cracks, bodies=bodies)
        if mode == "subdivision":  # the shattered core is crushed into grains below the particle size
            n_before = len(ps)
            ps, debris = pulverise(ps, debris, cracks)
            rep.crushed = len(ps) - n_before
        rep.debris = debris
        debris_body = ps.body[debris].copy()
        ps = replace(ps, body=ps.body.copy())
        ps.body[debris] = -1
        rep.timings["shatter_s"] += clock() - t0
    for crack in cracks:
        n_removed = 0
        if mode == "subdivision":
            t0 = clock()
            ps, srep = subdivide(ps, crack, bodies=bodies, snap_rel=snap_rel)
            rep.timings["subdivision_s"] += clock() - t0
            rep.subdivision.append(srep)
            if srep.children and done:
                new = np.zeros(len(ps), dtype=bool)
                new[srep.first_child :] = True
                t0 = clock()
                ps, n_removed = remove_links_crossing_any(ps, done, bodies, new)
                rep.timings["links_s"] += clock() - t0
        t0 = clock()
        ps, n = remove_crossed_links(ps, crack, bodies=bodies)
        rep.timings["links_s"] += clock() - t0
        rep.removed_links.append(n_removed + n)
        done.append(crack)
    if shatter:
        ps.body[debris] = debris_body
    if label:
        t0 = clock()
        rep.labels = fragment_labels(ps, bodies)
        rep.timings["labels_s"] = clock() - t0
        rep.n_fragments = int(rep.labels.max()) + 1 if (rep.labels >= 0).any() else 0
    return ps, rep
