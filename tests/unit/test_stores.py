"""The Taichi tet particle store mirrors the host particles exactly and refuses to overflow."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.build import build_object
from sim.errors import CapacityError
from sim.stores import TetParticleStore


@pytest.fixture(scope="module")
def box():
    return build_object("box", resolution=0.02)


def test_load_round_trips_every_field(box):
    ps = box.particles
    store = TetParticleStore(capacity=len(ps) + 100)
    try:
        store.load(ps)
        n = len(ps)
        assert store.count == n
        assert np.array_equal(store.tet_rest_verts.to_numpy()[:n], ps.rest_verts)
        assert np.array_equal(store.tet_links.to_numpy()[:n], ps.links)
        assert np.array_equal(store.tet_mass.to_numpy()[:n], ps.mass)
        assert np.all(store.tet_links.to_numpy()[n:] == -1)
        assert np.all(store.tet_alive.to_numpy()[n:] == 0)
        # default kernel: isotropic G = I / h with h = 4 r
        G = store.tet_kernel_G0.to_numpy()[:n]
        assert np.allclose(G[:, 0, 0], 1.0 / (4.0 * ps.radius))
        assert np.allclose(G[:, 0, 1], 0.0)
    finally:
        store.release()


def test_overflow_names_the_store_and_option(box):
    store = TetParticleStore(capacity=10)
    try:
        with pytest.raises(CapacityError, match="scene.particle_capacity"):
            store.load(box.particles)
        assert store.count == 0
    finally:
        store.release()
