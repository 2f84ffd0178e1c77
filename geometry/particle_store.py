"""The tet particles of a World in Taichi ndarrays (Sect. 5.1, 5.2): one store, worked on in place.

One store holds the physical particles and the children adaptive subdivision makes (a kind flag, an
alive flag, parent ids), their rest kernel tensors (Eq. 5) and the extra links of Fig. 5; fixed data
(written once, when a particle is made) apart from changing data (body, alive, links). A particle's
id is its row; children are appended, ids are never reused.

A fracture event works on the store in place and touches only its body (issue 17, item 4):
`take_body` gathers the struck body's particles, and the physical parents its children came from
(Algorithm 1 analyses them, sim/fracture_stage.py), into a body-sized host `ParticleSet` with local
indices; the host geometry code (geometry.fragments) cuts that; `put_body` writes back what changed
and appends the children. Gathering and scattering are kernels, and which rows a body holds is an
index kept on the host where the store writes them (geometry/body_rows.py: no pass over the whole
store), so no whole-store array crosses to the host during an event: `transfers` records every copy
to or from the host with its row count (a test counts an event's). `host()` is the whole store as a
read-only `ParticleSet` for outputs (statistics, exports, the viewer), downloaded only when the store
changed since the last.

Ndarrays rather than fields: a kernel taking ndarrays compiles once for every capacity, so the store
grows (doubling, copied on the device) without compiling anything, while a field passed as a
template compiles its kernels per store (rigid/store.py pools its stores for that reason). Geometry
stays float64 whatever the simulation precision: cuts, subdivision and mass properties run on it in
float64 on the host, and a round trip is exact (a fracture event gives the same bits as before the
store existed: tested with the scenes' state hashes). No `from __future__ import annotations` here:
Taichi reads the kernels' annotations as objects.
"""

import functools

import numpy as np
import taichi as ti

from geometry.body_rows import BodyRows
from geometry.particles import ParticleSet
from geometry.store_checks import Arr, host_first_invalid, k_first_invalid

GEOMETRY_DTYPE = ti.f64  # rest geometry and kernel tensors: float64, as the host geometry code
MIN_CAPACITY = 64  # rows: the smallest store
# rows per particle built: subdivision's children at the end of the paper scenes' runs make 2.2 (pot)
# to 2.7 (glass_r3) rows per physical particle, so the store starts with room for that; Pots' grains
# outgrow it (4.0 rows), and growing doubles it with a device copy whose kernels warm_pieces compiles
HEADROOM = 4

Ref = ti.template()  # an ndarray handed on to a ti.func


