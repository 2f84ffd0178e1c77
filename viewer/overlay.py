"""What the viewer draws over the bodies: particles, links, kernel ellipsoids, crack discs, the
crack preview, and the surface colour modes (numpy geometry handed to a RenderScene; no window).

Colour modes (surfaces, and particles when they are shown):
  fragment  one palette colour per body (render.scene_data.body_palette), as headless runs;
  material  one colour per material id (MATERIAL_COLOURS), from the particle under each face;
  energy    the group strain energy U'_g (J; Eq. 8 summed over the group's members, capped by the
            impact's kinetic energy) of the most recent analysis, divided by the largest group's:
            blue (0) -> white (0.5) -> red (1);
  stress    lambda_max(T_g) / tensile strength of the most recent analysis (T_g: the group's mean
            tensile stress, the Rankine stress of Algorithm 1): blue (0) -> white (1: the group
            is at the threshold) -> red (>= 2).
Energy and stress are per GROUP (Algorithm 1 works per group), painted on the group's analysed
particles; everything else is grey. "Most recent analysis" = the preview, or the last strike.
A surface face takes the value of the nearest live particle of its body (reference frame).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from render.scene_data import MeshPart, body_palette, disc_outline
from render.session import SceneView, world_surfaces

COLOUR_MODES = ("fragment", "material", "energy", "stress")
MATERIAL_COLOURS = np.array([[0.85, 0.78, 0.62], [0.35, 0.55, 0.85], [0.85, 0.4, 0.35], [0.45, 0.75, 0.45],
                             [0.7, 0.5, 0.8], [0.75, 0.75, 0.75]])  # linear RGB per material id (cycled)
NO_DATA = (0.5, 0.5, 0.52)  # grey: no analysis value here
PHYSICAL_COLOUR = (0.92, 0.58, 0.22)
SUBDIVIDED_COLOUR = (0.25, 0.8, 0.92)
BOUNDARY_COLOUR = (0.35, 0.85, 0.4)
LINK_COLOUR = (0.6, 0.65, 0.85)
KERNEL_COLOUR = (0.5, 0.95, 0.75)
CRACK_COLOUR = (1.0, 0.85, 0.2)
CRACK_NORMAL_COLOUR = (1.0, 0.3, 0.25)
SHATTER_COLOUR = (0.95, 0.3, 0.9)
KERNEL_SAMPLES = 6  # particles near the cursor whose kernels are drawn
LOOP_SEGMENTS = 40  # segments per drawn circle / ellipse
NORMAL_ARROW = 0.2  # -: crack normal drawn at this fraction of r_outer
PREVIEW_RADIUS = 1.15  # -: preview spheres are this much larger than the particles (they poke through the surface)


def coolwarm(t) -> np.ndarray:
    """(..., 3) blue (t = 0) -> white (0.5) -> red (1) linear RGB; NaN -> NO_DATA grey."""
    t = np.asarray(t, dtype=np.float64)
    tc = np.clip(np.nan_to_num(t, nan=0.5), 0.0, 1.0)[..., None]
    blue, white, red = np.array([0.23, 0.3, 0.75]), np.array([0.93, 0.93, 0.93]), np.array([0.75, 0.1, 0.12])
    lo = blue + (white - blue) * (2.0 * tc)
    hi = white + (red - white) * (2.0 * tc - 1.0)
    out = np.where(tc < 0.5, lo, hi)
    return np.where(np.isnan(t)[..., None], np.array(NO_DATA), out)


class AnalysisValues:
    """Per-particle values of one analysis (group values painted on the analysed particles), kept
    valid when fracture events add subdivided children (a child takes its parent's value: the analysis
    runs on the physical particles, sim.fracture_stage.analysed_rows)."""

    def __init__(self, n: int, ids: np.ndarray, energy: np.ndarray, stress_ratio: np.ndarray) -> None:
        self.energy = np.full(n, np.nan)
        self.stress = np.full(n, np.nan)
        self.energy[ids] = energy
        self.stress[ids] = stress_ratio
        self.version = 0
        self._n_done = -1  # particle count the values were last extended to

    @classmethod
    def from_analysis(cls, n: int, ids: np.ndarray, analysis) -> AnalysisValues:
        g = np.asarray(analysis.group, dtype=np.int64)
        ua = np.asarray(analysis.energy_available, dtype=np.float64)
        e = ua[g] / ua.max() if ua.size and ua.max() > 0.0 else np.zeros(len(g))
        s = np.asarray(analysis.principal_stress, dtype=np.float64)[:, 0][g] / float(analysis.tensile_strength)
        return cls(n, np.asarray(ids, dtype=np.int64), e, s)

    def values(self, ps, mode: str) -> np.ndarray:
        """(N,) colour parameter in [0, 1] (NaN: no data) for every particle of `ps`."""
        if self._n_done != len(ps):
            for name in ("energy", "stress"):
                a = getattr(self, name)
                b = np.concatenate([a, np.full(max(0, len(ps) - len(a)), np.nan)])[: len(ps)]
                kids = np.flatnonzero(ps.parent >= 0)
                for _ in range(64):  # a child takes its parent's value (subdivision depth is small)
                    todo = kids[np.isnan(b[kids]) & ~np.isnan(b[ps.parent[kids]])]
                    if not len(todo):
                        break
                    b[todo] = b[ps.parent[todo]]
                setattr(self, name, b)
            self._n_done = len(ps)
        return self.energy if mode == "energy" else np.clip(self.stress / 2.0, 0.0, 1.0)


def particle_colours(world, ids: np.ndarray, mode: str, data: AnalysisValues | None) -> np.ndarray:
    """(len(ids), 3) colours of particles `ids` in a colour mode (fragment: by kind)."""
    ps = world.particles
    if mode == "material":
        return MATERIAL_COLOURS[ps.material[ids] % len(MATERIAL_COLOURS)]
    if mode in ("energy", "stress"):
        if data is None:
            return np.broadcast_to(np.array(NO_DATA), (len(ids), 3)).copy()
        return coolwarm(data.values(ps, mode)[ids])
    return np.where(ps.kind[ids, None] == 1, [SUBDIVIDED_COLOUR], [PHYSICAL_COLOUR])


class ViewerScene(SceneView):
    """SceneView (render/session.py) with the viewer's surface colour modes. Fragment mode is
    SceneView's own; the other modes colour each face by the particle under it."""

    def __init__(self, world) -> None:
        self.colour_mode = "fragment"
        self.data: AnalysisValues | None = None
        self._colour_key = None
        self._mesh_cache = (None, None)
        super().__init__(world)

    def refresh(self) -> None:
        w = self.world
        if "rigid" in w.stages and self.colour_mode != "fragment":
            key = (w.surface_version, self.colour_mode, id(self.data), getattr(self.data, "version", 0))
            if key != self._colour_key:
                self.scene.set_surfaces(self._coloured_parts())
                self._colour_key = key
                self._version = w.surface_version  # SceneView keeps these surfaces until fracture changes them
        elif self._colour_key is not None:
            self._colour_key = None
            self._version = -1  # back to SceneView's fragment colours
        super().refresh()

    def mesh(self):
        """The World's fragment surfaces (reference frame), cached per surface version."""
        if self._mesh_cache[0] != self.world.surface_version:
            self._mesh_cache = (self.world.surface_version, world_surfaces(self.world))
        return self._mesh_cache[1]

    def _coloured_parts(self) -> list:
        w = self.world
        ps = w.particles
        mesh = self.mesh()
        parts = list(self._floor)
        for label in np.unique(mesh.vert_label):
            verts, faces = mesh.fragment(int(label))
            ids = np.flatnonzero(ps.alive & (ps.body == label))
            if not len(ids) or not len(faces):
                continue
            _, k = cKDTree(ps.centroid[ids]).query(verts[faces].mean(1))
            cols = particle_colours(w, ids[np.asarray(k)], self.colour_mode, self.data)
            parts.append(MeshPart(verts, faces, body=int(label), colors=np.asarray(cols), color_per="face"))
        return parts


