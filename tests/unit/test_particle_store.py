"""The particle store (geometry/particle_store.py): Taichi ndarrays that a fracture event works on in
place. A round trip is exact; a body taken, cut by the host geometry code and put back gives, bit for
bit, what cutting the whole-world arrays gives (the store's ids for the children included); the store
grows without losing a row; its device checks agree with numpy. Each test runs with the copies made by
numpy on views of the ndarrays (the CPU backend's way, geometry/store_host.py) and by the kernels
(geometry/store_kernels.py, CUDA's), and the two give the same bits.
"""

from __future__ import annotations

import numpy as np
import pytest

from geometry.cutting import Crack
from geometry.fragments import apply_cracks
from geometry.particles import concat_particles, transform_particles
from rigid.bodies import box_tetmesh

pytestmark = pytest.mark.usefixtures("taichi_runtime")


def _two_blocks():
    """Two 6 x 3 x 2-cell blocks (bodies 0 and 1, 216 tets each) side by side; kernel tensors."""
    from geometry.particles import build_particles

    block = build_particles(box_tetmesh((0.06, 0.03, 0.02), (6, 3, 2)), 2500.0)
    other = transform_particles(block, np.eye(3), np.array([0.2, 0.0, 0.0]))
    other.body[:] = 1
    ps = concat_particles([block, other])
    G = np.einsum("n,ij->nij", 1.0 / (2.0 * ps.radius), np.eye(3))  # (N, 3, 3) 1/m
    return ps, G


@pytest.fixture(params=[True, False], ids=["numpy", "kernels"])
def on_host(request) -> bool:
    """ParticleStore's on_host: its copies by numpy on views of the ndarrays, or by its kernels."""
    return request.param


