"""The earliest time at which any two things of a rigid world could touch (issue 16: a start that
does not wait for what only a contact needs; sim/warm_up.py).

A lower bound, from the host's copy of the world: each body's bounding sphere about its centre of
mass (`body_reach`, which rotation does not move), its velocity, and gravity. Two moving bodies fall
together, so their gap closes no faster than their relative speed; a moving body and a static one or
a collider (a half-space or a box) close by at most |v| t + |g| t^2 / 2. Contacts are made
`speculative_margin_m` before touching, so the margin counts as closed already. Bodies that touch,
or overlap their bounds, give 0.
"""

from __future__ import annotations

import math

import numpy as np

from rigid.quat import quat_to_matrix


def _time_to_close(gap: np.ndarray, speed: np.ndarray, accel: float) -> np.ndarray:
    """s: the least t >= 0 with speed t + accel t^2 / 2 >= gap (inf where never; 0 where gap <= 0)."""
    gap = np.maximum(gap, 0.0)
    if accel > 0.0:
        return (np.sqrt(speed * speed + 2.0 * accel * gap) - speed) / accel
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(gap <= 0.0, 0.0, np.where(speed > 0.0, gap / speed, math.inf))


def _collider_gaps(col: dict, x: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """(K, N) m: from each body's bounding sphere to each collider (negative where they overlap)."""
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


def earliest_contact_s(world, gravity, margin: float) -> float:
    """s: no contact can be made in the `world` (rigid.world.RigidWorld) before this time."""
    n = world.n_bodies
    if n == 0:
        return math.inf
    st = world.body_state()
    alive = st.alive[:n]
    x, v = st.x[:n][alive], st.v[:n][alive]
    reach = world.body_reach()[:n][alive]
    static = np.asarray(world._hb.static[:n], dtype=bool)[alive]
    speed = np.where(static, 0.0, np.linalg.norm(v, axis=1))
    g = float(np.linalg.norm(np.asarray(gravity, dtype=np.float64)))
    best = math.inf
    moving = ~static
    if len(x) > 1:
        i, j = np.triu_indices(len(x), 1)  # every pair once
        d = np.linalg.norm(x[i] - x[j], axis=1) - reach[i] - reach[j] - margin
        both, one = moving[i] & moving[j], moving[i] ^ moving[j]
        if both.any():  # falling together: only their relative speed closes the gap
            best = min(best, float(_time_to_close(d[both], np.linalg.norm(v[i] - v[j], axis=1)[both], 0.0).min()))
        if one.any():  # a static body does not fall: the moving one closes with gravity
            best = min(best, float(_time_to_close(d[one], np.maximum(speed[i], speed[j])[one], g).min()))
    if world._ncol and moving.any():
        gaps = _collider_gaps(world._col, x[moving], reach[moving]) - margin
        best = min(best, float(_time_to_close(gaps, np.broadcast_to(speed[moving], gaps.shape), g).min()))
    return best


__all__ = ["earliest_contact_s"]
