"""Mesh input with validation before anything else (Sect. 5.1 starts from a surface or a tet mesh).

Surface meshes (OBJ, STL, PLY, GLB, OFF) are read with trimesh, tetrahedral meshes (Gmsh .msh,
VTK .vtk/.vtu, Medit .mesh) with meshio. The caller declares the file's length unit; coordinates
are converted to metres. Every problem raises `MeshError` naming the file, the problem and a count
or first index. Repairs happen only with `repair=True`, and each one is reported.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from core.errors import ConfigError, MeshError
from geometry.surface_checks import check_surface_overlap
from geometry.tetmesh import TetMesh, validate_tets

UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "um": 1e-6, "km": 1000.0, "in": 0.0254, "ft": 0.3048}
SURFACE_EXTENSIONS = (".obj", ".stl", ".ply", ".glb", ".gltf", ".off")
TET_EXTENSIONS = (".msh", ".vtk", ".vtu", ".mesh")


def unit_scale(units: str | None, source: str) -> float:
    """Metres per file unit; a mesh without declared units is refused."""
    if units is None:
        raise ConfigError("units", None, "one of " + ", ".join(UNITS), source=source)
    if units not in UNITS:
        raise ConfigError("units", units, "one of " + ", ".join(UNITS), source=source)
    return UNITS[units]


def _check_file(path: str) -> None:
    if not os.path.exists(path):
        raise MeshError(path, "file not found")
    if os.path.isdir(path):
        raise MeshError(path, "is a directory, not a mesh file")
    if os.path.getsize(path) == 0:
        raise MeshError(path, "file is empty")


@dataclass
class SurfaceMesh:
    """A validated closed, consistently oriented, outward-facing triangle mesh in metres."""

    vertices: np.ndarray  # (V, 3) m
    faces: np.ndarray  # (F, 3) int
    source: str
    repairs: list[str] = field(default_factory=list)

    def trimesh(self):
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, process=False)


def validate_surface(vertices: np.ndarray, faces: np.ndarray, source: str, repair: bool = False) -> SurfaceMesh:
    """Check (and, when asked, repair) a triangle mesh; see the module docstring for the rules."""
    import trimesh

    repairs: list[str] = []
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        raise MeshError(source, "no faces")
    if not np.all(np.isfinite(vertices)):
        bad = np.flatnonzero(~np.all(np.isfinite(vertices), axis=1))
        raise MeshError(source, "non-finite vertex coordinates", f"{bad.size} vertices, first index {bad[0]}")
    if faces.min() < 0 or faces.max() >= len(vertices):
        bad = np.flatnonzero((faces < 0).any(1) | (faces >= len(vertices)).any(1))
        raise MeshError(source, "face index out of range", f"{bad.size} faces, first index {bad[0]}")
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.merge_vertices()  # files often duplicate vertices per face; identity by position
    tri = mesh.triangles
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    scale = float(np.ptp(mesh.vertices, axis=0).max()) or 1.0
    degenerate = np.flatnonzero(area <= 1e-12 * scale * scale)
    if degenerate.size:
        if not repair:
            raise MeshError(
                source, "degenerate (zero-area) faces", f"{degenerate.size} faces, first index {degenerate[0]}"
            )
        keep = np.ones(len(mesh.faces), dtype=bool)
        keep[degenerate] = False
        mesh.update_faces(keep)
        mesh.remove_unreferenced_vertices()
        repairs.append(f"removed {degenerate.size} zero-area faces")
    # edge use: every undirected edge must be shared by exactly two faces
    edges = np.sort(mesh.edges, axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    nonmanifold = int((counts > 2).sum())
    if nonmanifold:
        raise MeshError(source, "non-manifold edges", f"{nonmanifold} edges shared by more than two faces")
    boundary = int((counts == 1).sum())
    if boundary:
        if not repair:
            raise MeshError(source, "open surface (not watertight)", f"{boundary} boundary edges")
        trimesh.repair.fill_holes(mesh)
        edges = np.sort(mesh.edges, axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        if (counts == 1).any():
            raise MeshError(source, "open surface that hole filling could not close", f"{boundary} boundary edges")
        repairs.append(f"filled holes bounded by {boundary} edges")
    if not mesh.is_winding_consistent:
        if not repair:
            raise MeshError(source, "mixed face orientation (inconsistent winding)", f"{len(mesh.faces)} faces")
        trimesh.repair.fix_winding(mesh)
        repairs.append("made face winding consistent")
    if mesh.volume < 0:
        if not repair:
            raise MeshError(source, "inside-out surface (normals point inwards)", f"volume {mesh.volume:.3g}")
        mesh.invert()
        repairs.append("inverted the inside-out surface")
    check_surface_overlap(np.asarray(mesh.vertices), np.asarray(mesh.faces), source)
    return SurfaceMesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), source, repairs)


def load_surface_mesh(path: str, units: str | None, repair: bool = False) -> SurfaceMesh:
    """Read and validate a surface mesh; `units` is the file's length unit (see UNITS)."""
    import trimesh

    path = str(path)
    scale = unit_scale(units, path)
    _check_file(path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in SURFACE_EXTENSIONS:
        raise MeshError(path, f"unsupported surface format '{ext}'", "use " + ", ".join(SURFACE_EXTENSIONS))
    try:
        loaded = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types for corrupt files
        raise MeshError(path, "unreadable mesh file", f"{type(exc).__name__}: {exc}") from None
    vertices = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=np.float64)
    faces = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), dtype=np.int64)
    if len(vertices) == 0 or len(faces) == 0:
        raise MeshError(path, "no faces", "the file holds no triangles: empty, corrupt or a point cloud")
    return validate_surface(vertices * scale, faces, path, repair)