# ----------------------------------------------------------------------------------------- kernels
@ti.kernel
def _k_copy_rows_i32(k: ti.i32, src: Arr, dst: Arr):
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
def _k_gather(ids: Arr, particle_slot: Arr, particle_rest_verts: Arr, particle_centroid: Arr, particle_volume: Arr,
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
def _k_gather_extra(rows: Arr, ids: Arr, link_extra: Arr, particle_slot: Arr, pairs: Arr):
    """The extra links `rows` with local ids; then the marks of the gathered rows `ids` cleared."""
    for j in range(rows.shape[0]):
        for a in ti.static(range(2)):
            pairs[j, a] = particle_slot[link_extra[rows[j], a]] - 1
    for j in range(ids.shape[0]):
        particle_slot[ids[j]] = 0


@ti.kernel
def _k_take_f64(ids: Arr, src: Arr, out: Arr):
    for j in range(ids.shape[0]):
        out[j] = src[ids[j]]


@ti.kernel
def _k_put(ids: Arr, made: ti.i32, verts: Arr, centroid: Arr, volume: Arr, mass: Arr, radius: Arr, kernel: Arr,
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
def _k_replace_extra(kill: Arr, first: ti.i32, pairs: Arr, link_extra: Arr, link_extra_alive: Arr):
    """Extra links `kill` removed, `pairs` appended from row `first` on."""
    for j in range(kill.shape[0]):
        link_extra_alive[kill[j]] = 0
    for j in range(pairs.shape[0]):
        for a in ti.static(range(2)):
            link_extra[first + j, a] = pairs[j, a]
        link_extra_alive[first + j] = 1


@ti.kernel
def _k_compact_extra(ne: ti.i32, link_extra: Arr, link_extra_alive: Arr) -> ti.i32:
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
def _k_body_totals(n: ti.i32, particle_alive: Arr, particle_body: Arr, particle_mass: Arr, count: Arr, mass: Arr):
    """Alive particles and their mass (kg) per body, for bodies below count.shape[0]."""
    for i in range(n):
        b = particle_body[i]
        if particle_alive[i] != 0 and 0 <= b < count.shape[0]:
            ti.atomic_add(count[b], 1)
            ti.atomic_add(mass[b], particle_mass[i])


@ti.kernel
def _k_copy_store(n: ti.i32, src: Arr, dst: Arr):
    """Rows 0..n-1 of one store array into a bigger one of the same rank and trailing shape."""
    for I in ti.grouped(src):
        if I[0] < n:
            dst[I] = src[I]


# ------------------------------------------------------------------------------------------- store
# store array -> (trailing shape, Taichi dtype, host dtype); the first five are fixed data
_FIXED = {
    "particle_rest_verts": ((4, 3), GEOMETRY_DTYPE, np.float64),  # (C, 4, 3) m: tet vertices, reference frame
    "particle_centroid": ((3,), GEOMETRY_DTYPE, np.float64),  # (C, 3) m: rest centroid
    "particle_volume": ((), GEOMETRY_DTYPE, np.float64),  # (C,) m^3: tet volume
    "particle_mass": ((), GEOMETRY_DTYPE, np.float64),  # (C,) kg
    "particle_radius": ((), GEOMETRY_DTYPE, np.float64),  # (C,) m: (3V / 4 pi)^(1/3)
    "particle_kernel": ((3, 3), GEOMETRY_DTYPE, np.float64),  # (C, 3, 3) 1/m: rest kernel tensor G0 (Eq. 5)
    "particle_material": ((), ti.i32, np.int32),  # (C,) -: material id
    "particle_kind": ((), ti.i32, np.int8),  # (C,) -: KIND_PHYSICAL or KIND_SUBDIVIDED
    "particle_parent": ((), ti.i32, np.int64),  # (C,) -: parent of a subdivided child, or -1
}
_CHANGING = {
    "particle_body": ((), ti.i32, np.int32),  # (C,) -: rigid body, -1 once freed (debris)
    "particle_alive": ((), ti.i32, bool),  # (C,) flag: 0 once replaced by its children or removed
    "particle_links": ((4,), ti.i32, np.int64),  # (C, 4) -: particle across tet face k, or -1
}
_HOST_NAME = {"particle_rest_verts": "rest_verts"}  # ParticleSet attribute; else the name minus 'particle_'


class ParticleStore:
    """Tet particles in Taichi ndarrays (see the module docstring); `count` rows are in use."""

    def __init__(self, particles: ParticleSet, kernel_G: np.ndarray | None, capacity: int = 0) -> None:
        self.transfers: list[tuple[str, int]] = []  # (what, rows) of every copy to or from the host
        self.version = 0  # bumped by every change; host() downloads again when it moved
        self.body_stamp: dict[int, int] = {}  # body -> version of its last change (surface caches)
        self.count = 0  # rows in use (particles ever made)
        self.extra_count = 0  # rows of link_extra in use, dead ones included until compacted
        self._host = None  # (version, ParticleSet, kernel tensors) of the last download
        self._valid = None  # (version found valid, the rows put_body wrote since: one array a put), or None
        self._body_rows = BodyRows()  # the rows take_bodies gathers per body (geometry/body_rows.py)
        self._allocate(max(MIN_CAPACITY, int(capacity), HEADROOM * len(particles)),
                       max(MIN_CAPACITY, len(particles), 4 * len(particles.extra_links)))
        self.reset(particles, kernel_G)

    # ---- allocation -----------------------------------------------------------------------------
    def _allocate(self, capacity: int, extra_capacity: int) -> None:
        self.capacity = int(capacity)
        self.extra_capacity = int(extra_capacity)
        for name, (shape, dtype, _) in {**_FIXED, **_CHANGING}.items():
            setattr(self, name, ti.ndarray(dtype, (self.capacity, *shape)))
        self.particle_slot = ti.ndarray(ti.i32, (self.capacity,))  # (C,) -: local index + 1 in the event, else 0
        self.link_extra = ti.ndarray(ti.i32, (self.extra_capacity, 2))  # (CE, 2) -: particles of an extra link
        self.link_extra_alive = ti.ndarray(ti.i32, (self.extra_capacity,))  # (CE,) flag: 0 once removed
        self.select_rows = ti.ndarray(ti.i32, (self.extra_capacity,))  # (CE,) -: scratch of a selection
        self.counter = ti.ndarray(ti.i32, (1,))  # () -: selection counter

    def _grow(self, rows: int, extra_rows: int) -> None:
        """Room for `rows` particles and `extra_rows` extra links: double and copy on the device (no
        kernel compiles: ndarray kernels are compiled per dtype and rank, not per size)."""
        if rows <= self.capacity and extra_rows <= self.extra_capacity:
            return
        old = {name: getattr(self, name) for name in (*_FIXED, *_CHANGING, "link_extra", "link_extra_alive")}
        n, ne = self.count, self.extra_count
        cap, ecap = self.capacity, self.extra_capacity
        while cap < rows:
            cap *= 2
        while ecap < extra_rows:
            ecap *= 2
        self._allocate(cap, ecap)
        for name, src in old.items():
            rows_in_use = ne if name.startswith("link_extra") else n
            _k_copy_store(rows_in_use, src, getattr(self, name))

    def reset(self, particles: ParticleSet, kernel_G: np.ndarray | None) -> None:
        """Replace the whole content (input: a World's build, the viewer's added ball). Without
        kernel tensors (a scene with neither fracture nor elastic effect) the column holds zeros."""
        n = len(particles)
        self.has_kernels = kernel_G is not None
        if kernel_G is None:
            kernel_G = np.zeros((n, 3, 3))
        self._grow(n, len(particles.extra_links))
        self.count, self.extra_count = 0, 0
        host = _host_columns(particles, kernel_G)
        ids = np.arange(n, dtype=np.int32)
        self._put_rows(ids, host, made=True)
        self._body_rows.reset(particles.body, particles.alive, particles.kind, particles.parent)
        self.count = n
        self._append_extra(particles.extra_links)
        self._valid = None  # a new content: its first check passes over all of it
        self._changed(np.unique(particles.body[particles.body >= 0]))
        self.transfers.append(("reset", n))
        # what host() would download now is what was just uploaded: kept, so a start compiles no
        # download kernel (six of Taichi's to_numpy kernels, 0.1 s before the first frame); copies,
        # so that the caller's arrays stay its own and writable
        cols = {name: col.copy() for name, col in host.items()}
        self._keep_host(_particle_set(cols, particles.extra_links.copy()), cols["particle_kernel"])

    def release(self) -> None:
        for name in (*_FIXED, *_CHANGING, "particle_slot", "link_extra", "link_extra_alive",
                     "select_rows", "counter"):
            setattr(self, name, None)  # the last host() copy stays readable

    # ---- a fracture event ------------------------------------------------------------------------
    def take_bodies(self, bodies) -> tuple[np.ndarray, ParticleSet, np.ndarray, np.ndarray]:
        """The alive particles of `bodies` and the parents of their children, gathered: (store ids (K,)
        ascending, a local ParticleSet of K rows, their kernel tensors (K, 3, 3) 1/m, the store rows
        of their extra links). `put_body` writes a changed copy of one body back."""
        ids = self._body_rows.rows(bodies)  # ascending: the order of the whole-world arrays (geometry/body_rows.py)
        ps, kernel_G, rows = self._take(ids)
        self.transfers.append(("take_bodies", len(ids)))
        return ids.astype(np.int64), ps, kernel_G, rows

    def _take(self, ids: np.ndarray) -> tuple[ParticleSet, np.ndarray, np.ndarray]:
        """Rows `ids` (ascending) as a local ParticleSet, their kernel tensors and the store rows of the
        extra links among them (ascending)."""
        cols, ne = self._gather(ids)
        rows = np.empty(ne, dtype=np.int32)
        _k_copy_rows_i32(ne, self.select_rows, rows)
        rows.sort()
        pairs = np.empty((ne, 2), dtype=np.int32)
        _k_gather_extra(rows, ids, self.link_extra, self.particle_slot, pairs)
        return _particle_set(cols, pairs), cols["particle_kernel"], rows

    def _gather(self, ids: np.ndarray) -> tuple[dict, int]:
        """take_bodies' gather: the rows' columns (local ids) and how many extra links they hold."""
        cols = {name: np.empty((len(ids), *shape), dtype=_kernel_dtype(host))
                for name, (shape, _, host) in {**_FIXED, **_CHANGING}.items()}
        ne = _k_gather(ids, self.particle_slot, *self._columns(), *cols.values(), self.extra_count, self.link_extra,
                       self.link_extra_alive, self.select_rows, self.counter)
        return cols, ne

    def put_body(self, ids: np.ndarray, ps: ParticleSet, kernel_G: np.ndarray, extra_rows: np.ndarray) -> np.ndarray:
        """Write back an event's local ParticleSet: rows 0..len(ids)-1 are the gathered particles
        (changed body, alive and links), the rest are new children appended to the store with their
        kernel tensors. Returns the global id of every local row."""
        k, n_new = len(ids), len(ps) - len(ids)
        self._grow(self.count + n_new, self.extra_count + len(ps.extra_links))
        global_id = self.global_ids(ids, len(ps))
        host = _host_columns(ps, kernel_G)
        for name in ("particle_links", "particle_parent"):
            host[name] = _to_global(host[name], global_id)
        self._put_rows(global_id[k:].astype(np.int32), {n: c[k:] for n, c in host.items()}, made=True)
        self._put_rows(np.asarray(ids, np.int32), {n: c[:k] for n, c in host.items()}, made=False)
        self._body_rows.write(global_id, ps.body, ps.alive, ps.kind, host["particle_parent"])
        self.count += n_new
        pairs = global_id[ps.extra_links] if len(ps.extra_links) else ps.extra_links
        self._append_extra(pairs, kill=extra_rows)
        self.transfers.append(("put_body", len(ps)))
        self._changed(np.unique(ps.body[ps.alive & (ps.body >= 0)]))
        if self._valid is not None:
            self._valid[1].append(global_id)
        return global_id

    def warm_pieces(self) -> list:
        """Launchers of every kernel of an event and a frame after it, growth and compaction included (Pots'
        grains outgrow HEADROOM: compiling the copy stalled a frame 190 ms), each on nothing and changing
        nothing (the host copy and `transfers` stay): sim/warm_up.py runs them (issue 16)."""
        columns = {(a.dtype, len(a.shape)): a for a in self._columns() + [self.link_extra]}.values()
        nothing = np.zeros(0, np.int32)
        launches = [lambda: self._gather(nothing),  # the event's largest kernels first
                    lambda: self.put_body(*self.take_bodies([])), lambda: self.take_mass(np.zeros(0, np.int64)),
                    lambda: self.first_invalid(device=True), lambda: self.body_totals(1, device=True),
                    *(functools.partial(_k_copy_store, 0, c, c) for c in columns),  # one per dtype and rank
                    lambda: _k_compact_extra(0, self.link_extra, self.link_extra_alive)]
        return [functools.partial(self._unchanged, f) for f in launches]

    def _unchanged(self, launch) -> None:
        version, host, logged = self.version, self._host, len(self.transfers)
        valid = None if self._valid is None else (self._valid[0], list(self._valid[1]))
        launch()
        self.version, self._host, self.transfers[logged:], self._valid = version, host, [], valid

    def global_ids(self, ids: np.ndarray, n_local: int) -> np.ndarray:
        """(n_local,) store id of every row of a local set taken as `ids`: the gathered rows keep
        theirs, rows beyond them (children) get the next free ids, as `put_body` will give them."""
        n_new = n_local - len(ids)
        return np.concatenate([np.asarray(ids, np.int64), self.count + np.arange(n_new, dtype=np.int64)])

    def _columns(self) -> list:
        return [getattr(self, name) for name in (*_FIXED, *_CHANGING)]

    def _put_rows(self, ids: np.ndarray, host: dict, made: bool) -> None:
        _k_put(ids, int(made), *(host[name] for name in (*_FIXED, *_CHANGING)), *self._columns())

    def _append_extra(self, pairs: np.ndarray, kill=()) -> None:
        """Remove the extra links at store rows `kill`, append `pairs` (store ids)."""
        pairs = np.asarray(pairs, dtype=np.int32).reshape(-1, 2)
        kill = np.asarray(kill, dtype=np.int32).reshape(-1)
        if self.extra_count + len(pairs) > self.extra_capacity:
            _k_replace_extra(kill, 0, pairs[:0], self.link_extra, self.link_extra_alive)
            kill = kill[:0]
            self.extra_count = _k_compact_extra(self.extra_count, self.link_extra, self.link_extra_alive)
            self._grow(self.count, self.extra_count + len(pairs))
        _k_replace_extra(kill, self.extra_count, pairs, self.link_extra, self.link_extra_alive)
        self.extra_count += len(pairs)

    def _changed(self, bodies) -> None:
        self.version += 1
        for b in np.asarray(bodies).tolist():
            self.body_stamp[int(b)] = self.version

    # ---- reading ---------------------------------------------------------------------------------
    def body_totals(self, n_bodies: int, device: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(alive particles (B,), their mass (B,) kg) per body id below n_bodies: from the host copy the
        store keeps while nothing changed (as `first_invalid`), else (or with `device`) one kernel, B
        rows back."""
        kept = None if device else self.kept_host()
        if kept is not None:
            rows = np.flatnonzero(kept.alive & (kept.body >= 0) & (kept.body < n_bodies))
            return (np.bincount(kept.body[rows], minlength=n_bodies).astype(np.int32),
                    np.bincount(kept.body[rows], weights=np.asarray(kept.mass[rows], np.float64), minlength=n_bodies))
        count = np.zeros(max(1, n_bodies), dtype=np.int32)
        mass = np.zeros(max(1, n_bodies), dtype=np.float64)
        _k_body_totals(self.count, self.particle_alive, self.particle_body, self.particle_mass, count, mass)
        self.transfers.append(("body_totals", len(count)))
        return count[:n_bodies], mass[:n_bodies]

    def take_mass(self, ids: np.ndarray) -> np.ndarray:
        """(K,) kg: the masses of particles `ids` (K rows back)."""
        out = np.empty(len(ids), dtype=np.float64)
        _k_take_f64(np.asarray(ids, np.int32), self.particle_mass, out)
        self.transfers.append(("take_mass", len(ids)))
        return out

    def first_invalid(self, device: bool = False) -> dict[str, int]:
        """Per check, the first alive particle that fails it (geometry.store_checks), or -1: on the host
        copy the store keeps while nothing changed (the build's: a first frame compiles no kernel for
        it); else by one kernel over the rows `put_body` wrote since the store was last found valid,
        where every change since came from `put_body` (the rows no event wrote are as they were); else
        (or with `device`) by that kernel over the whole store."""
        kept = None if device else self.kept_host()
        if kept is not None:
            first = host_first_invalid(kept, self._host[2] if self.has_kernels else None)
        else:
            only_puts = not device and self._valid is not None and self.version - self._valid[0] == len(self._valid[1])
            written = self._valid[1] if only_puts else []
            rows = np.unique(np.concatenate([np.zeros(0, np.int64), *written])).astype(np.int32)
            first = np.zeros(5, dtype=np.int32)
            k_first_invalid(self.count, rows, len(rows) if only_puts else -1, int(self.has_kernels),
                            self.particle_alive, self.particle_centroid, self.particle_rest_verts,
                            self.particle_volume, self.particle_mass, self.particle_kernel, first)
        names = ("particle_centroid", "particle_rest_verts", "particle_volume", "particle_mass", "kernel_G")
        found = {name: (int(i) if i < self.count else -1) for name, i in zip(names, first)}
        # (version, rows written since) while the store is known valid: the next check need look at those only
        self._valid = (self.version, []) if set(found.values()) == {-1} else None
        return found

    def kept_host(self) -> ParticleSet | None:
        """`host()`'s ParticleSet where it is kept already (nothing changed since the build or the last
        download), else None: read without launching a kernel."""
        return self._host[1] if self._host is not None and self._host[0] == self.version else None

    def host(self) -> tuple[ParticleSet, np.ndarray]:
        """The whole store as a read-only ParticleSet and its kernel tensors (N, 3, 3) 1/m: an output
        copy, downloaded when the store changed since the last call."""
        if self.kept_host() is None:
            # every row gathered as an event gathers a body's (local ids are then the store's): the
            # event's kernels, compiled at the start, where Taichi's to_numpy compiles one kernel per
            # dtype and rank at a run's end (0.5 s)
            ps, kernel_G, _ = self._take(np.arange(self.count, dtype=np.int32))
            self.transfers.append(("host", self.count))
            self._keep_host(ps, kernel_G)
        return self._host[1], self._host[2]

    def _keep_host(self, ps: ParticleSet, G: np.ndarray) -> None:
        """The store's content at this version, read-only, for host() to return."""
        for a in (*vars(ps).values(), G):
            a.flags.writeable = False
        self._host = (self.version, ps, G)


# ------------------------------------------------------------------------------------------ helpers
def _kernel_dtype(host_dtype) -> type:
    return np.float64 if host_dtype is np.float64 else np.int32


def _host_columns(ps: ParticleSet, kernel_G: np.ndarray) -> dict[str, np.ndarray]:
    """The store's columns of a ParticleSet, in the dtypes its kernels take."""
    cols = {}
    for name, (shape, _, host) in {**_FIXED, **_CHANGING}.items():
        src = kernel_G if name == "particle_kernel" else getattr(ps, _host_name(name))
        cols[name] = np.ascontiguousarray(src, dtype=_kernel_dtype(host)).reshape(len(ps), *shape)
    return cols


def _particle_set(cols: dict[str, np.ndarray], extra_pairs: np.ndarray) -> ParticleSet:
    """A ParticleSet of store columns (in the ParticleSet's own dtypes)."""
    host = {_host_name(name): cols[name].astype(dtype, copy=False)
            for name, (_, _, dtype) in {**_FIXED, **_CHANGING}.items() if name != "particle_kernel"}
    return ParticleSet(**host, extra_links=np.asarray(extra_pairs, dtype=np.int64).reshape(-1, 2))


def _host_name(name: str) -> str:
    """The ParticleSet attribute of a store column."""
    return _HOST_NAME.get(name, name[len("particle_"):])


def _to_global(local: np.ndarray, global_id: np.ndarray) -> np.ndarray:
    """Local particle ids -> store ids: -1 stays, -2 - id (outside the gathered rows) decodes."""
    local = np.asarray(local, dtype=np.int64)
    out = np.where(local >= 0, global_id[np.maximum(local, 0)], np.where(local <= -2, -2 - local, -1))
    return out.astype(np.int32)
