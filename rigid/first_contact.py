"""The earliest time at which any two things of a rigid world could touch (issue 16: a start that
does not wait for what only a contact needs; sim/warm_up.py).

A lower bound, from the host's copy of the world, in two passes:
- Bounding spheres: each body's bounding sphere about its centre of mass (`body_reach`, which
  rotation does not move), its velocity and gravity. Two moving bodies fall together, so their gap
  closes no faster than their relative speed; a moving body and a static or sleeping one or a
  collider (a half-space or a box) close by at most |v| t + |g| t^2 / 2.
- Collision spheres, where the bounding spheres give a time sooner than the best so far (in that
  order): the least gap between the two bodies' spheres (or between a body's spheres and a
  collider), closed at the speed above plus each body's spin times its reach. A free body's spin can
  grow while it tumbles (its kinetic energy w.I.w / 2 is kept), at most by sqrt(I_max / I_min). The
  pieces of a pot stacked on another, or a body resting in a frame, overlap their bounding spheres
  without touching: the first pass alone gives 0 for them.

Either pass is a lower bound; each pair keeps the larger of its two. Contacts are made
`speculative_margin_m` before touching, so the margin counts as closed already. Nothing else can
speed a body up before the first contact, so the least over all pairs bounds that contact. A
speculative contact is made at the start of the step in which the pair can close, up to one rigid
step before this time (sim/warm_up.py keeps SAFETY_FRAMES frames between).
"""

from __future__ import annotations

import math

import numpy as np

from rigid.quat import quat_to_matrix

PAIR_WORK_LIMIT = 4_000_000  # sphere pairs measured for one pair of bodies; above: the bounding-sphere time stands
CHUNK = 256  # spheres of one body measured against the other's at once


def _time_to_close(gap: np.ndarray, speed: np.ndarray, accel: float) -> np.ndarray:
    """s: the least t >= 0 with speed t + accel t^2 / 2 >= gap (inf where never; 0 where gap <= 0)."""
    gap = np.maximum(gap, 0.0)
    if accel > 0.0:
        return (np.sqrt(speed * speed + 2.0 * accel * gap) - speed) / accel
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(gap <= 0.0, 0.0, np.where(speed > 0.0, gap / speed, math.inf))


