"""The rigid store's fields as numpy views on the CPU (rigid/host_views.py): a view and the kernels read
and write the same memory, and a world whose host copies go through the views steps to the same bits
as one whose copies go through the transfer kernels (rigid/transfers.py, CUDA's way): uploads, state
downloads and writes, wake-ups, contacts, the warm-start contacts kept across a removal."""

from __future__ import annotations

import numpy as np
import pytest

from rigid.bodies import add_box_body

pytestmark = pytest.mark.usefixtures("taichi_runtime")
DT = 1.0 / 240.0


def test_views_and_kernels_share_the_fields(fresh):
    from rigid import transfers
    from rigid.host_views import ROWS, SCALARS

    w = fresh
    hv = w._views()
    assert hv is not None and set(hv) == set(ROWS) | set(SCALARS)
    for name in ROWS:  # every row of the store, each element's shape
        field = getattr(w._s, name)
        assert hv[name].shape[0] == field.shape[0], name
    a = add_box_body(w, [0.1, 0.2, 0.3], 1000.0, x=(0.5, 2.0, -1.0))
    hv["body_v"][a] = (1.0, -2.0, 3.0)  # a view's write, read by a kernel
    n = w.n_bodies
    x, q, v, om = (np.zeros((n, k), hv["body_x"].dtype) for k in (3, 4, 3, 3))
    i1, f1 = np.zeros(n, np.int32), np.zeros(n, hv["body_x"].dtype)
    transfers.k_download_bodies(w._s, n, x, q, v, om, i1, f1, i1.copy())
    assert v[a].tolist() == [1.0, -2.0, 3.0] and x[a].tolist() == [0.5, 2.0, -1.0]
    inertia = w._s.body_inv_inertia[a].to_numpy()  # a kernel's (the upload's) write, read by the view
    np.testing.assert_array_equal(hv["body_inv_inertia"][a], inertia)
    assert inertia[0, 0] != inertia[1, 1]  # a box of three sizes: the matrix's layout is tested
    w.write_scalar("pc_valid", 1)
    assert w._s.pc_valid[None] == 1 and w.read_scalar("pc_valid") == 1


def _run(world, monkeypatch, views: bool) -> list:
    """A pile of boxes dropped on a plane, one removed half way, one woken: each frame's state and contacts."""
    import rigid.host_sync

    if not views:
        monkeypatch.setattr(rigid.host_sync, "store_views", lambda s: None)
    world._views_cache = None
    world.clear()
    world.add_plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.2)
    ids = [add_box_body(world, [0.1, 0.05, 0.08], 900.0, x=(0.03 * k, 0.1 + 0.12 * k, 0.0)) for k in range(4)]
    out = []
    for step in range(140):
        world.step(DT)
        if step == 100:  # every contact carries impulse: the warm-start contacts are renumbered
            world.remove_bodies([ids[0]])
        if step == 110:
            world.set_body_state(ids[0], v=(0.0, 1.0, 0.0))
            world.wake([ids[2]])
        st, ev = world.body_state(), world.contact_events()
        out.append((st.x.copy(), st.q.copy(), st.v.copy(), st.w.copy(), st.asleep.copy(), st.alive.copy(),
                    ev.body_a, ev.point, ev.normal_impulse, world._download_prev()[1]))
    monkeypatch.undo()
    world._views_cache = None
    return out


def test_views_step_to_the_kernels_bits(world, monkeypatch):
    by_views, by_kernels = _run(world, monkeypatch, True), _run(world, monkeypatch, False)
    assert any(len(frame[6]) for frame in by_views)  # contacts were made
    for f, (a, b) in enumerate(zip(by_views, by_kernels)):
        for k, (x, y) in enumerate(zip(a, b)):
            assert x.dtype == y.dtype and np.array_equal(x, y), (f, k)
