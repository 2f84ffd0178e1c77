"""Benchmark of the fracture-surface geometry (Sect. 5.2) against the paper's Table 2.

Usage: .venv/bin/python bench/bench_fracture.py [--quick] [--repeat N]

For blocks of about 1.7k, 6k, 24k and 80k tet particles (the paper's Glass, Pot, Pet and Pots
counts) one fracture event is timed: three radial half-disc cracks from a point on the top face
(the paper's crack-count 3). Printed per event:
  subdivision  = adaptive subdivision of the cut tets for all cracks (Algorithm 2, lines 1-14)
  crack gen.   = link removal for all cracks + connected components (relabelling)
  surfaces     = closed fragment surfaces (not in the paper's table; for reference)
beside the paper's Table 2 figures (Xeon W3530 + GTX 760) and the ratio paper / ours.
Timings are the best of --repeat runs (each on a fresh copy of the block).
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from geometry.cutting import Crack  # noqa: E402
from geometry.fragments import apply_cracks, fragment_volumes  # noqa: E402
from geometry.particles import build_particles  # noqa: E402
from geometry.subdivision import SNAP_REL  # noqa: E402
from geometry.surface import fragment_surfaces  # noqa: E402
from geometry.tetmesh import TetMesh, signed_volumes  # noqa: E402

# paper Table 2: (scene, physical particles, particle subdivision ms, crack generation ms)
PAPER = [
    ("Glass", 1743, 1593.0, 329.0),
    ("Pot", 6163, 2869.0, 1505.0),
    ("Pet", 23664, 86784.0, 3386.0),
    ("Pots", 80119, 12923.0, 11037.0),
]
BLOCKS = [(7, 7, 6), (10, 10, 10), (16, 16, 15), (24, 24, 23)]  # cubes; x6 tets each


def kuhn_block(nx: int, ny: int, nz: int, jitter: float = 0.2, seed: int = 0) -> TetMesh:
    """Box of nx*ny*nz cubes, 6 Kuhn tets each, interior points jittered (cell size 1 cm)."""
    h = 0.01
    n = np.array([nx, ny, nz])
    grid = np.stack(np.meshgrid(*[np.arange(k + 1) for k in n], indexing="ij"), -1).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    j = rng.uniform(-jitter, jitter, grid.shape)
    j[(grid == 0) | (grid == n)] = 0.0
    verts = (grid + j) * h
    cells = np.stack(np.meshgrid(*[np.arange(k) for k in n], indexing="ij"), -1).reshape(-1, 3)

    def vid(c):
        return (c[:, 0] * (ny + 1) + c[:, 1]) * (nz + 1) + c[:, 2]

    tets = []
    for perm in itertools.permutations(range(3)):
        corner = np.zeros(3, dtype=np.int64)
        cols = [vid(cells + corner)]
        for axis in perm:
            corner = corner.copy()
            corner[axis] += 1
            cols.append(vid(cells + corner))
        tets.append(np.stack(cols, 1))
    tets = np.concatenate(tets)
    neg = signed_volumes(verts[tets]) < 0
    tets[neg] = tets[neg][:, [0, 2, 1, 3]]
    return TetMesh(verts, tets, source=f"kuhn_block({nx},{ny},{nz})")


def event_cracks(mesh: TetMesh, count: int = 3) -> list[Crack]:
    """Radial half-disc cracks from the centre of the top face, reaching through the block."""
    lo, hi = mesh.verts.min(0), mesh.verts.max(0)
    p = np.array([(lo[0] + hi[0]) / 2 + 1e-4, (lo[1] + hi[1]) / 2 + 2e-4, hi[2]])
    radius = 0.8 * float(np.linalg.norm(hi - lo))
    cracks = []
    for g in range(count):
        a = 2.0 * np.pi * (g + 0.1) / count
        side = np.array([np.cos(a), np.sin(a), 0.0])
        normal = np.array([-np.sin(a), np.cos(a), 0.0])
        cracks.append(Crack(point=p, normal=normal, r_outer=radius, side=side, r_inner=0.0))
    return cracks


def run_event(ps, cracks):
    _, rep = apply_cracks(ps, cracks, mode="subdivision")
    t = rep.timings
    t0 = time.perf_counter()
    surf = fragment_surfaces(_, rep.labels)
    t_surf = time.perf_counter() - t0
    children = sum(r.children for r in rep.subdivision)
    return (
        t["subdivision_s"],
        t["links_s"] + t["labels_s"],
        t_surf,
        children,
        rep.n_fragments,
        surf.open_edges,
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="only the two smallest blocks, one run each")
    ap.add_argument("--repeat", type=int, default=3, help="runs per block (best is reported)")
    args = ap.parse_args(argv)
    blocks = BLOCKS[:2] if args.quick else BLOCKS
    repeat = 1 if args.quick else max(1, args.repeat)
    print(
        "fracture event: 3 radial half-disc cracks, adaptive subdivision; times in ms (best of "
        f"{repeat}); ratio = paper / ours"
    )
    head = (
        f"{'paper scene':<12}{'paper N':>8}{'our N':>8}{'children':>9}{'frags':>6}"
        f"{'subdiv':>9}{'paper':>9}{'ratio':>8}{'crackgen':>10}{'paper':>9}{'ratio':>8}{'surfaces':>10}"
    )
    print(head)
    for (name, n_paper, sub_paper, cut_paper), dims in zip(PAPER, blocks, strict=False):
        mesh = kuhn_block(*dims)
        ps0 = build_particles(mesh, 2400.0)
        cracks = event_cracks(mesh)
        best = None
        for _ in range(repeat):
            r = run_event(ps0, cracks)
            best = (
                r
                if best is None
                else tuple(min(a, b) if i < 3 else a for i, (a, b) in enumerate(zip(best, r, strict=True)))
            )
        t_sub, t_cut, t_surf, children, frags, open_edges = best
        assert open_edges == 0, "open fragment surface"
        print(
            f"{name:<12}{n_paper:>8}{len(ps0):>8}{children:>9}{frags:>6}"
            f"{1e3 * t_sub:>9.1f}{sub_paper:>9.0f}{sub_paper / (1e3 * t_sub):>8.0f}"
            f"{1e3 * t_cut:>10.1f}{cut_paper:>9.0f}{cut_paper / (1e3 * t_cut):>8.0f}{1e3 * t_surf:>10.1f}"
        )
    print()
    accuracy_table(blocks)
    return 0


def box_halfspace_volume(size: np.ndarray, normal: np.ndarray, point: np.ndarray) -> float:
    """Exact volume of the box [0, size] on the negative side of the plane (point, normal):
    inclusion-exclusion over the box corners (all normal components must be non-zero)."""
    n = np.asarray(normal, dtype=np.float64).copy()
    c = float(n @ point)
    for a in range(3):  # reflect axes with a negative component
        if n[a] < 0:
            c -= n[a] * size[a]
            n[a] = -n[a]
    total = 0.0
    for sig in itertools.product((0, 1), repeat=3):
        v = np.array(sig) * size
        total += (-1) ** sum(sig) * max(0.0, c - float(n @ v)) ** 3
    return total / (6.0 * n[0] * n[1] * n[2])


def accuracy_table(blocks) -> None:
    """A box cut by a tilted, off-centre plane: fragment volumes against the exact split."""
    print("accuracy: box cut by a tilted off-centre plane; error = max |V_frag - V_exact| / V_exact (exact:")
    print("inclusion-exclusion over the box corners); time = one event in ms; min child = smallest")
    print("child volume / its parent's volume; snapped = vertices snapped onto the plane")
    head = f"{'our N':>8}{'mode':>24}{'error':>11}{'time':>9}{'children':>10}{'snapped':>9}{'min child':>11}"
    print(head)
    for dims in blocks:
        mesh = kuhn_block(*dims)
        ps0 = build_particles(mesh, 2400.0)
        lo, hi = mesh.verts.min(0), mesh.verts.max(0)
        point = lo + np.array([0.37, 0.41, 0.53]) * (hi - lo)
        normal = np.array([0.3, 0.2, 1.0])
        crack = Crack(point=point, normal=normal, r_outer=2.0 * float(np.linalg.norm(hi - lo)))
        below = box_halfspace_volume(hi - lo, normal, point - lo)
        exact = np.array([below, ps0.volume.sum() - below])
        for mode, snap in (
            ("basic", SNAP_REL),
            ("subdivision", 0.05),
            ("subdivision", 0.01),
            ("subdivision", 0.001),
        ):
            t0 = time.perf_counter()
            ps, rep = apply_cracks(ps0, [crack], mode=mode, snap_rel=snap)
            dt = time.perf_counter() - t0
            vol = fragment_volumes(ps, rep.labels)
            if len(vol) == 2:
                # match fragments to the sides by their centroid
                c0 = (ps.centroid[rep.labels == 0] * ps.volume[rep.labels == 0, None]).sum(0) / vol[0]
                if (c0 - point) @ normal > 0:
                    vol = vol[::-1]
                err = float(np.abs(vol - exact).max() / exact.min())
            else:
                err = float("nan")
            sub = rep.subdivision[0] if rep.subdivision else None
            label = mode if mode == "basic" else f"{mode} snap {snap:g}"
            print(
                f"{len(ps0):>8}{label:>24}{err:>11.2e}{1e3 * dt:>9.1f}"
                f"{(sub.children if sub else 0):>10}{(sub.snapped_vertices if sub else 0):>9}"
                f"{(sub.min_volume_ratio if sub and sub.children else float('nan')):>11.2e}"
            )


if __name__ == "__main__":
    raise SystemExit(main())
