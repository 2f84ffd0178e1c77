"""Neighbour search for anisotropic kernels on a hashed uniform grid, CSR output without a cap.

Relation (gather, i's own kernel): j is a neighbour of i iff j != i and |G_i (x_j - x_i)| < 1,
the support of W(x_ij, G_i) (Eq. 4). It is not symmetric when G differs between particles; the
elastic model does not need it to be: every pair (i, j in N(i)) contributes equal and opposite
forces to i and j (sph/corotated.py), so momentum is conserved with one-sided lists.

Grid: cell size = the largest support radius over all particles, max_i 1/lambda_min(G_i) (via
`sph.eigen`), so the support of every particle lies within 3 cells per axis. Cells are hashed
into a table of 2^k >= 2 * capacity buckets (the domain may be unbounded: debris can fly far).
Build: count per bucket (atomics) -> exclusive scan -> scatter particle ids -> sort each bucket
by id (makes the result independent of atomic order, thus of the thread count and backend).
Query: for each particle, visit the cells overlapping the bounding box of its support ellipsoid
(half-widths sqrt(diag(G^-2))), and in each cell's bucket keep only particles whose cell is that
cell (hash collisions can put several cells in one bucket; this keeps each candidate once).
Two passes: count -> exclusive scan to CSR offsets -> fill. The index array grows (x1.5, at
least to the need) between the passes, so there is no cap on neighbours and no write out of bounds.

Storage: `ti.ndarray`s passed to module-level kernels, not fields: a new or grown store then
never recompiles (new fields given to a kernel recompile it, TAICHI_NOTES), and the compiled
kernels are shared by every store in the process and cached on disk.

Scan: chunks of SCAN_CHUNK entries are scanned in parallel (serial inside a chunk), the chunk
sums serially, then added back in parallel: one code path that is parallel on CUDA and cheap on
CPU (the serial part is n / SCAN_CHUNK long).

Output order: particle i's neighbours are listed by visited cell (ascending cell coordinates,
z fastest), ids ascending inside a cell; deterministic.
"""

import numpy as np
import taichi as ti

from core.errors import CapacityError
from core.runtime import numpy_float
from sph.kernel import support_extent, support_radius_ti

SCAN_CHUNK = 1024  # entries scanned serially per parallel task
_H1, _H2, _H3 = 73856093, 19349663, 83492791  # spatial-hash primes (Teschner et al. 2003)

ivec3 = ti.types.vector(3, ti.i32)
nd_i32 = ti.types.ndarray(dtype=ti.i32, ndim=1)
nd_v3 = ti.types.ndarray(dtype=ti.math.vec3, ndim=1)
nd_m3 = ti.types.ndarray(dtype=ti.math.mat3, ndim=1)
nd_iv3 = ti.types.ndarray(dtype=ivec3, ndim=1)
nd_f = ti.types.ndarray(ndim=1)  # float array of the running precision


def _next_pow2(n: int) -> int:
    return 1 << max(4, int(n - 1).bit_length())


@ti.func
def _hash(c, mask):
    return ((c[0] * _H1) ^ (c[1] * _H2) ^ (c[2] * _H3)) & mask


