"""A fracture event works on the particle store in place (issue 17, item 4).

The tet particles live in Taichi ndarrays (geometry.particle_store); an event takes the struck
body's particles, cuts them and writes them back. These tests count the store's copies to and from
the host (`ParticleStore.transfers`, rows per copy) over one event and what the frame does after it
(the render's surface update, the state guard, the pieces count): nothing of the size of the world
crosses, and the event in a scene of four pots equals the same event in a scene of one.
"""

from __future__ import annotations

import numpy as np
import pytest

STRIKE = (0.0, -3.2, 0.0)  # m/s: the pot scene's drop of 0.6 m, straight down
SPACING = 0.3  # m: between neighbouring pots (a pot is 0.18 m wide)


def _pots(count: int):
    import anisofrac

    return anisofrac.load("pot", [f"objects.pot.count={count}", f"objects.pot.spacing=[{SPACING},0.0,0.0]",
                                  "scene.gravity=[0.0,0.0,0.0]"])


def _strike_first_pot(sim):
    """The event on pot 0 and the store's transfers from the strike to the end of what follows it."""
    from render.surface_blocks import SurfaceCache
    from sim.guards import check_state

    world = sim.world
    cache = SurfaceCache()
    cache.surfaces(world)  # the surfaces before the event (one take of every body)
    point = sim.surface_point(0, (0.0, -1.0, 0.0))
    world.store.transfers.clear()
    record = sim.strike(0, point, STRIKE)
    event = list(world.store.transfers)
    mesh = cache.surfaces(world)
    check_state(world)
    pieces = world.pieces()
    return record, event, list(world.store.transfers), mesh, pieces


@pytest.mark.usefixtures("taichi_runtime")
def test_an_event_copies_only_its_body():
    with _pots(4) as sim:
        store = sim.world.store
        pot = int(np.count_nonzero(sim.world.particles.body == 0))  # the struck pot's particles
        record, event, frame, mesh, pieces = _strike_first_pot(sim)
        assert record is not None and record["cracks"] >= 1 and record["subdivided"] > 0  # the blow cut the pot
        world_rows = store.count
        assert world_rows > 3 * pot  # four pots and the children of one
        names = [name for name, _ in frame]
        assert "host" not in names and "reset" not in names  # no whole-store download or upload
        children = int(record["subdivided"])
        # the event takes the pot (its alive particles and their parents) once and writes it back with
        # its children; the surfaces take the new fragments only; the rest are per-body totals
        assert [name for name, _ in event] == ["take_bodies", "put_body"]
        assert event[0][1] == pot and event[1][1] == pot + children
        for name, rows in frame[2:]:
            assert name in ("take_bodies", "body_totals") and rows <= pot + children, (name, rows)
        # every live body has its surface: the pot's fragments (new) and the three other pots (cached)
        assert np.unique(mesh.face_label).tolist() == sorted([1, 2, 3, *record["new_bodies"]])
        assert pieces["total"] >= record["fragments"] + 3


@pytest.mark.usefixtures("taichi_runtime")
def test_an_event_does_not_depend_on_the_rest_of_the_scene():
    """The same blow on the same pot breaks it the same way alone and beside three others."""
    out = []
    for count in (1, 4):
        with _pots(count) as sim:
            record, *_ = _strike_first_pot(sim)
            ps = sim.world.particles
            mine = np.isin(ps.body, record["new_bodies"])
            out.append((record["fragments"], record["debris"], record["subdivided"], int(mine.sum()),
                        np.sort(ps.volume[mine])))
    one, four = out
    assert one[:4] == four[:4]
    np.testing.assert_allclose(one[4], four[4], rtol=1e-9)  # the aim point: a ray cast across the scene
