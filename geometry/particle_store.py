"""The tet particles of a World in Taichi ndarrays (Sect. 5.1, 5.2): one store, worked on in place.

One store holds the physical particles and the children adaptive subdivision makes (a kind flag, an
alive flag, parent ids), their rest kernel tensors (Eq. 5) and the extra links of Fig. 5; fixed data
(written once, when a particle is made) apart from changing data (body, alive, links). A particle's
id is its row; children are appended, ids are never reused.

A fracture event works on the store in place and touches only its body (issue 17, item 4):
`take_body` gathers the struck body's particles, and the physical parents its children came from
(Algorithm 1 analyses them, sim/fracture_stage.py), into a body-sized host `ParticleSet` with local
indices; the host geometry code (geometry.fragments) cuts that; `put_body` writes back what changed
and appends the children. Which rows a body holds is an index kept on the host where the store writes
them (geometry/body_rows.py: no pass over the whole store), so no whole-store array crosses to the
host during an event: `transfers` records every copy to or from the host with its row count (a test
counts an event's). `host()` is the whole store as a read-only `ParticleSet` for outputs (statistics,
exports, the viewer), downloaded only when the store changed since the last.

The copies (gathering, scattering, the extra links, per-body totals, the checks, growth) are numpy on
views of the ndarrays' own memory where that memory is the host's, the CPU backend
(geometry/store_host.py: nothing to compile, 0.9 s less of a process's compiling), and kernels
elsewhere (geometry/store_kernels.py: CUDA); both give the same bits. Ndarrays rather than fields: a
kernel taking ndarrays compiles once for every capacity, so the store grows (doubling, copied in
place) without compiling anything, while a field passed as a template compiles its kernels per store
(rigid/store.py pools its stores for that reason). Geometry stays float64 whatever the simulation
precision: cuts, subdivision and mass properties run on it in float64 on the host, and a round trip
is exact (a fracture event gives the same bits as before the store existed: tested with the scenes'
state hashes).
"""

import functools

import numpy as np
import taichi as ti

from geometry import store_host
from geometry.body_rows import BodyRows
from geometry.particles import ParticleSet
from geometry.store_checks import host_first_invalid, k_first_invalid
from geometry.store_kernels import (
    k_body_totals,
    k_compact_extra,
    k_copy_rows_i32,
    k_copy_store,
    k_gather,
    k_gather_extra,
    k_put,
    k_replace_extra,
    k_take_f64,
)

GEOMETRY_DTYPE = ti.f64  # rest geometry and kernel tensors: float64, as the host geometry code
MIN_CAPACITY = 64  # rows: the smallest store
# rows per particle built: subdivision's children at the end of the paper scenes' runs make 2.2 (pot)
# to 2.7 (glass_r3) rows per physical particle, so the store starts with room for that; Pots' grains
# outgrow it (4.0 rows), and growing doubles it (on CUDA with a copy whose kernels warm_pieces compiles)
HEADROOM = 4

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
_ARRAYS = (*_FIXED, *_CHANGING, "particle_slot", "link_extra", "link_extra_alive", "select_rows", "counter")