@ti.kernel
def exclusive_scan(data: nd_i32, chunk_sum: nd_i32, n: ti.i32):
    """Exclusive prefix sum of data[0..n) in place; data[n] = total. chunk_sum: >= n/SCAN_CHUNK + 1."""
    nchunk = (n + SCAN_CHUNK - 1) // SCAN_CHUNK
    for c in range(nchunk):
        s = 0
        hi = ti.min((c + 1) * SCAN_CHUNK, n)
        for k in range(c * SCAN_CHUNK, hi):
            v = data[k]
            data[k] = s
            s += v
        chunk_sum[c] = s
    for _ in range(1):  # serial scan of the chunk sums (n / SCAN_CHUNK entries)
        s = 0
        for c in range(nchunk):
            v = chunk_sum[c]
            chunk_sum[c] = s
            s += v
        data[n] = s
    for k in range(n):
        data[k] += chunk_sum[k // SCAN_CHUNK]


@ti.kernel
def _bin(
    x: nd_v3, G: nd_m3, cell: nd_iv3, bucket_start: nd_i32, bucket_fill: nd_i32, cell_size: nd_f,
    n: ti.i32, table: ti.i32,
):
    cell_size[0] = 0.0
    for i in range(n):
        ti.atomic_max(cell_size[0], support_radius_ti(G[i]))
    for b in range(table + 1):
        bucket_start[b] = 0
    for b in range(table):
        bucket_fill[b] = 0
    for i in range(n):
        c = ti.floor(x[i] / cell_size[0]).cast(ti.i32)
        cell[i] = c
        ti.atomic_add(bucket_start[_hash(c, table - 1)], 1)


@ti.kernel
def _scatter(
    cell: nd_iv3, bucket_start: nd_i32, bucket_fill: nd_i32, sorted_id: nd_i32, n: ti.i32, table: ti.i32
):
    for i in range(n):
        b = _hash(cell[i], table - 1)
        k = ti.atomic_add(bucket_fill[b], 1)
        sorted_id[bucket_start[b] + k] = i
    for b in range(table):  # insertion sort per bucket: deterministic order
        lo = bucket_start[b]
        hi = bucket_start[b + 1]
        for k in range(lo + 1, hi):
            v = sorted_id[k]
            m = k - 1
            while m >= lo:  # no short-circuit 'and' in Taichi: test the bound first
                if sorted_id[m] > v:
                    sorted_id[m + 1] = sorted_id[m]
                    m -= 1
                else:
                    break
            sorted_id[m + 1] = v


@ti.func
def _visit(
    i, x: ti.template(), G: ti.template(), cell: ti.template(), bucket_start: ti.template(),
    sorted_id: ti.template(), cs, table, out: ti.template(), write: ti.template(), start,
):
    """Count (write=False) or write at out[start + k] (write=True) the neighbours of i."""
    xi = x[i]
    Gi = G[i]
    ext = support_extent(Gi)
    lo = ti.floor((xi - ext) / cs).cast(ti.i32)
    hi = ti.floor((xi + ext) / cs).cast(ti.i32)
    cnt = 0
    for cx in range(lo[0], hi[0] + 1):
        for cy in range(lo[1], hi[1] + 1):
            for cz in range(lo[2], hi[2] + 1):
                b = _hash(ti.Vector([cx, cy, cz]), table - 1)
                for k in range(bucket_start[b], bucket_start[b + 1]):
                    j = sorted_id[k]
                    cj = cell[j]
                    if cj[0] == cx and cj[1] == cy and cj[2] == cz and j != i:
                        if (Gi @ (x[j] - xi)).norm() < 1.0:
                            if ti.static(write):
                                out[start + cnt] = j
                            cnt += 1
    return cnt


@ti.kernel
def _count(
    x: nd_v3, G: nd_m3, cell: nd_iv3, bucket_start: nd_i32, sorted_id: nd_i32, cell_size: nd_f,
    nbr_offset: nd_i32, n: ti.i32, table: ti.i32,
):
    for i in range(n):
        nbr_offset[i] = _visit(
            i, x, G, cell, bucket_start, sorted_id, cell_size[0], table, nbr_offset, False, 0
        )
    nbr_offset[n] = 0


@ti.kernel
def _fill(
    x: nd_v3, G: nd_m3, cell: nd_iv3, bucket_start: nd_i32, sorted_id: nd_i32, cell_size: nd_f,
    nbr_offset: nd_i32, nbr_index: nd_i32, n: ti.i32, table: ti.i32,
):
    for i in range(n):
        _visit(i, x, G, cell, bucket_start, sorted_id, cell_size[0], table, nbr_index, True, nbr_offset[i])


class NeighbourSearch:
    """Gather neighbour lists (CSR) for points with per-point kernel tensors G.

    Usage: `ns = NeighbourSearch(capacity)`, `ns.set_points(x, G)` (numpy), `ns.build()`; then
    `ns.nbr_offset` (n+1 entries used) and `ns.nbr_index` (`total` entries used), or `ns.to_numpy()`.
    """

    def __init__(self, capacity: int, nbr_capacity: int = 0, max_points: int = 1 << 26) -> None:
        if capacity < 1:
            raise CapacityError(f"NeighbourSearch capacity must be >= 1, got {capacity}")
        self.max_points = int(max_points)
        self.n = 0
        self.total = 0
        self._alloc(capacity)
        self.nbr_capacity = max(int(nbr_capacity), 16)
        self.nbr_index = ti.ndarray(ti.i32, shape=self.nbr_capacity)  # (nbr_capacity,) 1: neighbour ids

    def _alloc(self, capacity: int) -> None:
        self.capacity = int(capacity)
        self.table_size = _next_pow2(2 * self.capacity)
        n_scan = max(self.table_size, self.capacity + 1)
        self.particle_x = ti.ndarray(ti.math.vec3, shape=self.capacity)  # (capacity,) m: positions
        self.particle_G = ti.ndarray(ti.math.mat3, shape=self.capacity)  # (capacity,) 1/m: kernel tensors
        self.particle_cell = ti.ndarray(ivec3, shape=self.capacity)  # (capacity,) 1: integer cell coordinates
        self.sorted_id = ti.ndarray(ti.i32, shape=self.capacity)  # (capacity,) 1: particle ids by bucket
        self.nbr_offset = ti.ndarray(ti.i32, shape=self.capacity + 1)  # (capacity+1,) 1: counts, then offsets
        self.bucket_start = ti.ndarray(ti.i32, shape=self.table_size + 1)  # (table+1,) 1: counts, offsets
        self.bucket_fill = ti.ndarray(ti.i32, shape=self.table_size)  # (table,) 1: scatter cursors
        self.scan_sum = ti.ndarray(ti.i32, shape=n_scan // SCAN_CHUNK + 2)  # (.,) 1: chunk sums of a scan
        self.grid_cell = ti.ndarray(float, shape=1)  # (1,) m: cell size

    def release(self) -> None:
        """Drop the device arrays (no field tree is held)."""
        for name in ("particle_x", "particle_G", "particle_cell", "sorted_id", "nbr_offset", "bucket_start",
                     "bucket_fill", "scan_sum", "grid_cell", "nbr_index"):
            setattr(self, name, None)

    # ------------------------------------------------------------------ host API

    def set_points(self, x: np.ndarray, G: np.ndarray) -> None:
        """Copy n points (n,3) m and their kernel tensors (n,3,3) 1/m; grows the store if needed."""
        x = np.asarray(x)
        G = np.asarray(G)
        n = x.shape[0]
        if x.shape != (n, 3) or G.shape != (n, 3, 3):
            raise ValueError(f"set_points: x must be (n,3) and G (n,3,3), got {x.shape} and {G.shape}")
        if n > self.max_points:
            raise CapacityError(f"NeighbourSearch: {n} points exceed max_points={self.max_points}")
        if n > self.capacity:
            self._alloc(max(n, int(self.capacity * 1.5)))
        dtype = numpy_float()
        xs = np.zeros((self.capacity, 3), dtype=dtype)
        Gs = np.tile(np.eye(3, dtype=dtype), (self.capacity, 1, 1))
        xs[:n] = x
        Gs[:n] = G
        self.particle_x.from_numpy(xs)
        self.particle_G.from_numpy(Gs)
        self.n = n

    def build(self) -> int:
        """Build the CSR lists for the points set last; returns the number of (i, j) entries."""
        n = self.n
        if n == 0:
            self.total = 0
            return 0
        T = self.table_size
        _bin(self.particle_x, self.particle_G, self.particle_cell, self.bucket_start, self.bucket_fill,
             self.grid_cell, n, T)
        exclusive_scan(self.bucket_start, self.scan_sum, T)
        _scatter(self.particle_cell, self.bucket_start, self.bucket_fill, self.sorted_id, n, T)
        _count(self.particle_x, self.particle_G, self.particle_cell, self.bucket_start, self.sorted_id,
               self.grid_cell, self.nbr_offset, n, T)
        exclusive_scan(self.nbr_offset, self.scan_sum, n)
        total = int(self.nbr_offset[n])
        if total > self.nbr_capacity:
            self.nbr_capacity = max(total, int(self.nbr_capacity * 1.5))
            self.nbr_index = ti.ndarray(ti.i32, shape=self.nbr_capacity)
        _fill(self.particle_x, self.particle_G, self.particle_cell, self.bucket_start, self.sorted_id,
              self.grid_cell, self.nbr_offset, self.nbr_index, n, T)
        self.total = total
        return total

    def to_numpy(self) -> tuple[np.ndarray, np.ndarray]:
        """(offsets (n+1,), indices (total,)) of the last build, int64."""
        off = self.nbr_offset.to_numpy()[: self.n + 1].astype(np.int64)
        idx = self.nbr_index.to_numpy()[: self.total].astype(np.int64)
        return off, idx

    def neighbour_sets(self) -> list[set[int]]:
        off, idx = self.to_numpy()
        return [set(idx[off[i] : off[i + 1]].tolist()) for i in range(self.n)]


def brute_force_neighbours(x: np.ndarray, G: np.ndarray) -> list[set[int]]:
    """numpy reference: N(i) = {j != i : |G_i (x_j - x_i)| < 1} (O(n^2); for tests)."""
    x = np.asarray(x, dtype=np.float64)
    G = np.asarray(G, dtype=np.float64)
    out = []
    for i in range(x.shape[0]):
        q = np.linalg.norm((x - x[i]) @ G[i].T, axis=1)
        m = q < 1.0
        m[i] = False
        out.append(set(np.nonzero(m)[0].tolist()))
    return out
