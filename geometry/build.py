"""From a shape description or a mesh file to tets, physical particles and boundary particles.

The one entry point the World and `main.py check` use for Sect. 5.1 and 5.3:
`build_object(source, resolution, ...)` returns an `ObjectGeometry`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from core.errors import ConfigError
from geometry.boundary import DEFAULT_GROUP_SIZE, BoundaryParticles, build_boundary_particles
from geometry.mesh_io import SURFACE_EXTENSIONS, TET_EXTENSIONS, MeshSolid, load_surface_mesh, load_tet_mesh
from geometry.particles import ParticleSet, build_particles
from geometry.shapes import SHAPES, lathe
from geometry.tetmesh import TetMesh, quality_report
from geometry.tetrahedralize import tetrahedralize

# Named objects for `main.py check NAME` and scenes: the paper's pot (Fig. 7, about 6k tets).
NAMED_SHAPES = {
    "pot": ("lathe", dict(profile=[[0.05, 0.0], [0.09, 0.08], [0.06, 0.2]], thickness=0.008), 0.01),
    "pane": ("pane", dict(size=[0.4, 0.4, 0.008]), 0.012),
    "sphere": ("sphere", dict(radius=0.1), 0.01),
    "box": ("box", dict(size=[0.2, 0.1, 0.05]), 0.01),
    "wire": ("wire", dict(radius=0.004, length=0.4), 0.003),
    "taichi": ("taichi", dict(radius=0.1, height=0.02), 0.008),
    "pet": ("figurine", dict(size=0.2), 0.01),
}


@dataclass
class ObjectGeometry:
    """Everything Sect. 5.1 and 5.3 produce for one object."""

    mesh: TetMesh
    particles: ParticleSet
    boundary: BoundaryParticles | None  # None where the caller builds its bodies' spheres itself (the World)
    report: dict  # quality and counts (the paper's Table 1 columns among them)
    thickness: float  # m: the object's thickness B (Eq. 11)


def make_shape(kind: str, params: dict, key_path: str = "shape"):
    """A procedural shape from its type name and parameters (lengths in metres)."""
    if kind not in SHAPES:
        raise ConfigError(f"{key_path}.type", kind, "one of " + ", ".join(sorted(SHAPES)))
    try:
        return SHAPES[kind](**params)
    except TypeError as exc:
        raise ConfigError(key_path, params, f"parameters of '{kind}': {exc}") from None


def build_object(
    source: str,
    resolution: float | None = None,
    density: float | np.ndarray = 1000.0,
    units: str | None = None,
    repair: bool = False,
    seed: int = 0,
    group_size: int = DEFAULT_GROUP_SIZE,
    body: int = 0,
    shape_params: dict | None = None,
    layer_axis=None,
    boundary: bool = True,
) -> ObjectGeometry:
    """Build an object from a named shape ('pot', 'pane', ...), a shape type with `shape_params`,
    a surface mesh file (tetrahedralized at `resolution`) or a tet mesh file (used as is); its
    boundary spheres unless `boundary` is False (the World makes each body's own, rigid/bodies.py)."""
    tet_report: dict = {}
    repairs: list[str] = []
    ext = os.path.splitext(source)[1].lower()
    if ext in TET_EXTENSIONS:
        mesh, repairs = load_tet_mesh(source, units, repair)
        thickness = float(np.ptp(mesh.verts, axis=0).min())
    else:
        if ext in SURFACE_EXTENSIONS:
            surface = load_surface_mesh(source, units, repair)
            repairs = surface.repairs
            shape = MeshSolid(surface)
            if resolution is None:
                raise ConfigError("resolution", None, "a tet size > 0 m for a surface mesh", source=source)
        elif shape_params is not None:
            shape = make_shape(source, shape_params)
        elif source in NAMED_SHAPES:
            kind, params, default_res = NAMED_SHAPES[source]
            shape = make_shape(kind, params)
            resolution = resolution or default_res
        else:
            raise ConfigError(
                "object",
                source,
                "a named shape (" + ", ".join(NAMED_SHAPES) + "), a shape type with parameters, or a mesh "
                "file (" + ", ".join(SURFACE_EXTENSIONS + TET_EXTENSIONS) + ")",
            )
        if resolution is None:
            raise ConfigError("resolution", None, "a tet size > 0 m")
        mesh, tet_report = tetrahedralize(shape, resolution, seed=seed, layer_axis=layer_axis)
        thickness = shape.thickness()
    particles = build_particles(mesh, density, body=body)
    report = quality_report(mesh) if not tet_report else tet_report
    report.update(
        physical_particles=len(particles),
        surface_particles=int(particles.surface.sum()),
        links=int((particles.links >= 0).sum() // 2),
        mass_kg=float(particles.mass.sum()),
        thickness_m=thickness,
        repairs=repairs,
    )
    spheres = None
    if boundary:
        spheres = build_boundary_particles(
            particles.centroid, particles.radius, particles.mass, particles.body, particles.surface, group_size,
            rest_verts=particles.rest_verts, free_faces=particles.links < 0,
        )
        report.update(boundary_particles=len(spheres), boundary_group_size=group_size)
    return ObjectGeometry(mesh, particles, spheres, report, thickness)


__all__ = ["NAMED_SHAPES", "ObjectGeometry", "build_object", "make_shape", "lathe"]
