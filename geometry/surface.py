"""Fragment surfaces as closed triangle meshes (Sect. 5.2: "detect and generate new surface").

Rule. Start from every face of every alive tet of a fragment (outward, TET_FACES order): the sum
of closed tet boundaries is itself closed. Then cancel only sets of faces that form a closed chain
by themselves, so closure is never lost:
  * a face-linked pair: the two faces coincide with opposite orientation (face links always join
    coinciding faces);
  * an extra-link group: the faces joined by extra links (Fig. 5: one big face against the pieces
    of a subdivided neighbour, or two different tilings of one face) form connected groups; a
    group is cancelled when its faces balance (vector area sums to zero within 1e-9 of its
    total), which means both sides of the group tile the same region. A group with a link removed
    by a crack does not balance and is kept whole (both sides), and a face whose link a crack
    removed is kept on both sides, so crack faces show on both fragments with opposite normals,
    and a crack that ends inside a fragment shows as an internal double face.
Vertices are deduplicated per fragment by exact coordinates. Where a subdivided tet meets one
that is not (rim of a crack, or an earlier child), an edge on one side is split at a cut point on
the other (a T-junction); such edges are found (directed edges without a reverse) and the face
with the long edge is split at the hanging vertex, so every edge is used in both directions.
The enclosed volume (divergence theorem) then equals the fragment's tet volume.
The searches (extra-link groups, T-junctions, faces on the rest surface) use geometry/grid_search.py,
not scipy: the drawing process makes these surfaces too, and importing scipy there took 0.45 s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.arrays import cross3
from geometry.grid_search import PointGrid, components, pairs_within
from geometry.particles import ParticleSet
from geometry.subdivision import coplanar_face_pairs, face_points
from geometry.tetmesh import TET_FACES

BALANCE_REL = 1e-9  # -: extra-link group cancelled when |sum of vector areas| <= this x total area
COLLINEAR_REL = 1e-9  # -: hanging vertex tolerance, relative to the edge length


@dataclass
class SurfaceMesh:
    """Triangle surfaces of several fragments, vertices not shared between fragments."""

    verts: np.ndarray  # (V, 3) m: rest-frame vertex positions
    faces: np.ndarray  # (F, 3) int64: vertex ids, outward (counter-clockwise seen from outside)
    face_label: np.ndarray  # (F,) int64: fragment label of each face
    vert_label: np.ndarray  # (V,) int64: fragment label of each vertex
    open_edges: int = 0  # directed edges left without a reverse (0 for closed surfaces)
    face_id: np.ndarray | None = None  # (F,) int64: particle * 4 + k: face k of that particle's tet

    def fragment(self, label: int) -> tuple[np.ndarray, np.ndarray]:
        """(verts, faces) of one fragment, vertex ids local to it."""
        f = self.faces[self.face_label == label]
        used, inv = np.unique(f, return_inverse=True)
        return self.verts[used], inv.reshape(-1, 3)


def _cancelled_extra_faces(ps: ParticleSet, sel: np.ndarray) -> np.ndarray:
    """(K,) int: face ids (particle * 4 + face) in balanced extra-link groups."""
    ex = ps.extra_links
    if len(ex) == 0:
        return np.zeros(0, np.int64)
    ex = ex[sel[ex[:, 0]] & sel[ex[:, 1]]]
    if len(ex) == 0:
        return np.zeros(0, np.int64)
    fa, fb, found = coplanar_face_pairs(ps.rest_verts[ex[:, 0]], ps.rest_verts[ex[:, 1]])
    na = ex[found, 0] * 4 + fa[found]
    nb = ex[found, 1] * 4 + fb[found]
    nodes, inv = np.unique(np.concatenate([na, nb]), return_inverse=True)
    inv = inv.ravel()
    m = len(na)
    nc, comp = components(len(nodes), inv[:m], inv[m:])
    tri = ps.rest_verts[nodes // 4][np.arange(len(nodes))[:, None], TET_FACES[nodes % 4]]  # (K, 3, 3)
    varea = 0.5 * cross3(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    total = np.bincount(comp, weights=np.linalg.norm(varea, axis=1), minlength=nc)
    net = np.stack([np.bincount(comp, weights=varea[:, a], minlength=nc) for a in range(3)], 1)
    balanced = np.linalg.norm(net, axis=1) <= BALANCE_REL * total
    # a face with a face link is never part of a group (guard against mixed configurations)
    linked = ps.links[nodes // 4, nodes % 4] >= 0
    bad_comp = np.unique(comp[linked])
    balanced[bad_comp] = False
    return nodes[balanced[comp]]


def _split_t_junctions(verts, faces, vert_label, face_data, max_rounds: int = 64):
    """Split faces at vertices hanging on their edges (both halves keep their face's `face_data`);
    returns (faces, face_data, open directed edges)."""
    nv = len(verts)
    for _ in range(max_rounds):
        e = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 3, 2)  # (F, 3, 2): directed edges per face
        key = e[..., 0] * nv + e[..., 1]
        rkey = e[..., 1] * nv + e[..., 0]
        uk, cnt = np.unique(key, return_counts=True)
        pos = np.searchsorted(uk, rkey)
        pos = np.minimum(pos, len(uk) - 1)
        rcnt = np.where(uk[pos] == rkey, cnt[pos], 0)
        fcnt = cnt[np.searchsorted(uk, key)]
        open_e = fcnt != rcnt  # (F, 3)
        if not open_e.any():
            return faces, face_data, 0
        fi, ei = np.nonzero(open_e)
        u = e[fi, ei, 0]
        v = e[fi, ei, 1]
        cand = np.unique(np.concatenate([u, v]))
        a, b = verts[u], verts[v]
        length = np.linalg.norm(b - a, axis=1)
        row, w = pairs_within(0.5 * (a + b), verts[cand], 0.5 * length * (1.0 + 1e-9) + 1e-300)
        if len(row) == 0:
            return faces, face_data, int(open_e.sum())
        w = cand[w]
        ab = b[row] - a[row]
        aw = verts[w] - a[row]
        L2 = np.einsum("ij,ij->i", ab, ab)
        t = np.einsum("ij,ij->i", aw, ab) / L2
        off = np.linalg.norm(aw - t[:, None] * ab, axis=1)
        ok = (
            (w != u[row])
            & (w != v[row])
            & (vert_label[w] == vert_label[u[row]])
            & (t > COLLINEAR_REL)
            & (t < 1.0 - COLLINEAR_REL)
            & (off <= COLLINEAR_REL * np.sqrt(L2))
        )
        if not ok.any():
            return faces, face_data, int(open_e.sum())
        row, w, t = row[ok], w[ok], t[ok]
        f = fi[row]
        # one split per face and round: the hanging vertex closest to its edge's start
        order = np.lexsort((t, f))
        f, row, w = f[order], row[order], w[order]
        first = np.unique(f, return_index=True)[1]
        f, row, w = f[first], row[first], w[first]
        ed = ei[row]
        tri = faces[f]
        # rotate so that the split edge is (t0, t1): face (t0, t1, t2) -> (t0, w, t2), (w, t1, t2)
        rot = np.stack([tri[np.arange(len(f)), (ed + s) % 3] for s in range(3)], 1)
        new_a = np.stack([rot[:, 0], w, rot[:, 2]], 1)
        new_b = np.stack([w, rot[:, 1], rot[:, 2]], 1)
        keep = np.ones(len(faces), dtype=bool)
        keep[f] = False
        faces = np.concatenate([faces[keep], new_a, new_b])
        face_data = np.concatenate([face_data[keep], face_data[f], face_data[f]])
    return faces, face_data, edge_imbalance(faces)


def fragment_surfaces(ps: ParticleSet, labels: np.ndarray) -> SurfaceMesh:
    """Closed, outward triangle surfaces of every fragment labelled >= 0 (rule in module doc)."""
    sel = (labels >= 0) & ps.alive
    pid = np.flatnonzero(sel)
    fid = (pid[:, None] * 4 + np.arange(4)).ravel()
    emit = ps.links[pid].ravel() < 0
    cancelled = _cancelled_extra_faces(ps, sel)
    if cancelled.size:
        emit &= ~np.isin(fid, cancelled)
    fid = fid[emit]
    tri = face_points(ps.rest_verts[fid // 4])[np.arange(len(fid)), fid % 4]  # (F, 3, 3)
    flab = labels[fid // 4]
    # deduplicate vertices per fragment by exact coordinates
    pts = tri.reshape(-1, 3) + 0.0
    rec = np.empty(len(pts), dtype=[("l", "<i8"), ("x", "<f8"), ("y", "<f8"), ("z", "<f8")])
    rec["l"] = np.repeat(flab, 3)
    rec["x"], rec["y"], rec["z"] = pts[:, 0], pts[:, 1], pts[:, 2]
    uniq, inv = np.unique(rec.view(np.dtype((np.void, 32))), return_inverse=True)
    inv = inv.ravel()
    u = uniq.view(rec.dtype)
    verts = np.stack([u["x"], u["y"], u["z"]], 1).astype(np.float64)
    vlab = u["l"].astype(np.int64)
    faces = inv.reshape(-1, 3).astype(np.int64)
    faces, face_id, n_open = _split_t_junctions(verts, faces, vlab, fid)
    return SurfaceMesh(
        verts=verts, faces=faces, face_label=vlab[faces[:, 0]], vert_label=vlab, open_edges=n_open,
        face_id=face_id,
    )


def edge_imbalance(faces: np.ndarray) -> int:
    """Number of directed edges (u, v) used a different number of times than (v, u): 0 means every
    edge is used by an even number of faces with opposite directions (closed and consistent)."""
    if len(faces) == 0:
        return 0
    e = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    nv = int(faces.max()) + 1
    k = e[:, 0] * nv + e[:, 1]
    uk, cnt = np.unique(k, return_counts=True)
    rk = (uk % nv) * nv + uk // nv
    pos = np.minimum(np.searchsorted(uk, rk), len(uk) - 1)
    rcnt = np.where(uk[pos] == rk, cnt[pos], 0)
    return int((cnt != rcnt).sum())


def enclosed_volumes(mesh: SurfaceMesh) -> np.ndarray:
    """(F,) m^3: volume enclosed by each fragment's surface (divergence theorem)."""
    n = int(mesh.face_label.max()) + 1 if len(mesh.face_label) else 0
    # relative to a point of each fragment, to keep the sum well conditioned far from the origin
    cnt = np.maximum(np.bincount(mesh.vert_label, minlength=n), 1)
    ref = np.stack([np.bincount(mesh.vert_label, weights=mesh.verts[:, a], minlength=n) for a in range(3)], 1)
    ref /= cnt[:, None]
    v = mesh.verts[mesh.faces] - ref[mesh.face_label][:, None, :]
    six = np.einsum("ij,ij->i", v[:, 0], cross3(v[:, 1], v[:, 2]))
    return np.bincount(mesh.face_label, weights=six, minlength=n) / 6.0


class RestSurface:
    """The objects' surface at rest, indexed once, to tell a fragment's outer faces (on it) from the
    faces a crack created: `covers(tris, tol)` is asked after every fracture event, for that event's
    new faces only, so the triangles' centres, normals and search tree are built here and kept."""

    def __init__(self, surface_tris: np.ndarray) -> None:
        self.tris = np.asarray(surface_tris, dtype=np.float64).reshape(-1, 3, 3)  # (T, 3, 3) m
        self.centre = self.tris.mean(1)  # (T, 3) m
        n = cross3(self.tris[:, 1] - self.tris[:, 0], self.tris[:, 2] - self.tris[:, 0])
        self.area2 = np.linalg.norm(n, axis=1)  # (T,) m^2: twice each triangle's area
        self.normal = n / np.maximum(self.area2, 1e-300)[:, None]  # (T, 3) -: unit normals
        corner = np.linalg.norm(self.tris - self.centre[:, None, :], axis=2)
        self.reach = float(corner.max(initial=0.0))  # m: a point on a triangle lies this near its centre
        self._grid = None  # geometry.grid_search.PointGrid over `centre`, made at the first `covers`

    def covers(self, tris: np.ndarray, tol: float) -> np.ndarray:
        """(F,) bool: which triangles `tris` (F, 3, 3) lie on this surface with the same orientation: the
        centroid within `tol` (m) of a surface triangle's plane and inside it (barycentric tolerance tol /
        its size), normals within 25 degrees."""
        out = np.zeros(len(tris), dtype=bool)
        if len(tris) == 0 or len(self.tris) == 0:
            return out
        qc = tris.mean(1)
        qn = cross3(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        qn /= np.maximum(np.linalg.norm(qn, axis=1, keepdims=True), 1e-300)
        if self._grid is None or self._grid.cell < self.reach + tol:
            self._grid = PointGrid(self.centre, self.reach + tol)
        q, t = self._grid.pairs(qc, self.reach + tol)  # candidate (query, surface triangle) pairs
        if len(q) == 0:
            return out
        a, b, c = self.tris[t, 0], self.tris[t, 1], self.tris[t, 2]
        n = self.normal[t]
        p = qc[q]
        near_plane = np.abs(np.einsum("ij,ij->i", p - a, n)) <= tol
        same_way = np.einsum("ij,ij->i", qn[q], n) > np.cos(np.radians(25.0))
        # barycentric coordinates of p in (a, b, c), by sub-areas along n
        wa = np.einsum("ij,ij->i", cross3(c - b, p - b), n)
        wb = np.einsum("ij,ij->i", cross3(a - c, p - c), n)
        wc = np.einsum("ij,ij->i", cross3(b - a, p - a), n)
        slack = -tol * np.sqrt(self.area2[t])
        inside = (wa >= slack) & (wb >= slack) & (wc >= slack)
        ok = near_plane & same_way & inside
        out[q[ok]] = True
        return out
