"""The rows a fracture event takes per body (geometry/body_rows.py): kept on the host where the store
writes, they are at every step what a pass over the whole store finds (a body's alive particles and
the parents of its subdivided ones), both for random writes and through real fracture events."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geometry.body_rows import BodyRows
from geometry.particles import KIND_PHYSICAL, KIND_SUBDIVIDED


def _scan(body: np.ndarray, alive: np.ndarray, kind: np.ndarray, parent: np.ndarray, bodies) -> np.ndarray:
    """The rows of `bodies` by a pass over every row (what the store's selection kernel did)."""
    mine = alive & np.isin(body, list(bodies)) & (body >= 0)
    rows = np.flatnonzero(mine)
    parents = parent[rows[kind[rows] == KIND_SUBDIVIDED]]
    return np.unique(np.concatenate([rows, parents])).astype(np.int32)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.integers(0, 10_000))
def test_random_writes_list_what_a_scan_finds(seed):
    """Rows rewritten, appended, freed (body -1), killed and subdivided at random, a body at a time or
    across bodies: every body's rows, and those of sets of bodies, equal a scan of the mirror."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 60))
    body = rng.integers(-1, 5, n)
    alive = rng.random(n) < 0.8
    kind = np.full(n, KIND_PHYSICAL, np.int8)
    parent = np.full(n, -1, np.int64)
    index = BodyRows()
    index.reset(body, alive, kind, parent)
    for _ in range(int(rng.integers(1, 8))):
        old = rng.choice(len(body), int(rng.integers(0, len(body) + 1)), replace=False)
        new = int(rng.integers(0, 20))  # appended children of rewritten (or any) rows
        rows = np.concatenate([old, len(body) + np.arange(new)])
        body = np.concatenate([body, np.zeros(new, np.int64)])
        alive = np.concatenate([alive, np.zeros(new, bool)])
        kind = np.concatenate([kind, np.full(new, KIND_SUBDIVIDED, np.int8)])
        parent = np.concatenate([parent, rng.integers(0, len(parent), new)])
        body[rows] = rng.integers(-1, 8, len(rows))
        alive[rows] = rng.random(len(rows)) < 0.7
        index.write(rows, body[rows], alive[rows], kind[rows], parent[rows])
        for b in range(-1, 9):
            assert np.array_equal(index.rows([b]), _scan(body, alive, kind, parent, [b])), b
        some = rng.choice(9, 3, replace=False).tolist()
        assert np.array_equal(index.rows(some), _scan(body, alive, kind, parent, some))


@pytest.mark.usefixtures("taichi_runtime")
def test_events_take_what_a_scan_of_the_store_finds():
    """Two blows on a pot (the second on a piece of the first): after each, every body's rows in the
    store's index are those a scan of the whole store (its host copy) finds, and a take gathers them."""
    import anisofrac

    sim = anisofrac.load("pot", ["scene.gravity=[0.0,0.0,0.0]"])
    world, store = sim.world, sim.world.store
    for blow in range(2):
        body = max(world.bodies, key=lambda b: int(np.count_nonzero(world.particles.body == b)))
        record = sim.strike(body, sim.surface_point(body, (0.0, -1.0, 0.0)), (0.0, -3.2, 0.0))
        assert record is not None and record["subdivided"] > 0, blow  # children: their parents are taken too
        host, _ = store.host()
        for b in world.bodies:
            expected = _scan(host.body, host.alive, host.kind, host.parent, [b])
            assert np.array_equal(store.take_bodies([b])[0], expected), (blow, b)
        both = sorted(world.bodies)[:2]
        assert np.array_equal(store.take_bodies(both)[0], _scan(host.body, host.alive, host.kind, host.parent, both))
