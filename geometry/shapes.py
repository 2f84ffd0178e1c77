"""Procedural solids in metres: a signed distance, surface samples and a reference surface mesh.

Each shape gives the tetrahedralizer (geometry.tetrahedralize, Sect. 5.1) what it needs:
- `sdf(points)`: signed distance (negative inside), exact or a bound that is exact on the surface;
- `surface_samples(h)`: points on the surface about h apart, with sharp edges and corners sampled
  exactly, so the Delaunay hull of the samples reproduces creases;
- `bounds()`: an axis-aligned box containing the solid;
- `region(points)`: a region id per point (material slot; only the Tai Chi disk has two);
- `reference_mesh()`: a fine trimesh of the surface, the reference volume in tests.

Shapes of revolution (sphere, disk, rod, lathe/pot) share one implementation: a closed 2D polygon
in the (r, y) half-plane revolved about the y axis.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from core.errors import ConfigError


def _segment_distance_2d(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from points p (P, 2) to every segment a-b (S, 2): (P, S)."""
    ab = b - a
    ap = p[:, None, :] - a[None, :, :]
    t = np.clip((ap * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0.0, 1.0)
    d = ap - t[..., None] * ab
    return np.sqrt((d * d).sum(-1))


def _polygon_sdf_2d(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Signed distance to a closed simple polygon (V, 2): negative inside (even-odd rule)."""
    a, b = poly, np.roll(poly, -1, axis=0)
    out = np.empty(len(p))
    for s in range(0, len(p), 20000):  # chunks bound memory (P x S)
        q = p[s : s + 20000]
        dist = _segment_distance_2d(q, a, b).min(1)
        y = q[:, 1:2]
        crosses = ((a[None, :, 1] > y) != (b[None, :, 1] > y)) & (
            q[:, 0:1]
            < (b[None, :, 0] - a[None, :, 0]) * (y - a[None, :, 1]) / (b[None, :, 1] - a[None, :, 1] + 1e-300)
            + a[None, :, 0]
        )
        inside = crosses.sum(1) % 2 == 1
        out[s : s + 20000] = np.where(inside, -dist, dist)
    return out


def _sample_polyline(poly: np.ndarray, h: float, closed: bool = True) -> np.ndarray:
    """Points along a polyline about h apart, every vertex included exactly."""
    pts = []
    n = len(poly)
    for i in range(n if closed else n - 1):
        a, b = poly[i], poly[(i + 1) % n]
        k = max(1, int(np.ceil(np.linalg.norm(b - a) / h)))
        t = np.arange(k) / k
        pts.append(a + t[:, None] * (b - a))
    if not closed:
        pts.append(poly[-1:])
    return np.concatenate(pts)


class Shape(ABC):
    """Base of procedural solids; subclasses define the geometry."""

    name = "shape"
    regions = 1  # number of material regions

    @abstractmethod
    def sdf(self, points: np.ndarray) -> np.ndarray:
        """(P,) m: signed distance, negative inside."""

    @abstractmethod
    def surface_samples(self, h: float) -> np.ndarray:
        """(S, 3) m: surface points about h apart, creases sampled exactly."""

    @abstractmethod
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) m: an axis-aligned box containing the solid."""

    def region(self, points: np.ndarray) -> np.ndarray:
        return np.zeros(len(points), dtype=np.int32)

    @abstractmethod
    def reference_mesh(self):
        """A fine trimesh of the surface (the reference volume in tests)."""

    def thickness(self) -> float:
        """Smallest wall thickness (m): the object's thickness B in Eq. 11."""
        lo, hi = self.bounds()
        return float((hi - lo).min())


@dataclass
class Box(Shape):
    """An axis-aligned box centred on the origin; `size` (m) per axis. A pane is a thin box."""

    size: tuple[float, float, float]
    name: str = "box"

    def __post_init__(self) -> None:
        self.half = 0.5 * np.asarray(self.size, dtype=np.float64)
        for axis, s in zip("xyz", self.size):
            if not np.isfinite(s) or s <= 0:
                raise ConfigError(f"shape.size.{axis}", s, "a finite length > 0 m")

    def sdf(self, points: np.ndarray) -> np.ndarray:
        q = np.abs(points) - self.half
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
        inside = np.minimum(q.max(1), 0.0)
        return outside + inside

    def surface_samples(self, h: float) -> np.ndarray:
        counts = [max(2, int(np.ceil(2 * hh / h)) + 1) for hh in self.half]
        axes = [np.linspace(-hh, hh, n) for hh, n in zip(self.half, counts)]
        g = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        on_face = np.isclose(np.abs(g), self.half)
        g = g[on_face.any(1)]
        on_face = on_face[on_face.any(1)]
        # Move samples within their faces (never off them, edges and corners only along free axes) by
        # a fixed pseudo-random fraction of the spacing: a regular grid is co-circular everywhere and
        # Delaunay would make flat tets across the edges.
        step = np.array([2 * hh / (n - 1) for hh, n in zip(self.half, counts)])
        rng = np.random.default_rng(12345)
        shift = rng.uniform(-0.15, 0.15, g.shape) * step
        interior_of_axis = np.abs(g) < self.half - 0.5 * step
        return g + np.where(~on_face & interior_of_axis, shift, 0.0)

    def bounds(self):
        return -self.half, self.half.copy()

    def reference_mesh(self):
        import trimesh

        return trimesh.creation.box(extents=2 * self.half)

    def thickness(self) -> float:
        return float(2 * self.half.min())


@dataclass
class Sphere(Shape):
    radius: float
    name: str = "sphere"

    def __post_init__(self) -> None:
        if not np.isfinite(self.radius) or self.radius <= 0:
            raise ConfigError("shape.radius", self.radius, "a finite length > 0 m")

    def sdf(self, points: np.ndarray) -> np.ndarray:
        return np.linalg.norm(points, axis=1) - self.radius

    def surface_samples(self, h: float) -> np.ndarray:
        # Fibonacci sphere: near-uniform spacing h on the surface
        n = max(12, int(np.ceil(4 * np.pi * self.radius**2 / (h * h * np.sqrt(3) / 2))))
        i = np.arange(n) + 0.5
        phi = np.arccos(1 - 2 * i / n)
        theta = np.pi * (1 + 5**0.5) * i
        return self.radius * np.stack(
            [np.cos(theta) * np.sin(phi), np.cos(phi), np.sin(theta) * np.sin(phi)], 1
        )

    def bounds(self):
        r = np.full(3, self.radius)
        return -r, r

    def reference_mesh(self):
        import trimesh

        return trimesh.creation.icosphere(subdivisions=6, radius=self.radius)

    def thickness(self) -> float:
        return 2 * self.radius


@dataclass
class Revolved(Shape):
    """A solid of revolution: the closed polygon `section` in the (r >= 0, y) half-plane about y."""

    section: np.ndarray  # (V, 2) m: closed polygon, counter-clockwise, r >= 0
    name: str = "revolved"
    wall: float | None = None  # m: wall thickness when the solid is a shell (Eq. 11's B)

    def __post_init__(self) -> None:
        self.section = np.asarray(self.section, dtype=np.float64)
        if self.section.ndim != 2 or self.section.shape[1] != 2 or len(self.section) < 3:
            raise ConfigError("shape.profile", self.section.tolist(), "a polygon of >= 3 (r, y) points")
        if not np.all(np.isfinite(self.section)) or self.section[:, 0].min() < 0:
            raise ConfigError("shape.profile", self.section.tolist(), "finite points with r >= 0")
        area2 = np.sum(
            self.section[:, 0] * np.roll(self.section[:, 1], -1) - np.roll(self.section[:, 0], -1) * self.section[:, 1]
        )
        if area2 < 0:
            self.section = self.section[::-1].copy()
        elif area2 == 0:
            raise ConfigError("shape.profile", self.section.tolist(), "a polygon with non-zero area")

    def sdf(self, points: np.ndarray) -> np.ndarray:
        r = np.hypot(points[:, 0], points[:, 2])
        return _polygon_sdf_2d(np.stack([r, points[:, 1]], 1), self.section)

    def surface_samples(self, h: float) -> np.ndarray:
        ring = _sample_polyline(self.section, h)
        out = []
        golden = 0.5 * (np.sqrt(5.0) - 1.0)
        for k, (r, y) in enumerate(ring):
            n = 1 if r < 1e-12 * h else max(6, int(np.ceil(2 * np.pi * r / h)))
            # a golden-ratio twist per ring avoids the co-circular rectangles of aligned rings,
            # which would give Delaunay flat (zero-volume) tets
            t = 2 * np.pi * (np.arange(n) + (k * golden) % 1.0) / n
            out.append(np.stack([r * np.cos(t), np.full(n, y), r * np.sin(t)], 1))
        return np.unique(np.concatenate(out), axis=0)

    def bounds(self):
        rmax = self.section[:, 0].max()
        return (
            np.array([-rmax, self.section[:, 1].min(), -rmax]),
            np.array([rmax, self.section[:, 1].max(), rmax]),
        )

    def exact_volume(self) -> float:
        """Pappus: 2 pi x (section area) x (centroid radius), exact for the polygon."""
        x, y = self.section[:, 0], self.section[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cross = x * yn - xn * y
        area = cross.sum() / 2
        cx = ((x + xn) * cross).sum() / (6 * area)
        return float(2 * np.pi * area * cx)

    def reference_mesh(self, sections: int = 512):
        import trimesh

        ring = _sample_polyline(self.section, np.inf)
        ring = np.vstack([ring, ring[:1]])
        mesh = trimesh.creation.revolve(ring, sections=sections)  # trimesh revolves about z
        # map trimesh's (x, y, z=axis) to ours (x, y=axis, z)
        mesh.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
        return mesh

    def thickness(self) -> float:
        if self.wall is not None:
            return self.wall
        return super().thickness()


def disk(radius: float, height: float, name: str = "disk") -> Revolved:
    """A flat cylinder about y (m)."""
    _positive("shape.radius", radius)
    _positive("shape.height", height)
    h = 0.5 * height
    return Revolved(np.array([[0, -h], [radius, -h], [radius, h], [0, h]]), name=name, wall=height)


def rod(radius: float, length: float, name: str = "rod") -> Revolved:
    """A wire or rod of circular section along y (m)."""
    _positive("shape.radius", radius)
    _positive("shape.length", length)
    h = 0.5 * length
    return Revolved(np.array([[0, -h], [radius, -h], [radius, h], [0, h]]), name=name, wall=2 * radius)


def lathe(profile, thickness: float, name: str = "lathe") -> Revolved:
    """A pot or vase: the outer profile [(r, y), ...] from the base up, a wall of `thickness` (m).

    The wall's inner surface is the outer profile moved inwards by `thickness` along r; the base is
    a disc of `thickness` from the first profile point inwards to the axis. The profile must rise
    (y strictly increasing) and stay wider than the wall.
    """
    p = np.asarray(profile, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < 2:
        raise ConfigError("shape.profile", np.asarray(profile).tolist(), "a list of >= 2 [r, y] points (m)")
    if not np.all(np.isfinite(p)):
        raise ConfigError("shape.profile", p.tolist(), "finite numbers")
    _positive("shape.thickness", thickness)
    if np.any(np.diff(p[:, 1]) <= 0):
        raise ConfigError("shape.profile", p.tolist(), "points with strictly increasing y")
    if p[:, 0].min() <= thickness:
        raise ConfigError("shape.profile", p.tolist(), f"every radius > thickness = {thickness} m")
    if p[-1, 1] - p[0, 1] <= 2 * thickness:
        raise ConfigError("shape.profile", p.tolist(), f"a height > 2 x thickness = {2 * thickness} m")
    y0 = p[0, 1]
    inner_y = p[:, 1].copy()
    inner_r = p[:, 0] - thickness
    # inner surface starts at the top of the base
    keep = inner_y > y0 + thickness
    r_at_base = np.interp(y0 + thickness, p[:, 1], p[:, 0]) - thickness
    inner = np.vstack([[r_at_base, y0 + thickness], np.stack([inner_r[keep], inner_y[keep]], 1)])
    section = np.vstack([[[0.0, y0]], p, inner[::-1], [[0.0, y0 + thickness]]])
    return Revolved(section, name=name, wall=thickness)


@dataclass
class TaiChiDisk(Shape):
    """A disk in the x-z plane (axis y) split into the two regions of the Tai Chi symbol (Fig. 12).

    Region 1 is the 'yin' half: x < 0 outside the upper small circle, plus the lower small circle;
    region 0 is the rest. Both regions are one solid; tets take the region of their centroid.
    """

    radius: float
    height: float
    name: str = "taichi"
    regions: int = 2
    _disk: Revolved = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._disk = disk(self.radius, self.height, self.name)

    def sdf(self, points):
        return self._disk.sdf(points)

    def surface_samples(self, h):
        return self._disk.surface_samples(h)

    def bounds(self):
        return self._disk.bounds()

    def thickness(self) -> float:
        return self.height

    def region(self, points: np.ndarray) -> np.ndarray:
        x, z = points[:, 0], points[:, 2]
        r2 = 0.5 * self.radius
        in_upper = x**2 + (z - r2) ** 2 < r2**2
        in_lower = x**2 + (z + r2) ** 2 < r2**2
        yin = ((x < 0) & ~in_upper) | in_lower
        return yin.astype(np.int32)

    def reference_mesh(self):
        return self._disk.reference_mesh()


@dataclass
class Figurine(Shape):
    """A small sitting animal (the paper's 'pet', Fig. 11): a union of ellipsoids, `size` m tall."""

    size: float = 0.2
    name: str = "pet"

    def __post_init__(self) -> None:
        _positive("shape.size", self.size)
        s = self.size
        # (centre, semi-axes) in metres, for a figure standing on y = 0 and facing +x
        self.parts = [
            ((0.00, 0.30, 0.00), (0.28, 0.22, 0.20)),  # body
            ((0.26, 0.62, 0.00), (0.16, 0.15, 0.15)),  # head
            ((0.40, 0.58, 0.00), (0.08, 0.05, 0.06)),  # snout
            ((0.22, 0.80, 0.09), (0.04, 0.10, 0.04)),  # ear
            ((0.22, 0.80, -0.09), (0.04, 0.10, 0.04)),  # ear
            ((0.16, 0.09, 0.11), (0.07, 0.09, 0.07)),  # front legs
            ((0.16, 0.09, -0.11), (0.07, 0.09, 0.07)),
            ((-0.16, 0.10, 0.12), (0.10, 0.10, 0.08)),  # hind legs
            ((-0.16, 0.10, -0.12), (0.10, 0.10, 0.08)),
            ((-0.33, 0.28, 0.00), (0.14, 0.04, 0.04)),  # tail
        ]
        self.centres = np.array([c for c, _ in self.parts]) * s
        self.axes = np.array([a for _, a in self.parts]) * s

    def sdf(self, points: np.ndarray) -> np.ndarray:
        # ellipsoid distance bound |p/a| - 1 scaled by the smallest axis (exact on the surface)
        q = (points[:, None, :] - self.centres[None]) / self.axes[None]
        d = (np.linalg.norm(q, axis=2) - 1.0) * self.axes.min(1)[None]
        return d.min(1)

    def surface_samples(self, h: float) -> np.ndarray:
        from geometry.layered_delaunay import project_to_surface

        return project_to_surface(self, h)

    def bounds(self):
        return (self.centres - self.axes).min(0), (self.centres + self.axes).max(0)

    def thickness(self) -> float:
        return float(2 * self.axes.min())

    def reference_mesh(self):
        import trimesh

        parts = []
        for c, a in zip(self.centres, self.axes):
            m = trimesh.creation.icosphere(subdivisions=3)
            m.apply_scale(a)
            m.apply_translation(c)
            parts.append(m)
        return trimesh.util.concatenate(parts)


@dataclass
class Tetra(Shape):
    """A single regular tetrahedron of edge `size` (m) resting on y = 0: the teaching scenes' tet.

    Sampled at its four corners only, so any resolution >= the edge length gives exactly one tet.
    """

    size: float = 0.1
    name: str = "tet"

    def __post_init__(self) -> None:
        _positive("shape.size", self.size)
        a = self.size
        base = np.array([[0.0, 0.0, 0.0], [a, 0.0, 0.0], [0.5 * a, 0.0, np.sqrt(3) / 2 * a]])
        apex = np.array([[0.5 * a, np.sqrt(2.0 / 3.0) * a, np.sqrt(3) / 6 * a]])
        self.corners = np.vstack([base, apex]) - np.array([0.5 * a, 0.0, np.sqrt(3) / 6 * a])
        self._planes = []
        for k in range(4):
            tri = np.delete(self.corners, k, axis=0)
            n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
            n /= np.linalg.norm(n)
            if np.dot(n, self.corners[k] - tri[0]) > 0:
                n = -n
            self._planes.append((n, float(np.dot(n, tri[0]))))

    def sdf(self, points: np.ndarray) -> np.ndarray:
        # max over the four face planes: exact inside, a lower bound outside (enough for sampling)
        return np.max([points @ n - d for n, d in self._planes], axis=0)

    def surface_samples(self, h: float) -> np.ndarray:
        return self.corners.copy()

    def bounds(self):
        return self.corners.min(0), self.corners.max(0)

    def reference_mesh(self):
        import trimesh

        return trimesh.Trimesh(self.corners, [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]).convex_hull


def _positive(key: str, value: float) -> None:
    if not isinstance(value, (int, float)) or not np.isfinite(value) or value <= 0:
        raise ConfigError(key, value, "a finite length > 0 m")


SHAPES = {
    "box": lambda size, **kw: Box(tuple(size), **kw),
    "pane": lambda size, **kw: Box(tuple(size), name="pane", **kw),
    "sphere": lambda radius, **kw: Sphere(radius, **kw),
    "disk": disk,
    "rod": rod,
    "wire": lambda radius, length, **kw: rod(radius, length, name="wire", **kw),
    "lathe": lathe,
    "taichi": lambda radius, height, **kw: TaiChiDisk(radius, height, **kw),
    "figurine": lambda size=0.2, **kw: Figurine(size, **kw),
    "tet": lambda size=0.1, **kw: Tetra(size, **kw),
}