def _collider_gaps(col: dict, x: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """(K, N) m: from each sphere (centre x, radius reach) to each collider (negative where they overlap)."""
    gaps = []
    for kind, at, q, n, half in zip(col["kind"], col["x"], col["q"], col["n"], col["half"]):
        at = np.asarray(at, dtype=np.float64)
        if kind == 0:  # half-space, solid below the plane through `at` with normal n
            gaps.append((x - at) @ np.asarray(n, dtype=np.float64) - reach)
        else:  # box: the distance from the centre to the box, outside it
            local = (x - at) @ quat_to_matrix(np.asarray(q, dtype=np.float64))
            out = np.maximum(np.abs(local) - np.asarray(half, dtype=np.float64), 0.0)
            gaps.append(np.linalg.norm(out, axis=1) - reach)
    return np.array(gaps).reshape(len(gaps), len(x))


class _Motion:
    """The alive bodies (indices into the world's) with their bounds, speeds and collision spheres."""

    def __init__(self, world) -> None:
        n = world.n_bodies
        st = world.body_state()
        self.ids = np.flatnonzero(st.alive[:n])
        ids = self.ids
        self.x, self.v = st.x[ids], st.v[ids]
        self.reach = world.body_reach()[ids].astype(np.float64)
        # a sleeping body does not move until a contact wakes it: held like a static one (a body
        # falling onto it closes the gap under gravity), and two held bodies never meet
        self.static = world.static_mask()[ids] | st.asleep[ids]
        self.speed = np.where(self.static, 0.0, np.linalg.norm(self.v, axis=1))
        self.spin = np.zeros(len(ids))  # m/s: the fastest a point of the body can move about its centre
        for k in np.flatnonzero(~self.static & (np.linalg.norm(st.w[ids], axis=1) > 0.0)):
            eig = np.linalg.eigvalsh(world.body_inertia(int(ids[k])))
            self.spin[k] = np.linalg.norm(st.w[ids[k]]) * math.sqrt(eig[-1] / eig[0]) * self.reach[k]
        local, radius, body = world.sphere_data()
        rot = quat_to_matrix(st.q[:n])
        self.centre = st.x[body] + np.einsum("nij,nj->ni", rot[body], local.astype(np.float64))
        self.radius = radius.astype(np.float64)
        # spheres of the k-th alive body: order[start[k]:start[k + 1]]
        slot = np.full(n, -1)
        slot[ids] = np.arange(len(ids))
        self.owner = slot[body]  # (NS,) the alive body (index into ids) of each sphere, -1 for a removed one
        self.order = np.argsort(self.owner, kind="stable")
        self.start = np.searchsorted(self.owner[self.order], np.arange(len(ids) + 1))

    def spheres(self, k: int) -> np.ndarray:
        return self.order[self.start[k]:self.start[k + 1]]


def _sphere_gap(m: _Motion, a: int, b: int, reach_by: float) -> float:
    """m: the least gap between the spheres of alive bodies a and b, of those that can reach within
    `reach_by` of the other body's bounding sphere (inf where none can; nan above PAIR_WORK_LIMIT)."""
    sa, sb = m.spheres(a), m.spheres(b)
    sa = sa[np.linalg.norm(m.centre[sa] - m.x[b], axis=1) - m.radius[sa] - m.reach[b] <= reach_by]
    sb = sb[np.linalg.norm(m.centre[sb] - m.x[a], axis=1) - m.radius[sb] - m.reach[a] <= reach_by]
    if len(sa) * len(sb) > PAIR_WORK_LIMIT:
        return math.nan
    least = math.inf
    xb, rb = m.centre[sb], m.radius[sb]
    for c in range(0, len(sa), CHUNK):
        part = sa[c:c + CHUNK]
        d = np.linalg.norm(m.centre[part][:, None] - xb[None], axis=2) - m.radius[part][:, None] - rb[None]
        if d.size:
            least = min(least, float(d.min()))
    return least


def _collider_times(world, m: _Motion, g: float, margin: float) -> float:
    """s: the earliest a moving body could reach a collider, from its bounding sphere and its spheres."""
    moving = np.flatnonzero(~m.static)
    col = world.colliders()
    if not col["kind"] or len(moving) == 0:
        return math.inf
    coarse = _time_to_close(_collider_gaps(col, m.x[moving], m.reach[moving]) - margin,
                            m.speed[moving], g)
    sph = np.flatnonzero(m.owner >= 0)
    sph = sph[~m.static[m.owner[sph]]]  # the moving bodies' spheres
    per_sphere = _collider_gaps(col, m.centre[sph], m.radius[sph]) - margin
    least = np.full((len(per_sphere), len(m.ids)), np.inf)  # (K, bodies) m: each body's nearest sphere
    for k in range(len(least)):
        np.minimum.at(least[k], m.owner[sph], per_sphere[k])
    fine = _time_to_close(least[:, moving], m.speed[moving] + m.spin[moving], g)
    return float(np.maximum(coarse, fine).min())


def earliest_contact_s(world, gravity, margin: float) -> float:
    """s: no contact can be made in the `world` (rigid.world.RigidWorld) before this time."""
    if world.n_bodies == 0:
        return math.inf
    m = _Motion(world)
    g = float(np.linalg.norm(np.asarray(gravity, dtype=np.float64)))
    best = _collider_times(world, m, g, margin)
    if len(m.ids) < 2:
        return best
    i, j = np.triu_indices(len(m.ids), 1)  # every pair once
    keep = ~(m.static[i] & m.static[j])
    i, j = i[keep], j[keep]
    both = ~m.static[i] & ~m.static[j]
    # falling together: only their relative speed closes the gap; a static body does not fall
    speed = np.where(both, np.linalg.norm(m.v[i] - m.v[j], axis=1), np.maximum(m.speed[i], m.speed[j]))
    accel = np.where(both, 0.0, g)
    gap = np.linalg.norm(m.x[i] - m.x[j], axis=1) - m.reach[i] - m.reach[j] - margin
    coarse = np.where(both, _time_to_close(gap, speed, 0.0), _time_to_close(gap, speed, g))
    speed = speed + m.spin[i] + m.spin[j]
    for p in np.argsort(coarse, kind="stable"):
        if coarse[p] >= best:
            break
        a, b, acc = i[p], j[p], accel[p]
        closing = speed[p] * best + 0.5 * acc * best * best if math.isfinite(best) else math.inf
        least = _sphere_gap(m, a, b, margin + closing)
        if math.isnan(least):
            best = min(best, float(coarse[p]))
            continue
        fine = float(_time_to_close(np.array([least - margin]), np.array([speed[p]]), acc)[0])
        best = min(best, max(float(coarse[p]), fine))
    return best


__all__ = ["earliest_contact_s"]
