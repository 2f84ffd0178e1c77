"""The particle store's copies as Taichi kernels (geometry/particle_store.py): rows gathered into host
arrays with local ids, host rows written back, extra links replaced and compacted, per-body totals, and
the store's growth. They take ndarrays, so each compiles once for any capacity (per dtype and rank).
They run where the store's memory is not the host's (CUDA); on the CPU backend the store does the same
copies with numpy on views of that memory (geometry/store_host.py), and these kernels are its
reference in the tests. No `from __future__ import annotations` here: Taichi reads the kernels'
annotations as objects.
"""

import taichi as ti

from geometry.store_checks import Arr

Ref = ti.template()  # an ndarray handed on to a ti.func


@ti.kernel
def k_copy_rows_i32(k: ti.i32, src: Arr, dst: Arr):
    for j in range(k):
        dst[j] = src[j]


@ti.func
def _copy_fixed(d, d_verts: Ref, d_centroid: Ref, d_volume: Ref, d_mass: Ref, d_radius: Ref, d_kernel: Ref,
                d_material: Ref, d_kind: Ref, s, s_verts: Ref, s_centroid: Ref, s_volume: Ref, s_mass: Ref,
                s_radius: Ref, s_kernel: Ref, s_material: Ref, s_kind: Ref):
    """Row s of one set of fixed columns into row d of another (the parent is remapped apart)."""
    for a, b in ti.ndrange(4, 3):
        d_verts[d, a, b] = s_verts[s, a, b]
    for a, b in ti.static(ti.ndrange(3, 3)):
        d_kernel[d, a, b] = s_kernel[s, a, b]
    for a in ti.static(range(3)):
        d_centroid[d, a] = s_centroid[s, a]
    d_volume[d] = s_volume[s]
    d_mass[d] = s_mass[s]
    d_radius[d] = s_radius[s]
    d_material[d] = s_material[s]
    d_kind[d] = s_kind[s]


@ti.kernel
def k_gather(ids: Arr, particle_slot: Arr, particle_rest_verts: Arr, particle_centroid: Arr, particle_volume: Arr,
              particle_mass: Arr, particle_radius: Arr, particle_kernel: Arr, particle_material: Arr,
              particle_kind: Arr, particle_parent: Arr, particle_body: Arr, particle_alive: Arr,
              particle_links: Arr, verts: Arr, centroid: Arr, volume: Arr, mass: Arr, radius: Arr, kernel: Arr,
              material: Arr, kind: Arr, parent: Arr, body: Arr, alive: Arr, links: Arr, ne: ti.i32,
              link_extra: Arr, link_extra_alive: Arr, select_rows: Arr, counter: Arr) -> ti.i32:
    """Rows `ids` into host arrays; particle ids become local ones (slot - 1). A link or parent
    outside the gathered rows is kept as -2 - id, which reads as 'no link' to the host code and is
    decoded again by `put_body`. Then the live extra links with both ends gathered, unordered;
    returns how many."""
    for j in range(ids.shape[0]):
        particle_slot[ids[j]] = j + 1
    for j in range(ids.shape[0]):
        i = ids[j]
        _copy_fixed(j, verts, centroid, volume, mass, radius, kernel, material, kind, i, particle_rest_verts,
                    particle_centroid, particle_volume, particle_mass, particle_radius, particle_kernel,
                    particle_material, particle_kind)
        body[j] = particle_body[i]
        alive[j] = particle_alive[i]
        p = particle_parent[i]
        parent[j] = -1
        if p >= 0:
            parent[j] = particle_slot[p] - 1 if particle_slot[p] > 0 else -2 - p
        for a in ti.static(range(4)):
            t = particle_links[i, a]
            links[j, a] = -1
            if t >= 0:
                links[j, a] = particle_slot[t] - 1 if particle_slot[t] > 0 else -2 - t
    counter[0] = 0
    for e in range(ne):
        if link_extra_alive[e] != 0 and particle_slot[link_extra[e, 0]] > 0 and particle_slot[link_extra[e, 1]] > 0:
            select_rows[ti.atomic_add(counter[0], 1)] = e
    return counter[0]


