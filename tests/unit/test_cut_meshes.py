"""Test meshes for the cutting / fragment tests, and checks that they are valid.

`kuhn_box`: a box split into cubes, each cube into the 6 Kuhn tets around its main diagonal (a
conforming structured hex -> tet split); interior lattice points are jittered, boundary points
only within their box faces, so the box stays exact. `delaunay_block`: scipy Delaunay of a
jittered lattice (the convex hull of the points, irregular tets everywhere).
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.spatial import Delaunay

from geometry.particles import ParticleSet, build_particles
from geometry.tetmesh import TetMesh, face_adjacency, signed_volumes, validate_tets

DENSITY = 2400.0  # kg/m^3


def kuhn_box(nx: int, ny: int, nz: int, size=(1.0, 1.0, 1.0), jitter: float = 0.0, seed: int = 0) -> TetMesh:
    """Box [0, size] split into nx*ny*nz cubes x 6 tets; jitter is a fraction of the cell size."""
    size = np.asarray(size, dtype=np.float64)
    n = np.array([nx, ny, nz])
    h = size / n
    grid = np.stack(np.meshgrid(*[np.arange(k + 1) for k in n], indexing="ij"), -1).reshape(-1, 3)
    verts = grid * h
    if jitter > 0.0:
        rng = np.random.default_rng(seed)
        j = rng.uniform(-jitter, jitter, verts.shape) * h
        on_lo = grid == 0
        on_hi = grid == n
        j[on_lo | on_hi] = 0.0  # boundary points move only within their faces
        verts = verts + j

    def vid(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    cells = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"), -1).reshape(
        -1, 3
    )
    tets = []
    for perm in itertools.permutations(range(3)):
        corners = [np.zeros(3, dtype=np.int64)]
        for axis in perm:
            c = corners[-1].copy()
            c[axis] += 1
            corners.append(c)
        tets.append(np.stack([vid(*(cells + c).T) for c in corners], axis=1))
    tets = np.concatenate(tets)
    vol = signed_volumes(verts[tets])
    neg = vol < 0
    tets[neg] = tets[neg][:, [0, 2, 1, 3]]
    mesh = TetMesh(verts, tets, source=f"kuhn_box({nx},{ny},{nz})")
    validate_tets(mesh)
    return mesh


def delaunay_block(nx: int, ny: int, nz: int, jitter: float = 0.3, seed: int = 0) -> TetMesh:
    """Delaunay tets of a jittered (nx+1)(ny+1)(nz+1) lattice with unit spacing scaled to 1/nx."""
    rng = np.random.default_rng(seed)
    grid = np.stack(np.meshgrid(*[np.arange(k + 1) for k in (nx, ny, nz)], indexing="ij"), -1).reshape(-1, 3)
    pts = (grid + rng.uniform(-jitter, jitter, grid.shape)) / nx
    tri = Delaunay(pts)
    tets = tri.simplices.astype(np.int64)
    vol = signed_volumes(pts[tets])
    tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
    vol = np.abs(vol)
    keep = vol > 1e-6 * vol.mean()  # drop hull slivers
    mesh = TetMesh(pts, tets[keep], source="delaunay_block")
    validate_tets(mesh)
    return mesh


def particles(mesh: TetMesh, body: int = 0) -> ParticleSet:
    return build_particles(mesh, DENSITY, body=body)


def test_kuhn_box_is_a_conforming_exact_box():
    mesh = kuhn_box(3, 4, 2, size=(0.3, 0.4, 0.2), jitter=0.2, seed=1)
    assert len(mesh.tets) == 3 * 4 * 2 * 6
    assert np.all(mesh.volumes > 0)
    assert abs(mesh.volume - 0.3 * 0.4 * 0.2) < 1e-15
    adj = face_adjacency(mesh.tets)
    assert (adj < 0).sum() == 2 * 2 * (3 * 4 + 4 * 2 + 3 * 2)  # two triangles per boundary square


def test_delaunay_block_is_valid():
    mesh = delaunay_block(4, 4, 4, seed=2)
    assert np.all(mesh.volumes > 0)
    ps = particles(mesh)
    i, k = np.nonzero(ps.links >= 0)
    j = ps.links[i, k]
    assert np.all((ps.links[j] == i[:, None]).sum(1) == 1)  # symmetric
