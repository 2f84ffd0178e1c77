"""Frame time of each renderer for pot-sized and pots-sized fragment surfaces (DESIGN.md section 8).

    .venv/bin/python bench/bench_render.py [--quick] [--arch cpu|cuda] [--precision f32|f64] [--threads N]

Surfaces: the paper's pot (geometry.build NAMED_SHAPES['pot'] at a 6.5 mm tet size, about 10k
boundary triangles, built with geometry.surface.fragment_surfaces) as one body; two pots (20k);
thirteen pots (about 130k, the 'Pots' scene) as thirteen bodies on a grid. Each measured frame moves
every body (new poses), runs the transform kernel (`RenderScene.update`) and renders one image; the
table gives the mean and median wall time per frame and, separately, the transform alone. Renderers:
the Taichi rasteriser and, when Vulkan works, headless GGUI. Sizes 640x480 and 1280x720.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

POT_RESOLUTION_M = 0.0065  # m: tet size giving about 10k surface triangles for the pot
POT_SPACING_M = 0.25  # m: grid spacing of the pots
SIZES = ((640, 480), (1280, 720))


def pot_surface():
    """(verts, faces, ref_com) of the pot's closed surface in its reference frame."""
    from geometry.build import build_object
    from geometry.surface import fragment_surfaces

    geo = build_object("pot", resolution=POT_RESOLUTION_M)
    ps = geo.particles
    surf = fragment_surfaces(ps, np.zeros(len(ps), dtype=np.int64))
    com = (ps.centroid * ps.mass[:, None]).sum(0) / ps.mass.sum()
    return surf.verts, surf.faces, com


def grid_poses(n: int, com: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Poses of n pots on a grid (5 per row), each turned about y by an angle depending on t."""
    from rigid.quat import quat_from_axis_angle

    idx = np.arange(n)
    x = np.stack([(idx % 5 - 2) * POT_SPACING_M, np.full(n, com[1]), (idx // 5 - 1) * POT_SPACING_M], 1)
    q = np.stack([quat_from_axis_angle([0.3, 1.0, 0.1], 0.4 * t + 0.5 * i) for i in idx])
    return x, q, np.repeat(com[None], n, 0)


def build_scene(verts, faces, com, n_pots: int):
    from render.scene_data import MeshPart, RenderScene, body_palette

    pal = body_palette(n_pots)
    scene = RenderScene()
    scene.set_surfaces([MeshPart(verts, faces, body=b, colors=pal[b]) for b in range(n_pots)])
    scene.set_poses(*grid_poses(n_pots, com, 0.0))
    scene.update()
    return scene


def camera_for(scene, width: int, height: int):
    from render.camera import Camera

    cam = Camera(eye=[0.35, 0.45, 1.0], target=[0.0, 0.1, 0.0])
    lo, hi = scene.bounds()
    return cam.fit(lo - 0.05, hi + 0.05, aspect=width / height)


def time_frames(renderer, scene, cam, n_pots: int, com, frames: int, warm: int) -> tuple[list, list]:
    import taichi as ti

    totals, transforms = [], []
    for k in range(warm + frames):
        t0 = time.perf_counter()
        scene.set_poses(*grid_poses(n_pots, com, 0.05 * k))
        scene.update()
        ti.sync()  # kernels may run asynchronously (CUDA): time the transform itself
        t1 = time.perf_counter()
        img = renderer.render(scene, cam)
        t2 = time.perf_counter()
        if k >= warm:
            totals.append(t2 - t0)
            transforms.append(t1 - t0)
        del img
    return totals, transforms


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer frames, skip the largest case at 1280x720")
    ap.add_argument("--arch", default="cpu", choices=["cpu", "cuda", "auto"])
    ap.add_argument("--precision", default="f32", choices=["f32", "f64"])
    ap.add_argument("--threads", type=int, default=1, help="CPU threads (default 1)")
    ap.add_argument("--renderers", default="raster,ggui", help="comma list of raster, ggui")
    args = ap.parse_args(argv)

    os.environ.setdefault("TI_LOG_LEVEL", "warn")
    from core.runtime import init_taichi

    info = init_taichi(args.arch, args.precision, args.threads)
    from render.ggui import vulkan_status
    from render.select import make_renderer

    frames, warm = (5, 2) if args.quick else (20, 3)
    t = time.perf_counter()
    verts, faces, com = pot_surface()
    print(f"# pot surface: {len(faces)} triangles, {len(verts)} vertices (built in {time.perf_counter() - t:.1f} s)")
    print(f"# taichi arch={info.arch} precision={info.precision} threads={info.threads} device={info.device}")
    ok, why = vulkan_status()
    print(f"# vulkan: {'yes' if ok else 'no'} ({why})")
    kinds = [k.strip() for k in args.renderers.split(",") if k.strip()]
    if "ggui" in kinds and not ok:
        kinds.remove("ggui")
        print("# ggui skipped: Vulkan unavailable")
    cases = [("pot", 1), ("2 pots", 2), ("pots (13)", 13)]
    print(f"# frames per case: {frames} after {warm} warm-up; times in ms per frame (transform + render)")
    print(f"{'case':<10} {'triangles':>9} {'size':>9} {'renderer':>8} {'mean':>8} {'median':>8} {'transform':>9}")
    for name, n_pots in cases:
        scene = build_scene(verts, faces, com, n_pots)
        for width, height in SIZES:
            if args.quick and n_pots == 13 and width > 640:
                continue
            cam = camera_for(scene, width, height)
            for kind in kinds:
                r = make_renderer(kind, width, height)
                try:
                    tot, tra = time_frames(r, scene, cam, n_pots, com, frames, warm)
                finally:
                    r.release()
                print(f"{name:<10} {scene.n_tris:>9} {width:>4}x{height:<4} {kind:>8} "
                      f"{1e3 * statistics.mean(tot):>8.1f} {1e3 * statistics.median(tot):>8.1f} "
                      f"{1e3 * statistics.median(tra):>9.2f}", flush=True)
        scene.release()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