# ----------------------------------------------------------------------------- overlays
def particle_positions(world, frames, ids: np.ndarray) -> np.ndarray:
    """World centroids (len(ids), 3) of particles `ids` (each moved by its body's pose)."""
    from anisofrac.strikes import to_world

    ps = world.particles
    return to_world(frames, ps.body[ids], ps.centroid[ids]) if len(ids) else np.zeros((0, 3))


def particle_overlay(world, frames, physical: bool, subdivided: bool, boundary: bool, mode: str,
                     data: AnalysisValues | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Spheres (x (P, 3) m, r (P,) m, colour (P, 3)) of the chosen particle kinds: physical and
    subdivided tet particles (radius (3V / 4 pi)^(1/3)), boundary particles (the rigid spheres)."""
    ps = world.particles
    xs, rs, cs = [], [], []
    want = np.zeros(len(ps), dtype=bool)
    if physical:
        want |= ps.kind == 0
    if subdivided:
        want |= ps.kind == 1
    ids = np.flatnonzero(want & ps.alive & (ps.body >= 0))
    if len(ids):
        xs.append(particle_positions(world, frames, ids))
        rs.append(ps.radius[ids])
        cs.append(particle_colours(world, ids, mode, data))
    if boundary and world.rigid.n_spheres:
        _, rad, _ = world.rigid.sphere_data()
        xs.append(world.rigid.sphere_world())
        rs.append(rad.astype(np.float64))
        cs.append(np.broadcast_to(np.array(BOUNDARY_COLOUR), (len(rad), 3)))
    if not xs:
        return np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3))
    return np.concatenate(xs), np.concatenate(rs), np.concatenate(cs)


def link_segments(world, frames, pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Segments between the world centroids of linked live particles (pairs (L, 2))."""
    ps = world.particles
    if not len(pairs):
        return np.zeros((0, 3)), np.zeros((0, 3))
    ok = ps.alive[pairs[:, 0]] & ps.alive[pairs[:, 1]] & (ps.body[pairs[:, 0]] >= 0)
    p = pairs[ok]
    return particle_positions(world, frames, p[:, 0]), particle_positions(world, frames, p[:, 1])


def ellipsoid_loops(centre, G: np.ndarray, R: np.ndarray, segments: int = LOOP_SEGMENTS):
    """Three principal ellipses of the kernel support |G (x - c)| < 1 (Eq. 4-5) of a particle whose body
    has rotation R: the unit circles about the eigenvectors of G mapped by R V diag(h) (h = 1/eigenvalue:
    the support semi-axes). Returns segments (a, b), each (3 segments, 3)."""
    w, V = np.linalg.eigh(np.asarray(G, dtype=np.float64))
    M = R @ V @ np.diag(1.0 / w)
    a_all, b_all = [], []
    for k in range(3):
        a, b = disc_outline(np.zeros(3), np.eye(3)[k], 1.0, segments)
        a_all.append(a @ M.T + centre)
        b_all.append(b @ M.T + centre)
    return np.concatenate(a_all), np.concatenate(b_all)


def kernel_segments(world, frames, point, body: int, count: int = KERNEL_SAMPLES):
    """Kernel ellipsoids of the `count` live particles of `body` nearest the world `point`."""
    from anisofrac.strikes import to_reference

    ps = world.particles
    G = getattr(world, "kernel_G", None)
    ids = np.flatnonzero(ps.alive & (ps.body == body))
    if G is None or not len(ids) or body < 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    pr = to_reference(frames, body, point)
    near = ids[np.argsort(np.linalg.norm(ps.centroid[ids] - pr, axis=1))[:count]]
    xw = particle_positions(world, frames, near)
    segs = [ellipsoid_loops(xw[i], G[p], frames[0][body]) for i, p in enumerate(near)]
    return np.concatenate([s[0] for s in segs]), np.concatenate([s[1] for s in segs])


def half_disc(point, normal, radius: float, side, segments: int = LOOP_SEGMENTS):
    """Outline of a crack disc: the full circle (side None) or the half-disc on `side` (arc + diameter)."""
    if side is None:
        return disc_outline(point, normal, radius, segments)
    n = np.asarray(normal, dtype=np.float64) / np.linalg.norm(normal)
    s = np.asarray(side, dtype=np.float64)
    s = s - (s @ n) * n
    s /= np.linalg.norm(s)
    t = np.cross(n, s)
    ang = np.linspace(-0.5 * np.pi, 0.5 * np.pi, segments // 2 + 1)
    arc = point + radius * (np.cos(ang)[:, None] * s + np.sin(ang)[:, None] * t)
    a = np.concatenate([arc[:-1], [point - radius * t]])
    b = np.concatenate([arc[1:], [point + radius * t]])
    return a, b


def crack_segments(cracks: list, impact_normal=None):
    """Segments (a, b, colours) of crack shapes (viewer.actions.CrackShape): each disc or half-disc
    with r_outer, its normal (a short red line), and the shatter circle of radius r_inner about the
    impact point in the plane normal to `impact_normal` (or to the first crack's normal)."""
    A, B, C = [], [], []
    for c in cracks:
        a, b = half_disc(c.point, c.normal, c.r_outer, c.side)
        A.append(a)
        B.append(b)
        C.append(np.broadcast_to(np.array(CRACK_COLOUR), (len(a), 3)))
        A.append(c.point[None])
        B.append((c.point + NORMAL_ARROW * c.r_outer * c.normal)[None])
        C.append(np.array([CRACK_NORMAL_COLOUR]))
    if cracks and cracks[0].r_inner > 0.0:
        n = cracks[0].normal if impact_normal is None else impact_normal
        a, b = disc_outline(cracks[0].point, n, cracks[0].r_inner, LOOP_SEGMENTS)
        A.append(a)
        B.append(b)
        C.append(np.broadcast_to(np.array(SHATTER_COLOUR), (len(a), 3)))
    if not A:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3))
    return np.concatenate(A), np.concatenate(B), np.concatenate(C)


def preview_particles(world, preview) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The preview's analysed particles as spheres coloured by group (palette per group; groups that
    did not fire are drawn darker), PREVIEW_RADIUS x their radius so they show through the surface."""
    an = preview.analysis
    n_groups = max(1, len(an.members))
    pal = body_palette(n_groups, saturation=0.75, value=1.0)
    fired = np.asarray(an.fired, dtype=bool)
    cols = pal[preview.group] * np.where(fired[preview.group], 1.0, 0.45)[:, None]
    r = PREVIEW_RADIUS * world.particles.radius[preview.particle_ids]
    return preview.particle_x, r, cols
