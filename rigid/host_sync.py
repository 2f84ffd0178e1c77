"""Host <-> store copies of the rigid world (rigid/world.py): the body table, spheres, colliders, the
contacts and the warm-start contacts. On the CPU backend by numpy on views of the store's fields
(rigid/host_views.py: nothing to compile), elsewhere by one kernel each of rigid/transfers.py; the
same bits. A mixin of RigidWorld: it reads the world's host mirror (`_hb`, sphere and collider lists)
and its store `_s`."""

from __future__ import annotations

import numpy as np

from core.runtime import numpy_float
from rigid import transfers
from rigid.host_views import store_views
from rigid.records import BodyState


class HostSync:
    """Copies between the host mirror and the Taichi store (used by RigidWorld only)."""

    def _state(self) -> BodyState:
        """Every body's state, downloaded once until a step or a write changes it: a frame reads it
        some ten times (impacts, guards, pieces, drawing, settling), 0.4-0.7 ms a download. Read only:
        `body_state` hands out copies."""
        cached = getattr(self, "_state_cache", None)
        if cached is None or cached[0] is not self._s or len(cached[1].alive) != self._nb:
            cached = (self._s, self._download_bodies(self._nb))
            self._state_cache = cached
        return cached[1]

    def _views(self) -> dict | None:
        """The store's fields as numpy views (rigid/host_views.py), or None (the kernels copy); made once
        per store."""
        cached = getattr(self, "_views_cache", None)
        if cached is None or cached[0] is not self._s:
            cached = self._views_cache = (self._s, store_views(self._s))
        return cached[1]

    def read_scalar(self, name: str):
        """A 0-D field of the store (rigid/host_views.py SCALARS), read through its view where there is one
        (Taichi compiles an accessor for each field read from Python)."""
        hv = self._views()
        return hv[name][()] if hv is not None else getattr(self._s, name)[None]

    def write_scalar(self, name: str, value) -> None:
        hv = self._views()
        if hv is not None:
            hv[name][...] = value
        else:
            getattr(self._s, name)[None] = value

    def _forget_state(self) -> None:
        """Called by everything that writes a body's state: the step, uploads, pose writes, wake-ups."""
        self._state_cache = None

    def _write_body_state(self, body: int, x, q, v, w, asleep: int, alive: int) -> None:
        if (hv := self._views()) is not None:
            for name, value in (("x", x), ("q", q), ("v", v), ("w", w), ("asleep", asleep), ("alive", alive),
                                ("sleep_time", 0.0)):
                hv["body_" + name][body] = value
        else:
            transfers.k_set_body_state(self._s, body, x, q, v, w, asleep, alive)
        self._forget_state()

    def _wake_bodies(self, ids: np.ndarray) -> None:
        if (hv := self._views()) is not None:
            ids = np.asarray(ids, np.int64)
            ids = ids[(hv["body_alive"][ids] == 1) & (hv["body_static"][ids] == 0) & (hv["body_asleep"][ids] == 1)]
            hv["body_asleep"][ids] = 0
            hv["body_sleep_time"][ids] = 0.0
        else:
            transfers.k_wake(self._s, ids, len(ids))
        self._forget_state()

    def _download_bodies(self, n: int) -> BodyState:
        if (hv := self._views()) is not None:
            return BodyState(**{name: hv["body_" + name][:n].astype(np.float64) for name in ("x", "q", "v", "w")},
                             asleep=hv["body_asleep"][:n].astype(bool), alive=hv["body_alive"][:n].astype(bool),
                             sleep_time=hv["body_sleep_time"][:n].astype(np.float64))
        fdt = numpy_float()
        m = max(n, 1)
        x = np.zeros((m, 3), fdt)
        q = np.zeros((m, 4), fdt)
        v = np.zeros((m, 3), fdt)
        w = np.zeros((m, 3), fdt)
        asleep = np.zeros(m, np.int32)
        st = np.zeros(m, fdt)
        alive = np.zeros(m, np.int32)
        if n > 0:
            transfers.k_download_bodies(self._s, n, x, q, v, w, asleep, st, alive)
        st_ = BodyState(
            x=x[:n].astype(np.float64),
            q=q[:n].astype(np.float64),
            v=v[:n].astype(np.float64),
            w=w[:n].astype(np.float64),
            asleep=asleep[:n].astype(bool),
            alive=alive[:n].astype(bool),
            sleep_time=st[:n].astype(np.float64),
        )
        return st_

    def body_reach(self) -> np.ndarray:
        """(nb,) m: each body's bounding radius about its centre of mass (largest |sphere centre| +
        radius); kept until the spheres change (they are replaced, never edited, when they do)."""
        cached = getattr(self, "_reach", None)
        if cached is None or cached[0] is not self._sph_body or len(cached[1]) != self._nb:
            reach = np.zeros(self._nb, numpy_float())
            np.maximum.at(reach, self._sph_body, np.linalg.norm(self._sph_local, axis=1) + self._sph_radius)
            self._reach = (self._sph_body, reach)
        return self._reach[1]

    def static_mask(self) -> np.ndarray:
        """(nb,) bool: which bodies are immovable (a window frame, a held body)."""
        return np.asarray(self._hb.static[: self._nb], dtype=bool)

    def colliders(self) -> dict:
        """The static colliders' host lists, one entry each: kind (0 half-space, 1 box), x, q, n, half,
        restitution, friction. Read only."""
        return self._col

    def warm_event_pieces(self) -> list:
        """Launchers of the copies a fracture event makes (body-state, contact and warm-start downloads,
        wake-ups, body-state writes), each launching one on nothing (zero counts; the body-state write on
        a free slot, with the zeros it holds), so that the first event is as fast as the later ones:
        Taichi loads a kernel's cached code at its first launch (10-60 ms each). sim/warm_up.py runs them.
        A run's frames download the bodies' state before any event; the API's first call that reads it
        (`Simulation.surface_point`, a strike) would compile it (60 ms), so it is among them. None where
        numpy makes the copies (the CPU backend: nothing to compile)."""
        from core.compile import precompile

        if self._views() is not None:
            return []

        fdt = numpy_float()
        i1, f1, f3 = np.zeros(1, np.int32), np.zeros(1, fdt), np.zeros((1, 3), fdt)
        v3, v4 = np.zeros(3, fdt), np.zeros(4, fdt)

        def set_state() -> None:
            free = self._s.cap_bodies - 1  # read when it runs: bodies may have been added since
            if free >= self._nb:
                self._write_body_state(free, v3, v4, v3, v3, 0, 0)
            else:
                precompile(transfers.k_set_body_state, self._s, 0, v3, v4, v3, v3, 0, 0)

        return [lambda: transfers.k_download_bodies(self._s, 0, f3, np.zeros((1, 4), fdt), f3, f3, i1, f1, i1),
                lambda: transfers.k_download_contacts(self._s, 0, i1, i1, i1, i1, f3, f3, f1, f1, f1),
                lambda: transfers.k_download_prev(self._s, 0, 0, i1, f1, f3, i1),
                lambda: transfers.k_wake(self._s, i1, 0), set_state]

    def _upload_bodies(self, start: int, n: int, state: BodyState, offset: int = 0) -> None:
        """Write bodies [start, start + n) from the host mirror and `state` rows [offset, offset + n)."""
        if n == 0:
            return
        fdt = numpy_float()
        hb = self._hb
        sl = slice(start, start + n)
        ss = slice(offset, offset + n)

        def arr(lst, dt=fdt):
            return np.ascontiguousarray(np.asarray(lst[sl], dtype=np.float64).astype(dt))

        sleep_time = state.sleep_time if state.sleep_time is not None else np.zeros(len(state.x))
        if (hv := self._views()) is not None:
            for name in ("inv_mass", "ref_com", "inv_inertia", "principal_q", "inv_principal", "restitution",
                         "friction"):
                hv["body_" + name][sl] = arr(getattr(hb, name))
            hv["body_static"][sl] = arr(hb.static, np.int32)
            for name, col in (("alive", state.alive), ("asleep", state.asleep)):
                hv["body_" + name][sl] = col[ss].astype(np.int32)
            for name, col in (("x", state.x), ("q", state.q), ("v", state.v), ("w", state.w),
                              ("sleep_time", np.asarray(sleep_time))):
                hv["body_" + name][sl] = col[ss].astype(fdt)
            self._forget_state()
            return
        transfers.k_upload_bodies(
            self._s,
            start,
            n,
            arr(hb.inv_mass),
            arr(hb.ref_com),
            arr(hb.inv_inertia),
            arr(hb.principal_q),
            arr(hb.inv_principal),
            arr(hb.restitution),
            arr(hb.friction),
            arr(hb.static, np.int32),
            np.ascontiguousarray(state.alive[ss].astype(np.int32)),
            np.ascontiguousarray(state.x[ss].astype(fdt)),
            np.ascontiguousarray(state.q[ss].astype(fdt)),
            np.ascontiguousarray(state.v[ss].astype(fdt)),
            np.ascontiguousarray(state.w[ss].astype(fdt)),
            np.ascontiguousarray(state.asleep[ss].astype(np.int32)),
            np.ascontiguousarray(np.asarray(sleep_time[ss]).astype(fdt)),
        )
        self._forget_state()

    def _upload_spheres(self, start: int, n: int) -> None:
        if n == 0:
            return
        fdt = numpy_float()
        sl = slice(start, start + n)
        if (hv := self._views()) is not None:
            hv["bp_local"][sl] = self._sph_local[sl].astype(fdt)
            hv["bp_radius"][sl] = self._sph_radius[sl].astype(fdt)
            hv["bp_body"][sl] = self._sph_body[sl]
            return
        transfers.k_upload_spheres(
            self._s,
            start,
            n,
            np.ascontiguousarray(self._sph_local[sl].astype(fdt)),
            np.ascontiguousarray(self._sph_radius[sl].astype(fdt)),
            np.ascontiguousarray(self._sph_body[sl]),
        )

    def _upload_colliders(self, start: int, n: int) -> None:
        if n == 0:
            return
        fdt = numpy_float()
        c = self._col
        sl = slice(start, start + n)

        def arr(key, dt=fdt):
            return np.ascontiguousarray(np.asarray(c[key][sl], dtype=np.float64).astype(dt))

        if (hv := self._views()) is not None:
            hv["col_kind"][sl] = arr("kind", np.int32)
            for key in ("x", "q", "n", "half", "restitution", "friction"):
                hv["col_" + key][sl] = arr(key)
            return
        transfers.k_upload_colliders(
            self._s,
            start,
            n,
            arr("kind", np.int32),
            arr("x"),
            arr("q"),
            arr("n"),
            arr("half"),
            arr("restitution"),
            arr("friction"),
        )

    def _download_contacts(self) -> tuple:
        """The last step's contacts (a, b, body_a, body_b, point, normal, normal impulse, normal speed,
        separation), each (nc, ...) in the store's dtypes."""
        nc = self._nc
        names = ("ct_a", "ct_b", "ct_body_a", "ct_body_b", "ct_p", "ct_n", "ct_ltot", "ct_vn0", "ct_sep")
        if (hv := self._views()) is not None:
            return tuple(hv[name][:nc].copy() for name in names)
        fdt, m = numpy_float(), max(nc, 1)
        out = [np.zeros(m, np.int32) for _ in range(4)] + [np.zeros((m, 3), fdt) for _ in range(2)]
        out += [np.zeros(m, fdt) for _ in range(3)]
        if nc > 0:
            transfers.k_download_contacts(self._s, nc, *out)
        return tuple(a[:nc] for a in out)

    def _download_prev(self):
        """(pc_b, pc_ln, pc_lt, pc_start, valid) of the previous step's contacts."""
        fdt = numpy_float()
        nc, ns = self._nc, self._ns
        if (hv := self._views()) is not None:
            valid = int(hv["pc_valid"][()])
            if not valid:
                return np.zeros(nc, np.int32), np.zeros(nc, fdt), np.zeros((nc, 3), fdt), np.zeros(ns + 1, np.int32), 0
            return (hv["pc_b"][:nc].copy(), hv["pc_ln"][:nc].copy(), hv["pc_lt"][:nc].copy(),
                    hv["bp_pc_start"][:ns + 1].copy(), valid)
        pb = np.zeros(max(nc, 1), np.int32)
        pln = np.zeros(max(nc, 1), fdt)
        plt = np.zeros((max(nc, 1), 3), fdt)
        pstart = np.zeros(ns + 1, np.int32)
        valid = int(self.read_scalar("pc_valid"))
        if valid:
            transfers.k_download_prev(self._s, nc, ns, pb, pln, plt, pstart)
        return pb[:nc], pln[:nc], plt[:nc], pstart, valid

    def _upload_prev(self, pb, pln, plt, pstart, valid) -> None:
        fdt = numpy_float()
        nc = len(pb)
        ns = len(pstart) - 1
        if nc > self._s.cap_contacts:  # only when shrinking, which never happens
            valid = 0
            nc = 0
        if (hv := self._views()) is not None:
            hv["pc_b"][:nc], hv["pc_ln"][:nc], hv["pc_lt"][:nc] = pb[:nc], pln[:nc], plt[:nc]
            hv["bp_pc_start"][:ns + 1] = pstart
            self.write_scalar("pc_valid", int(valid))
            self._nc = nc
            return
        transfers.k_upload_prev(
            self._s,
            nc,
            ns,
            np.ascontiguousarray(np.r_[pb, 0].astype(np.int32)),
            np.ascontiguousarray(np.r_[pln, 0].astype(fdt)),
            np.ascontiguousarray(np.concatenate([plt, np.zeros((1, 3))]).astype(fdt)),
            np.ascontiguousarray(pstart.astype(np.int32)),
            int(valid),
        )
        self._nc = nc

    def _remap_prev(self, prev, old_to_new: np.ndarray, new_ns: int) -> None:
        """Renumber the warm-start contacts `prev` (from `_download_prev` before the change) after
        spheres were added or removed (old_to_new[i] = -1 for a removed sphere)."""
        pb, pln, plt, pstart, valid = prev
        if not valid or len(pb) == 0:
            self._upload_prev(pb[:0], pln[:0], plt[:0], np.zeros(new_ns + 1, np.int32), 0)
            return
        counts = np.diff(pstart)
        a_old = np.repeat(np.arange(len(counts)), counts)
        a_new = old_to_new[a_old]
        b_new = np.where(pb >= 0, old_to_new[np.maximum(pb, 0)], pb)
        keep = (a_new >= 0) & ((pb < 0) | (b_new >= 0))
        a_new, b_new, pln, plt = a_new[keep], b_new[keep], pln[keep], plt[keep]
        order = np.lexsort((b_new, a_new))
        a_new, b_new, pln, plt = a_new[order], b_new[order], pln[order], plt[order]
        start = np.zeros(new_ns + 1, np.int64)
        np.cumsum(np.bincount(a_new, minlength=new_ns), out=start[1:])
        self._upload_prev(b_new, pln, plt, start, 1)

    # ------------------------------------------------------------------ building
