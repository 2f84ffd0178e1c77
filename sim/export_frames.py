"""Per-frame exports on request (DESIGN.md section 7): fragment meshes (OBJ/PLY) and a VTU series.

`meshes/frame_00000.obj|ply`: every body's closed fragment surface moved to its pose, in one file.
`vtu/particles_00000.vtu` + `vtu/particles.pvd`: alive particles at their world positions with
body id, kind (0 physical, 1 subdivided), mass and volume, for ParaView. Atomic like every output.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from core.output import atomic_write_text, temporary_beside


def body_frames(world) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per body: rotation R (B, 3, 3), position x (B, 3) m, reference centre of mass (B, 3) m; a body
    maps a reference point X to R (X - ref_com) + x."""
    from rigid.quat import quat_to_matrix

    st = world.rigid.body_state()
    nb = world.rigid.n_bodies
    com = np.array([world.rigid.body_ref_com(b) for b in range(nb)]).reshape(nb, 3)
    return quat_to_matrix(st.q).reshape(nb, 3, 3), np.asarray(st.x, dtype=np.float64).reshape(nb, 3), com


def world_positions(world, points: np.ndarray, body: np.ndarray) -> np.ndarray:
    """Reference-frame points of the given bodies at the bodies' current poses (m)."""
    if "rigid" not in world.stages:
        return points
    rot, x, com = body_frames(world)
    return np.einsum("nij,nj->ni", rot[body], points - com[body]) + x[body]


def _surfaces(world):
    cache = getattr(world, "_export_surface", None)
    if cache is None or cache[0] != world.surface_version:
        from render.session import world_surfaces

        cache = (world.surface_version, world_surfaces(world))
        world._export_surface = cache
    return cache[1]


def fragment_mesh(world) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fragment surfaces at the bodies' current poses: vertices (V, 3) m world, triangles (F, 3)
    int, body of each vertex (V,)."""
    mesh = _surfaces(world)
    return world_positions(world, mesh.verts, mesh.vert_label), mesh.faces, mesh.vert_label


def particle_positions(world, ids: np.ndarray) -> np.ndarray:
    """(len(ids), 3) m: world positions of particles `ids` (elastic particles where they moved, a
    body's particles at its pose, shattered ones where the debris effect carries them; NaN for a
    particle that left the simulation)."""
    ps = world.particles
    if "elastic" in world.stages:
        return world.elastic.positions()[ids]
    if "rigid" not in world.stages:
        return ps.centroid[ids]
    x = np.full((len(ids), 3), np.nan)
    on = ps.body[ids] >= 0
    x[on] = world_positions(world, ps.centroid[ids[on]], ps.body[ids[on]])
    if "debris" in world.stages and world.debris.count and (~on).any():
        st = world.debris.state()
        where = np.full(len(ps), -1, dtype=np.int64)
        where[st["particle"]] = np.arange(len(st["particle"]))
        slot = where[ids[~on]]
        x[np.flatnonzero(~on)[slot >= 0]] = st["x"][slot[slot >= 0]]
    return x


def write_particles_vtu(world, path: Path) -> Path:
    """The live particles as a VTU point cloud (meshio; body, kind, mass, volume per point), written
    to a temporary name and renamed."""
    import meshio

    ps = world.particles
    ids = np.flatnonzero(ps.alive)
    x = particle_positions(world, ids)
    keep = np.all(np.isfinite(x), axis=1)
    ids, x = ids[keep], x[keep]
    m = meshio.Mesh(x, [("vertex", np.arange(len(ids)).reshape(-1, 1))], point_data=dict(
        body=ps.body[ids].astype(np.int32), kind=ps.kind[ids].astype(np.int32),
        mass=ps.mass[ids], volume=ps.volume[ids]))
    path = Path(path)
    tmp = temporary_beside(path, ".vtu")
    meshio.write(tmp, m)
    os.replace(tmp, path)
    return path


def write_frame_exports(world, out: Path, frame: int, meshes: str, vtu: bool) -> None:
    out = Path(out)
    if meshes != "none" and "rigid" in world.stages:
        from geometry.export import write_mesh

        verts, faces, _ = fragment_mesh(world)
        (out / "meshes").mkdir(exist_ok=True)
        write_mesh(out / "meshes" / f"frame_{frame:05d}.{meshes}", verts, faces)
    if vtu:
        folder = out / "vtu"
        folder.mkdir(exist_ok=True)
        write_particles_vtu(world, folder / f"particles_{frame:05d}.vtu")
        steps = sorted(folder.glob("particles_*.vtu"))
        dt = world.dt_frame
        entries = "\n".join(
            f'    <DataSet timestep="{int(p.stem.split("_")[1]) * dt:.6g}" file="{p.name}"/>' for p in steps)
        atomic_write_text(folder / "particles.pvd", '<?xml version="1.0"?>\n<VTKFile type="Collection" '
                          f'version="0.1">\n  <Collection>\n{entries}\n  </Collection>\n</VTKFile>\n')
