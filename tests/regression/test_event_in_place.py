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


def _reference_spheres(rigid, body: int) -> set[tuple]:
    """A body's boundary spheres in the reference frame: (centre, radius) in nm (the store keeps the
    centres about the body's centre of mass: back in the reference frame they differ in the last bits)."""
    local, radius, _ = rigid.sphere_data()
    s = rigid.body_spheres(body)
    centre = local[s] + rigid.body_ref_com(body)
    return {tuple(np.round(np.r_[c, r] * 1e9).astype(np.int64).tolist()) for c, r in zip(centre, radius[s])}


@pytest.mark.usefixtures("taichi_runtime")
def test_a_split_keeps_the_spheres_away_from_its_crack():
    """The pot's fragments keep most of the pot's boundary spheres (groups the crack left whole,
    geometry/boundary.py), and each fragment's recorded groups are its spheres, so that the next
    split of a fragment keeps its spheres too."""
    with _pots(1) as sim:
        world = sim.world
        rigid = world.rigid
        before = _reference_spheres(rigid, 0)
        record, *_ = _strike_first_pot(sim)
        new = record["new_bodies"]
        after = set().union(*(_reference_spheres(rigid, b) for b in new))
        kept = before & after
        assert 0.6 * len(before) < len(kept) < len(before)
        for b in new:
            groups = world.bodies[b].spheres
            if groups is not None:  # None: a chip on its corners
                assert len(groups.member_start) - 1 == len(rigid.body_spheres(b))
        biggest = max(new, key=lambda b: len(rigid.body_spheres(b)))
        own = _reference_spheres(rigid, biggest)
        point = sim.surface_point(biggest, (0.0, -1.0, 0.0))
        again = sim.strike(biggest, point, (0.0, -6.0, 0.0))
        assert again is not None and again["fragments"] >= 2  # the largest fragment breaks again
        after = set().union(*(_reference_spheres(rigid, b) for b in again["new_bodies"]))
        assert len(own & after) > 0.3 * len(own)
