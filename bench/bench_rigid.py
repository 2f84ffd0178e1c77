"""Rigid-world benchmarks (DESIGN.md promise 1: show what accuracy costs in time).

    .venv/bin/python bench/bench_rigid.py [--quick] [--arch cpu|cuda|auto] [--precision f32|f64]

Table 1: step time against boundary-sphere count (1k to 100k; --quick stops at 10k). The scene is a
pile of boxes (8 corner spheres each) dropped in columns onto a plane; after 0.5 s of falling and
piling, 0.25 s are timed (sleeping off, so every body is simulated).

Table 2: boundary sampling size n = 1, 4, 8 (paper Sect. 5.3): a tet-meshed box and a tet-meshed ball
rest on a plane with the boundary spheres of geometry.boundary.build_boundary_particles (group
size n). For each: spheres, collision time per step (broad + narrow phase), total step time, the
deepest sphere penetration, and the rest-height error: the lowest tet vertex of the resting body
minus the ground (0 for an exact contact surface; > 0: the spheres hold the mesh up).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

DT = 1.0 / 240.0


def bench_scaling(sizes: list[int]) -> None:
    from rigid.bodies import add_box_body
    from rigid.world import RigidConfig, RigidWorld

    print("\nTable 1: step time against boundary-sphere count (box pile, 8 spheres per box, dt = 1/240 s)")
    print(
        f"{'spheres':>8} {'bodies':>7} {'contacts':>9} {'ms/step':>9} {'ns/sphere':>10} {'broad':>7} "
        f"{'narrow':>7} {'solve':>7} {'correct':>8}"
    )
    world = RigidWorld(
        capacity_bodies=max(sizes) // 8 + 8,
        capacity_spheres=max(sizes) + 64,
        capacity_colliders=2,
        capacity_contacts=4 * max(sizes),
    )
    try:
        for n_sph in sizes:
            world.clear()
            world.config = RigidConfig(sleep_enabled=False)
            world.add_plane((0, 0, 0), (0, 1, 0))
            n_boxes = n_sph // 8
            cols = int(np.ceil(np.sqrt(n_boxes / 8)))  # columns of up to 8 boxes
            half, gap = 0.05, 0.13
            k = 0
            specs = []
            for layer in range(8):
                for i in range(cols):
                    for j in range(cols):
                        if k == n_boxes:
                            break
                        x = (i - cols / 2) * gap + 0.01 * (layer % 3)
                        z = (j - cols / 2) * gap + 0.01 * (layer % 2)
                        specs.append((x, 0.06 + layer * 0.12, z))
                        k += 1
            for x in specs:
                add_box_body(world, [half] * 3, 800.0, x=x, sphere_radius=0.012)
            for _ in range(120):
                world.step(DT)
            world.profile = {}
            steps = 60
            t0 = time.perf_counter()
            for _ in range(steps):
                world.step(DT)
            import taichi as ti

            ti.sync()
            ms = (time.perf_counter() - t0) / steps * 1e3
            prof = {key: val / steps * 1e3 for key, val in world.profile.items()}
            world.profile = None
            print(
                f"{world.n_spheres:>8} {world.n_bodies:>7} {world.n_contacts:>9} {ms:>9.2f} "
                f"{ms * 1e6 / world.n_spheres:>10.0f} {prof.get('broad_phase', 0):>7.2f} "
                f"{prof.get('narrow_phase', 0):>7.2f} {prof.get('solve_integrate', 0):>7.2f} "
                f"{prof.get('correct_restitute', 0):>8.2f}"
            )
    finally:
        world.release()
    print("(stage columns: ms per step, measured with a device sync between stages)")


def bench_sampling(sizes=(1, 4, 8)) -> None:
    from geometry.particles import build_particles
    from rigid.bodies import add_tet_body, ball_tetmesh, box_tetmesh
    from rigid.quat import quat_to_matrix
    from rigid.world import RigidConfig, RigidWorld

    print("\nTable 2: boundary sampling size n against collision cost and accuracy (body resting on a plane)")
    print(
        f"{'body':>14} {'n':>2} {'tets':>5} {'spheres':>8} {'collide ms':>11} {'step ms':>8} "
        f"{'max pen mm':>11} {'rest err mm':>12}"
    )
    shapes = [
        (
            "box 0.2 m",
            build_particles(box_tetmesh([0.1, 0.1, 0.1], (8, 8, 8), center=(0.0, 0.1, 0.0)), 1000.0),
        ),
        ("ball r=0.1 m", build_particles(ball_tetmesh(0.1, 6, 600, center=(0.0, 0.1, 0.0)), 1000.0)),
    ]
    world = RigidWorld(capacity_bodies=4, capacity_spheres=4096, capacity_colliders=2)
    try:
        for name, ps in shapes:
            for n in sizes:
                world.clear()
                world.config = RigidConfig(sleep_enabled=False)
                world.add_plane((0, 0, 0), (0, 1, 0))
                b = add_tet_body(world, ps, group_size=n)
                for _ in range(360):  # settle 1.5 s
                    world.step(DT)
                pen = 0.0
                world.profile = {}
                steps = 60
                t0 = time.perf_counter()
                for _ in range(steps):
                    world.step(DT)
                    ev = world.contact_events()
                    if len(ev):
                        pen = max(pen, float(-ev.separation.min()))
                elapsed = (time.perf_counter() - t0) / steps * 1e3
                prof = world.profile
                world.profile = None
                collide = (prof.get("broad_phase", 0) + prof.get("narrow_phase", 0)) / steps * 1e3
                st = world.body_state()
                verts = ps.rest_verts.reshape(-1, 3)
                yw = ((verts - world.body_ref_com(b)) @ quat_to_matrix(st.q[b]).T + st.x[b])[:, 1]
                print(
                    f"{name:>14} {n:>2} {len(ps):>5} {world.n_spheres:>8} {collide:>11.3f} {elapsed:>8.2f} "
                    f"{pen * 1e3:>11.4f} {yw.min() * 1e3:>12.3f}"
                )
    finally:
        world.release()
    print("(step ms includes reading the contact events back each step)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="stop the sphere-count table at 10k")
    ap.add_argument("--arch", default="cpu", choices=["cpu", "cuda", "auto"])
    ap.add_argument("--precision", default="f32", choices=["f32", "f64"])
    ap.add_argument("--threads", type=int, default=0, help="CPU threads (0 = Taichi's default)")
    args = ap.parse_args()
    from core.runtime import init_taichi

    info = init_taichi(arch=args.arch, precision=args.precision, threads=args.threads)
    print(
        f"rigid bench: arch={info.arch} precision={info.precision} threads={info.threads} "
        f"device={info.device}"
    )
    sizes = [1000, 3000, 10000] if args.quick else [1000, 3000, 10000, 30000, 100000]
    bench_scaling(sizes)
    bench_sampling()


if __name__ == "__main__":
    main()
