"""The greedy grouping of surface particles into boundary spheres (Sect. 5.3), as one serial kernel.

geometry/boundary.py decides, per body, the visiting order (a Morton curve) and each particle's
nearest candidates; the grouping itself is sequential (a particle joins the first group that claims
it), so it runs here as a single serial Taichi loop instead of a Python loop over surface particles:
25-35 ms of every pot fracture event was that loop. Same rule, same groups (tests compare it with
the Python reference, `greedy_groups_reference`, which also runs while Taichi is not started:
geometry used on its own, as `main.py check` does, starts no Taichi). No `from __future__ import
annotations` here: Taichi reads the kernel's annotations as objects.
"""

import functools

import numpy as np

from core.runtime import taichi_started


@functools.cache
def _kernel():
    """The serial grouping kernel, defined at first use (importing geometry starts no Taichi)."""
    import taichi as ti

    @ti.kernel
    def k_greedy_groups(order: ti.types.ndarray(), near: ti.types.ndarray(), ok: ti.types.ndarray(),
                        weight: ti.types.ndarray(), group_size: ti.i32, first_id: ti.i32, gid: ti.types.ndarray(),
                        taken: ti.types.ndarray(), next_id: ti.types.ndarray()):
        for _ in range(1):  # one serial task: the grouping is order dependent
            nid = first_id
            for t in range(order.shape[0]):
                s = order[t]
                if taken[s] == 0:
                    count = 1
                    area = weight[s]
                    for j in range(near.shape[1]):  # how many free candidates it takes
                        c = near[s, j]
                        if area < group_size and ok[s, j] != 0 and taken[c] == 0 and c != s:
                            count += 1
                            area += weight[c]
                    taken[s] = 1
                    gid[s] = nid
                    if count >= group_size:  # a group
                        area = weight[s]
                        for j in range(near.shape[1]):
                            c = near[s, j]
                            if area < group_size and ok[s, j] != 0 and taken[c] == 0 and c != s:
                                taken[c] = 1
                                gid[c] = nid
                                area += weight[c]
                    elif weight[s] < 1.0:  # a child left over: it joins its nearest grouped child's group
                        for j in range(near.shape[1]):
                            c = near[s, j]
                            if gid[s] == nid and ok[s, j] != 0 and taken[c] != 0 and c != s and weight[c] < 1.0:
                                gid[s] = gid[c]
                    if gid[s] == nid:  # a new group, or a particle on its own
                        nid += 1
            next_id[0] = nid

    return k_greedy_groups


def greedy_groups(order: np.ndarray, near: np.ndarray, ok: np.ndarray, group_size: int,
                  first_id: int, weight: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Group ids (n,) int64 of n surface particles visited in `order` (n,), each taking free
    candidates among `near` (n,k) local indices where `ok` (n,k) bool, nearest first, until the
    group's area `weight` (n,) (1 for an unsubdivided particle: geometry.boundary.area_weights) reaches
    `group_size`; when that took fewer than `group_size` particles, a child (weight < 1) joins the group
    of its nearest grouped child candidate and any other particle stays alone. Ids count up from
    `first_id`. Returns (ids, next free id)."""
    weight = np.ones(len(near)) if weight is None else np.asarray(weight, np.float64)
    if not taichi_started():  # geometry used on its own (`main.py check`): the same rule in Python
        return greedy_groups_reference(order, near, ok, group_size, first_id, weight)
    n = len(order)
    gid = np.full(n, -1, np.int32)
    taken = np.zeros(n, np.int32)
    nxt = np.zeros(1, np.int32)
    _kernel()(np.ascontiguousarray(order, np.int32), np.ascontiguousarray(near, np.int32),
              np.ascontiguousarray(ok, np.int32), np.ascontiguousarray(weight, np.float64), int(group_size),
              int(first_id), gid, taken, nxt)
    return gid.astype(np.int64), int(nxt[0])


def warm_up() -> None:
    """Launch the grouping kernel on nothing: it compiles, for sim/warm_up.py, before an event needs it
    (a run's build reads its objects' groups from the disk cache)."""
    nothing = np.zeros((0, 1), np.int64)
    greedy_groups(nothing[:, 0], nothing, nothing.astype(bool), 1, 0)


def greedy_groups_reference(order, near, ok, group_size: int, first_id: int,
                            weight=None) -> tuple[np.ndarray, int]:
    """The same rule as a Python loop: the specification the kernel is tested against, and what
    runs while Taichi has not been started (geometry alone starts no Taichi)."""
    weight = [1.0] * len(near) if weight is None else np.asarray(weight, np.float64).tolist()
    near, ok = np.asarray(near).tolist(), np.asarray(ok).tolist()
    taken = [False] * len(near)
    gid = np.full(len(near), -1, np.int64)
    nid = first_id
    for s in np.asarray(order).tolist():
        if taken[s]:
            continue
        members = [s]
        area = weight[s]
        for j, good in zip(near[s], ok[s]):
            if area >= group_size:
                break
            if good and not taken[j] and j != s:
                members.append(j)
                area += weight[j]
        if len(members) < group_size:
            members = [s]
            if weight[s] < 1.0:  # a child left over joins its nearest grouped child's group
                near_child = [j for j, good in zip(near[s], ok[s]) if good and taken[j] and j != s and weight[j] < 1.0]
                if near_child:
                    taken[s] = True
                    gid[s] = gid[near_child[0]]
                    continue
        for m in members:
            taken[m] = True
            gid[m] = nid
        nid += 1
    return gid, nid


__all__ = ["greedy_groups", "greedy_groups_reference"]