def load_tet_mesh(path: str, units: str | None, repair: bool = False) -> tuple[TetMesh, list[str]]:
    """Read and validate a tetrahedral mesh (Gmsh, VTK/VTU, Medit) in metres."""
    import meshio

    path = str(path)
    scale = unit_scale(units, path)
    _check_file(path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in TET_EXTENSIONS:
        raise MeshError(path, f"unsupported tet mesh format '{ext}'", "use " + ", ".join(TET_EXTENSIONS))
    try:
        m = meshio.read(path)
    except Exception as exc:  # meshio raises many types for corrupt files
        raise MeshError(path, "unreadable tet mesh file", f"{type(exc).__name__}: {exc}") from None
    blocks = [c.data for c in m.cells if c.type == "tetra"]
    if not blocks:
        raise MeshError(path, "no tetrahedra in the file", "cell types: " + ", ".join(c.type for c in m.cells))
    mesh = TetMesh(np.asarray(m.points, dtype=np.float64)[:, :3] * scale, np.concatenate(blocks), source=path)
    repairs = validate_tets(mesh, repair=repair)
    return mesh, repairs


def trimesh_sample(mesh, count: int, rng: np.random.Generator):
    """`count` uniformly distributed surface points of a trimesh (area-weighted, seeded)."""
    area = mesh.area_faces
    face = rng.choice(len(area), size=count, p=area / area.sum())
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    tri = mesh.triangles[face]
    return tri[:, 0] + u[:, None] * (tri[:, 1] - tri[:, 0]) + v[:, None] * (tri[:, 2] - tri[:, 0]), face


def _thin(points: np.ndarray, spacing: float) -> np.ndarray:
    """Drop points closer than `spacing` to an earlier kept point (earlier points win)."""
    from scipy.spatial import cKDTree

    keep = np.ones(len(points), dtype=bool)
    pairs = cKDTree(points).query_pairs(spacing, output_type="ndarray")
    if len(pairs):
        pairs = np.sort(pairs, axis=1)
        pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
        for i, j in pairs.tolist():  # build-time only; sequential so earlier points win
            if keep[i]:
                keep[j] = False
    return points[keep]


class MeshSolid:
    """A validated surface mesh seen as a solid (geometry.shapes.Shape API).

    Netgen meshes its triangles (`reference_mesh`); `thickness` / `thinnest_wall` measure its walls.
    `sdf` and `surface_samples` serve only the layered Delaunay sampler: inside test by ray parity
    (trimesh, rtree), distance approximated by the nearest of dense surface samples, built on first use.
    """

    regions = 1

    def __init__(self, surface: SurfaceMesh, name: str | None = None) -> None:
        self.surface = surface
        self.name = name or os.path.basename(surface.source)
        self._mesh = surface.trimesh()
        self._tree = None  # cKDTree of dense surface samples, built by the first `sdf`
        self._wall = None  # (S,) m: sampled wall thicknesses, measured on first use

    def sdf(self, points: np.ndarray) -> np.ndarray:
        if self._tree is None:
            from scipy.spatial import cKDTree

            dense = self._mesh.sample(max(20000, len(self._mesh.faces) * 4), return_index=False, seed=0)
            self._tree = cKDTree(np.concatenate([self._mesh.vertices, dense]))
        d, _ = self._tree.query(points)
        inside = self._mesh.contains(points)
        return np.where(inside, -d, d)

    def surface_samples(self, h: float) -> np.ndarray:
        """Corners, then points along sharp edges, then points on faces, at least 0.6 h apart.

        Edge and face points are placed at seeded random positions: the regular grids a
        subdivision would give are co-circular, and Delaunay turns those into flat tets.
        """

        rng = np.random.default_rng(0)
        mesh = self._mesh
        sharp = mesh.face_adjacency_angles > np.radians(30.0)
        edges = mesh.face_adjacency_edges[sharp]
        corners = mesh.vertices[np.unique(edges)] if len(edges) else mesh.vertices[:0]
        a, b = mesh.vertices[edges[:, 0]], mesh.vertices[edges[:, 1]]
        length = np.linalg.norm(b - a, axis=1)
        count = np.maximum(0, np.ceil(length / h).astype(int) - 1)
        owner = np.repeat(np.arange(len(edges)), count)
        rank = np.arange(len(owner)) - np.repeat(np.cumsum(count) - count, count)
        t = (rank + 0.5 + rng.uniform(-0.3, 0.3, len(owner))) / np.repeat(count, count)
        along = a[owner] + t[:, None] * (b - a)[owner]
        n_face = int(np.ceil(mesh.area / (0.6 * h * h)))
        faces, _ = trimesh_sample(mesh, n_face, rng)
        candidates = np.concatenate([corners, along, faces])
        return _thin(candidates, 0.6 * h)

    def bounds(self):
        return self._mesh.bounds[0].copy(), self._mesh.bounds[1].copy()

    def region(self, points: np.ndarray) -> np.ndarray:
        return np.zeros(len(points), dtype=np.int32)

    def reference_mesh(self):
        return self._mesh

    def thickness(self) -> float:
        """m: the median wall thickness (Eq. 11's B): a shell's wall, a solid's size."""
        return float(np.median(self._walls()))

    def thinnest_wall(self) -> float:
        """m: the thinnest part (5th percentile of the sampled wall thickness)."""
        return float(np.percentile(self._walls(), 5))

    def _walls(self) -> np.ndarray:
        if self._wall is None:
            from geometry.surface_checks import wall_thickness

            walls = wall_thickness(self._mesh.vertices, self._mesh.faces)
            lo, hi = self.bounds()
            self._wall = walls if len(walls) else np.array([float((hi - lo).min())])
        return self._wall