def _same(a, b, extra_as_sets: bool = False):
    for name in ("rest_verts", "volume", "mass", "centroid", "radius", "material", "body", "links", "kind", "parent",
                 "alive"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and np.array_equal(x, y), name
    ea, eb = np.sort(a.extra_links, axis=1), np.sort(b.extra_links, axis=1)
    if extra_as_sets:
        ea, eb = np.unique(ea, axis=0), np.unique(eb, axis=0)
    assert np.array_equal(ea, eb)


def test_a_round_trip_is_exact(on_host):
    from geometry.particle_store import ParticleStore

    ps, G = _two_blocks()
    store = ParticleStore(ps, G, on_host=on_host)
    host, G2 = store.host()
    _same(ps, host)
    assert np.array_equal(G, G2) and not host.volume.flags.writeable  # an output copy, read-only
    # the copy kept from the upload (no download at a start) is what the device holds, and not the
    # caller's arrays: theirs stay writable and changing them changes no copy
    ids, every, G_all, _ = store.take_bodies([0, 1])
    assert np.array_equal(ids, np.arange(len(ps)))
    _same(every, host)
    assert np.array_equal(G_all, G2) and ps.volume.flags.writeable
    ps.volume[0] *= 2.0
    assert host.volume[0] == every.volume[0]
    ps.volume[0] /= 2.0
    ids, part, G_part, _ = store.take_bodies([1])
    assert np.array_equal(ids, np.flatnonzero(ps.body == 1))
    # local ids: the body's links stay inside it (a block's tets link only to its own)
    assert part.links.max() < len(part) and np.array_equal(part.links >= 0, ps.links[ids] >= 0)
    store.put_body(ids, part, G_part, np.zeros(0, np.int64))
    _same(ps, store.host()[0])
    # a body whose links lead out of it (half a block relabelled): they travel as -2 - id, read as
    # 'no link' by the host code, and come back as they were
    half = (ps.body == 0) & (ps.centroid[:, 0] < 0.0)
    ps.body[half] = 2
    store.reset(ps, G)
    ids, part, G_part, rows = store.take_bodies([2])
    out = part.links <= -2
    assert out.any() and np.array_equal(-2 - part.links[out], ps.links[ids][out])
    assert not half[-2 - part.links[out]].any()  # they lead to the other half
    store.put_body(ids, part, G_part, rows)
    _same(ps, store.host()[0])


@pytest.mark.parametrize("mode", ["basic", "subdivision"])
def test_a_cut_on_the_taken_body_equals_the_cut_on_the_whole_world(mode, on_host, monkeypatch):
    """Cut body 1 with two cracks (subdivision appends children, shattering frees particles), once on
    the whole-world arrays and once through take_bodies / put_body on a store too small for the
    children (it grows on the way): the same particles, links, parents and extra links."""
    import geometry.particle_store as store_module

    ps, G = _two_blocks()
    cracks = [Crack(point=[0.2, 0.0, 0.0], normal=[1.0, 0.2, 0.0], r_outer=0.1, r_inner=0.015),
              Crack(point=[0.21, 0.0, 0.0], normal=[0.0, 1.0, 0.3], r_outer=0.05)]
    whole, rep = apply_cracks(ps, cracks, mode=mode, shatter=True, bodies=[1])
    monkeypatch.setattr(store_module, "HEADROOM", 1)
    store = store_module.ParticleStore(ps, G, on_host=on_host)
    ids, part, G_part, rows = store.take_bodies([1])
    cut, rep_part = apply_cracks(part, cracks, mode=mode, shatter=True, bodies=[1])
    n_new = len(cut) - len(part)
    G_cut = np.concatenate([G_part, G_part[cut.parent[len(part):]]])
    assert (n_new > 0) == (mode == "subdivision") and len(rep_part.debris) == len(rep.debris) > 0
    store.put_body(ids, cut, G_cut, rows)
    assert store.count == len(whole) and (mode == "basic" or store.capacity > len(ps))  # grown
    host, G_host = store.host()
    _same(whole, host, extra_as_sets=True)
    # host() downloads with the event's gather over every row: the same as Taichi's own copy of the arrays
    n = store.count
    for name in ("rest_verts", "centroid", "parent", "links", "body", "alive"):
        column = getattr(store, "particle_" + name).to_numpy()[:n]
        assert np.array_equal(column.astype(getattr(host, name).dtype), getattr(host, name)), name
    live = store.link_extra_alive.to_numpy()[: store.extra_count] != 0
    assert np.array_equal(store.link_extra.to_numpy()[: store.extra_count][live], host.extra_links)
    assert np.array_equal(G_host[len(ps):], G[whole.parent[len(ps):]])  # children: their parent's tensor


def test_device_checks_agree_with_numpy(on_host):
    from geometry.particle_store import ParticleStore

    ps, G = _two_blocks()
    ps.alive[5] = False
    store = ParticleStore(ps, G, on_host=on_host)
    alive = ps.alive
    for device in (False, True):  # the build's host copy, then the kernel over the store
        count, mass = store.body_totals(3, device=device)
        assert count.tolist() == np.bincount(ps.body[alive], minlength=3).tolist()
        np.testing.assert_allclose(mass, np.bincount(ps.body[alive], weights=ps.mass[alive], minlength=3),
                                   rtol=1e-12)
    assert set(store.first_invalid().values()) == {-1} and set(store.first_invalid(device=True).values()) == {-1}
    store.particle_volume[5] = -1.0  # a dead particle is not checked
    store.particle_mass[9] = np.nan
    store.particle_kernel[12, 1, 1] = -1.0
    assert store.first_invalid(device=True) == dict(particle_centroid=-1, particle_rest_verts=-1, particle_volume=-1,
                                                    particle_mass=9, kernel_G=12)


@pytest.mark.parametrize("bad", ["centroid", "rest_verts", "volume", "mass", "kernel"])
def test_the_host_check_of_a_built_store_answers_as_the_kernel(bad, on_host):
    """A store that nothing changed since its build checks the build's host copy (numpy); it names the
    same particles as the kernel over the store does."""
    from geometry.particle_store import ParticleStore

    ps, G = _two_blocks()
    ps.alive[5] = False
    rows = {"centroid": ps.centroid, "rest_verts": ps.rest_verts, "volume": ps.volume, "mass": ps.mass, "kernel": G}
    rows[bad][5] = np.nan  # dead: not checked
    rows[bad][17] = -np.inf if bad != "kernel" else 0.0
    rows[bad][40] = 0.0 if bad in ("volume", "mass") else np.nan
    if bad == "kernel":
        G[23] = -np.eye(3)  # finite, not positive definite
    store = ParticleStore(ps, G, on_host=on_host)
    assert store.kept_host() is not None
    assert store.first_invalid() == store.first_invalid(device=True)
    assert list(store.first_invalid().values()).count(17) == 1
    np.testing.assert_array_equal(store.take_mass(np.array([3, 0, 400])), ps.mass[[3, 0, 400]])


def test_after_valid_check_only_the_rows_events_wrote_are_checked(on_host, monkeypatch):
    """Once the store was found valid, the next check looks at the rows `put_body` wrote since (the
    others are as they were) and names a bad row among them as the whole-store kernel does; a change
    made any other way (the version bumped by hand) sends the check over the whole store again."""
    from geometry.particle_store import ParticleStore

    ps, G = _two_blocks()
    store = ParticleStore(ps, G, on_host=on_host)
    ids, part, G_part, rows = store.take_bodies([1])
    store.put_body(ids, part, G_part, rows)  # the build's host copy is gone: the store's own check runs
    passes = []  # per check of the store's rows: how many it looked at, -1 for every row
    check = store._first_invalid_rows
    monkeypatch.setattr(store, "_first_invalid_rows", lambda rows: (
        passes.append(-1 if rows is None else len(rows)), check(rows))[1])
    assert set(store.first_invalid().values()) == {-1} and passes == [-1]  # not known valid yet: every row
    assert set(store.first_invalid().values()) == {-1} and passes == [-1, 0]  # nothing written since: no row
    ids, part, G_part, rows = store.take_bodies([0])
    crack = Crack(point=[0.0, 0.0, 0.0], normal=[1.0, 0.2, 0.0], r_outer=0.1)
    cut, _ = apply_cracks(part, [crack], mode="subdivision", shatter=False, bodies=[0])
    child = len(part) + 3
    cut.mass[child] = -1.0  # a bad child written by the event
    global_id = store.put_body(ids, cut, np.concatenate([G_part, G_part[cut.parent[len(part):]]]), rows)
    found = store.first_invalid()
    assert passes[-1] == len(np.unique(global_id)) < store.count  # only the rows this event wrote
    assert found["particle_mass"] == int(global_id[child]) and found == store.first_invalid(device=True)
    store.particle_mass[int(global_id[child])] = 1.0  # mended by hand, as the guard test writes: version bumped
    store.version += 1
    assert set(store.first_invalid().values()) == {-1} and passes[-1] == -1