class ParticleStore:
    """Tet particles in Taichi ndarrays (see the module docstring); `count` rows are in use."""

    def __init__(self, particles: ParticleSet, kernel_G: np.ndarray | None, capacity: int = 0,
                 on_host: bool = True) -> None:
        # copies by numpy on views of the ndarrays where their memory is the host's (geometry/store_host.py);
        # on_host=False: by the kernels everywhere (the tests compare the two)
        self._on_host = on_host
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
        # name -> numpy view of each ndarray's memory (CPU backend), or None: the kernels copy
        self._views = store_host.host_views({name: getattr(self, name) for name in _ARRAYS}) if self._on_host else None

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
        old_views = self._views
        self._allocate(cap, ecap)
        for name, src in old.items():
            rows_in_use = ne if name.startswith("link_extra") else n
            if self._views is not None:
                self._views[name][:rows_in_use] = old_views[name][:rows_in_use]
            else:
                k_copy_store(rows_in_use, src, getattr(self, name))

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
        for name in _ARRAYS:
            setattr(self, name, None)  # the last host() copy stays readable
        self._views = None

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
        if self._views is not None:
            columns = {name: _kernel_dtype(host) for name, (_, _, host) in {**_FIXED, **_CHANGING}.items()
                       if name not in ("particle_parent", "particle_links")}
            cols, rows, pairs = store_host.take(self._views, ids, self.extra_count, columns)
            return _particle_set(cols, pairs), cols["particle_kernel"], rows
        cols, ne = self._gather(ids)
        rows = np.empty(ne, dtype=np.int32)
        k_copy_rows_i32(ne, self.select_rows, rows)
        rows.sort()
        pairs = np.empty((ne, 2), dtype=np.int32)
        k_gather_extra(rows, ids, self.link_extra, self.particle_slot, pairs)
        return _particle_set(cols, pairs), cols["particle_kernel"], rows

    def _gather(self, ids: np.ndarray) -> tuple[dict, int]:
        """take_bodies' gather: the rows' columns (local ids) and how many extra links they hold."""
        cols = {name: np.empty((len(ids), *shape), dtype=_kernel_dtype(host))
                for name, (shape, _, host) in {**_FIXED, **_CHANGING}.items()}
        ne = k_gather(ids, self.particle_slot, *self._columns(), *cols.values(), self.extra_count, self.link_extra,
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
        nothing (the host copy and `transfers` stay): sim/warm_up.py runs them (issue 16). None where
        numpy makes the copies (the CPU backend: nothing to compile)."""
        if self._views is not None:
            return []
        columns = {(a.dtype, len(a.shape)): a for a in self._columns() + [self.link_extra]}.values()
        nothing = np.zeros(0, np.int32)
        launches = [lambda: self._gather(nothing),  # the event's largest kernels first
                    lambda: self.put_body(*self.take_bodies([])), lambda: self.take_mass(np.zeros(0, np.int64)),
                    lambda: self.first_invalid(device=True), lambda: self.body_totals(1, device=True),
                    *(functools.partial(k_copy_store, 0, c, c) for c in columns),  # one per dtype and rank
                    lambda: k_compact_extra(0, self.link_extra, self.link_extra_alive)]
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
        if self._views is not None:
            store_host.put(self._views, ids, host, made, tuple(_FIXED), tuple(_CHANGING))
        else:
            k_put(ids, int(made), *(host[name] for name in (*_FIXED, *_CHANGING)), *self._columns())

    def _replace_extra(self, kill: np.ndarray, first: int, pairs: np.ndarray) -> None:
        if self._views is not None:
            store_host.replace_extra(self._views, kill, first, pairs)
        else:
            k_replace_extra(kill, first, pairs, self.link_extra, self.link_extra_alive)

    def _append_extra(self, pairs: np.ndarray, kill=()) -> None:
        """Remove the extra links at store rows `kill`, append `pairs` (store ids)."""
        pairs = np.asarray(pairs, dtype=np.int32).reshape(-1, 2)
        kill = np.asarray(kill, dtype=np.int32).reshape(-1)
        if self.extra_count + len(pairs) > self.extra_capacity:
            self._replace_extra(kill, 0, pairs[:0])
            kill = kill[:0]
            if self._views is not None:
                self.extra_count = store_host.compact_extra(self._views, self.extra_count)
            else:
                self.extra_count = k_compact_extra(self.extra_count, self.link_extra, self.link_extra_alive)
            self._grow(self.count, self.extra_count + len(pairs))
        self._replace_extra(kill, self.extra_count, pairs)
        self.extra_count += len(pairs)

    def _changed(self, bodies) -> None:
        self.version += 1
        for b in np.asarray(bodies).tolist():
            self.body_stamp[int(b)] = self.version

    # ---- reading ---------------------------------------------------------------------------------
    def body_totals(self, n_bodies: int, device: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(alive particles (B,), their mass (B,) kg) per body id below n_bodies: from the host copy the
        store keeps while nothing changed (as `first_invalid`), else (or with `device`) from the store
        itself (one pass: numpy on its views, or a kernel), B rows back."""
        kept = None if device else self.kept_host()
        if kept is not None:
            rows = np.flatnonzero(kept.alive & (kept.body >= 0) & (kept.body < n_bodies))
            return (np.bincount(kept.body[rows], minlength=n_bodies).astype(np.int32),
                    np.bincount(kept.body[rows], weights=np.asarray(kept.mass[rows], np.float64), minlength=n_bodies))
        if self._views is not None:
            count, mass = store_host.body_totals(self._views, self.count, n_bodies)
        else:
            count = np.zeros(max(1, n_bodies), dtype=np.int32)
            mass = np.zeros(max(1, n_bodies), dtype=np.float64)
            k_body_totals(self.count, self.particle_alive, self.particle_body, self.particle_mass, count, mass)
        self.transfers.append(("body_totals", len(count)))
        return count[:n_bodies], mass[:n_bodies]

    def take_mass(self, ids: np.ndarray) -> np.ndarray:
        """(K,) kg: the masses of particles `ids` (K rows back)."""
        if self._views is not None:
            out = self._views["particle_mass"][np.asarray(ids, np.int64)]
        else:
            out = np.empty(len(ids), dtype=np.float64)
            k_take_f64(np.asarray(ids, np.int32), self.particle_mass, out)
        self.transfers.append(("take_mass", len(ids)))
        return out

    def first_invalid(self, device: bool = False) -> dict[str, int]:
        """Per check, the first alive particle that fails it (geometry.store_checks), or -1: on the host
        copy the store keeps while nothing changed (the build's); else on the store itself (numpy on
        its views, or a kernel) over the rows `put_body` wrote since the store was last found valid,
        where every change since came from `put_body` (the rows no event wrote are as they were); else
        (or with `device`) over the whole store."""
        kept = None if device else self.kept_host()
        if kept is not None:
            first = host_first_invalid(kept, self._host[2] if self.has_kernels else None)
        else:
            only_puts = not device and self._valid is not None and self.version - self._valid[0] == len(self._valid[1])
            written = self._valid[1] if only_puts else []
            rows = np.unique(np.concatenate([np.zeros(0, np.int64), *written])).astype(np.int32)
            first = self._first_invalid_rows(rows if only_puts else None)
        names = ("particle_centroid", "particle_rest_verts", "particle_volume", "particle_mass", "kernel_G")
        found = {name: (int(i) if i < self.count else -1) for name, i in zip(names, first)}
        # (version, rows written since) while the store is known valid: the next check need look at those only
        self._valid = (self.version, []) if set(found.values()) == {-1} else None
        return found

    def _first_invalid_rows(self, rows: np.ndarray | None) -> np.ndarray:
        """(5,) `first_invalid`'s answer over `rows` (ascending), or over every row for None."""
        if self._views is not None:
            return store_host.first_invalid(self._views, self.count, rows, self.has_kernels)
        first = np.zeros(5, dtype=np.int32)
        k_first_invalid(self.count, np.zeros(0, np.int32) if rows is None else rows, -1 if rows is None else len(rows),
                        int(self.has_kernels), self.particle_alive, self.particle_centroid, self.particle_rest_verts,
                        self.particle_volume, self.particle_mass, self.particle_kernel, first)
        return first

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