@ti.kernel
def k_gather_extra(rows: Arr, ids: Arr, link_extra: Arr, particle_slot: Arr, pairs: Arr):
    """The extra links `rows` with local ids; then the marks of the gathered rows `ids` cleared."""
    for j in range(rows.shape[0]):
        for a in ti.static(range(2)):
            pairs[j, a] = particle_slot[link_extra[rows[j], a]] - 1
    for j in range(ids.shape[0]):
        particle_slot[ids[j]] = 0


@ti.kernel
def k_take_f64(ids: Arr, src: Arr, out: Arr):
    for j in range(ids.shape[0]):
        out[j] = src[ids[j]]


@ti.kernel
def k_put(ids: Arr, made: ti.i32, verts: Arr, centroid: Arr, volume: Arr, mass: Arr, radius: Arr, kernel: Arr,
           material: Arr, kind: Arr, parent: Arr, body: Arr, alive: Arr, links: Arr, particle_rest_verts: Arr,
           particle_centroid: Arr, particle_volume: Arr, particle_mass: Arr, particle_radius: Arr,
           particle_kernel: Arr, particle_material: Arr, particle_kind: Arr, particle_parent: Arr,
           particle_body: Arr, particle_alive: Arr, particle_links: Arr):
    """Host rows into store rows `ids`: the changing columns, and the fixed ones when `made` (new
    particles; the fixed data of an existing particle never changes)."""
    for j in range(ids.shape[0]):
        i = ids[j]
        particle_body[i] = body[j]
        particle_alive[i] = alive[j]
        for a in ti.static(range(4)):
            particle_links[i, a] = links[j, a]
        if made != 0:
            _copy_fixed(i, particle_rest_verts, particle_centroid, particle_volume, particle_mass, particle_radius,
                        particle_kernel, particle_material, particle_kind, j, verts, centroid, volume, mass, radius,
                        kernel, material, kind)
            particle_parent[i] = parent[j]


@ti.kernel
def k_replace_extra(kill: Arr, first: ti.i32, pairs: Arr, link_extra: Arr, link_extra_alive: Arr):
    """Extra links `kill` removed, `pairs` appended from row `first` on."""
    for j in range(kill.shape[0]):
        link_extra_alive[kill[j]] = 0
    for j in range(pairs.shape[0]):
        for a in ti.static(range(2)):
            link_extra[first + j, a] = pairs[j, a]
        link_extra_alive[first + j] = 1


@ti.kernel
def k_compact_extra(ne: ti.i32, link_extra: Arr, link_extra_alive: Arr) -> ti.i32:
    """Live extra links moved to the front, in order (one serial task); returns how many."""
    kept = 0
    ti.loop_config(serialize=True)
    for e in range(ne):
        if link_extra_alive[e] != 0:
            for a in ti.static(range(2)):
                link_extra[kept, a] = link_extra[e, a]
            link_extra_alive[e] = 0
            link_extra_alive[kept] = 1
            kept += 1
    return kept


@ti.kernel
def k_body_totals(n: ti.i32, particle_alive: Arr, particle_body: Arr, particle_mass: Arr, count: Arr, mass: Arr):
    """Alive particles and their mass (kg) per body, for bodies below count.shape[0]."""
    for i in range(n):
        b = particle_body[i]
        if particle_alive[i] != 0 and 0 <= b < count.shape[0]:
            ti.atomic_add(count[b], 1)
            ti.atomic_add(mass[b], particle_mass[i])


@ti.kernel
def k_copy_store(n: ti.i32, src: Arr, dst: Arr):
    """Rows 0..n-1 of one store array into a bigger one of the same rank and trailing shape."""
    for I in ti.grouped(src):
        if I[0] < n:
            dst[I] = src[I]
