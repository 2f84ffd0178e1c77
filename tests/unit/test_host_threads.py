"""Host threads (core/host_threads.py): results in the items' order, nested maps run in line, and
the analysis' neighbour search and Eq. 7 give the same bits on the threads as in one thread."""

from __future__ import annotations

import threading
import time

import numpy as np

import core.host_threads as host_threads
import sph.gradient as gradient
from core.host_threads import host_cores, ordered_map
from geometry.build import build_object
from sph.kernel import kernel_isotropic


def test_results_come_in_the_items_order():
    def slow_square(k: int) -> int:
        time.sleep(0.002 * (7 - k % 7))  # later items finish first
        return k * k

    assert host_cores() >= 1
    assert ordered_map(slow_square, range(20)) == [k * k for k in range(20)]


def test_a_forked_child_gets_its_own_pool(monkeypatch):
    """The pool is per process: a child forked after the parent made its threads has none of them."""
    mine = host_threads._pool()
    monkeypatch.setattr(host_threads.os, "getpid", lambda: -12345)
    child = host_threads._pool()
    assert (child is None) == (mine is None) and (child is None or child is not mine)
    assert ordered_map(lambda k: 2 * k, range(5)) == [0, 2, 4, 6, 8]


def test_a_map_inside_a_pool_thread_runs_in_line():
    """A map called from one of the pool's threads must not wait for the (busy) pool itself."""
    def outer(k: int) -> list:
        return ordered_map(lambda j: (k, j, threading.current_thread().name), range(3))

    done = []
    runner = threading.Thread(target=lambda: done.append(ordered_map(outer, range(2 * host_cores()))))
    runner.start()
    runner.join(timeout=30.0)
    assert done, "nested ordered_map did not finish"
    for k, inner in enumerate(done[0]):
        assert [j for _, j, _ in inner] == [0, 1, 2] and all(kk == k for kk, _, _ in inner)
        assert len({name for _, _, name in inner}) == 1  # in line, in the outer item's thread


def test_analysis_on_threads_gives_the_same_bits(monkeypatch):
    """neighbour_pairs (radius bins) and sph_gradient (blocks) on the pool against the same calls with
    every item in the caller's thread; a stretched kernel and two particle sizes give several bins."""
    obj = build_object("box", shape_params=dict(size=[0.06, 0.06, 0.03]), resolution=0.005)
    x, V = obj.particles.centroid, obj.particles.volume
    scale = np.where(np.arange(len(x)) % 3 == 0, 1.3, 1.0)[:, None, None]  # mixed support radii
    G = kernel_isotropic(2.5 * 0.005) * np.diag([1.0, 0.5, 1.0]) / scale
    u = np.sin(40.0 * x) * 1e-6  # m: a smooth non-linear displacement
    mem = np.arange(len(x))
    monkeypatch.setattr(gradient, "kernels_run", lambda: False)  # the numpy path, the one on threads
    monkeypatch.setattr(gradient, "PAD_SLOTS", 4000)  # many blocks and chunks
    threaded = gradient.neighbour_pairs(x, G, mem, mem)
    grads = [gradient.sph_gradient(x, V, G, u, mem, *threaded, order) for order in (0, 1, 2)]
    monkeypatch.setattr(host_threads, "_pool", lambda: None)  # everything in this thread
    inline = gradient.neighbour_pairs(x, G, mem, mem)
    assert all(np.array_equal(a, b) and a.dtype == b.dtype for a, b in zip(threaded, inline))
    assert len(threaded[0]) > 10 * len(mem)
    for order, (g, used) in zip((0, 1, 2), grads):
        g1, used1 = gradient.sph_gradient(x, V, G, u, mem, *inline, order)
        assert np.array_equal(g, g1) and np.array_equal(used, used1)
