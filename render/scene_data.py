"""What one frame shows, independent of the renderer (DESIGN.md section 4, "render" stage).

A `RenderScene` holds Taichi buffers that both renderers (GGUI and the rasteriser) read:

  * triangle surfaces as *corners* (three per triangle, not shared): each corner has a position in
    the reference frame of its body, a body id and a colour. Unshared corners give flat shading
    with one normal per face (fragment surfaces are faceted, and a crack rim must not average the
    normals of the outer wall and the crack face) and per-face colours for free;
  * body poses (position of the centre of mass, unit quaternion w-x-y-z, reference centre of mass):
    a kernel maps every corner with `x = R(q) (X - ref_com) + x_body` (rigid/store.py convention,
    docs/decisions.md "Reference frame for rest data") and writes world corners and face normals.
    Body id -1 marks static geometry (floor, colliders) given directly in world coordinates;
  * optional particles (world position, radius, colour) and line segments (links, crack disc
    outlines; a colour per segment and one width in pixels);
  * lighting: one directional light, an ambient term and the background colour (`Lighting`).

Buffers are allocated with spare capacity in one `ti.FieldsBuilder` tree per kind (surfaces, poses,
particles, lines), taken from and given back to core/field_pool.py (never destroyed). Setting new
surfaces (after a fracture) uploads them and bumps `surface_version`; a tree is replaced only when its
capacity is exceeded (capacity doubles; `generation` counts replacements so renderers can drop caches).
Nothing is allocated per frame: `update()` only runs the transform.
"""


import colorsys
from dataclasses import dataclass, field

import numpy as np
import taichi as ti

from core import field_pool
from core.errors import ConfigError
from core.runtime import numpy_float
from render.buffers import _k_blank_corners, _k_put_corners, make_buffers
from rigid.kernel_math import q_to_mat

MIN_CAPACITY = 64  # slots: smallest tree allocated for any kind
BOUNDS_BLOCK = 1024  # corners reduced per parallel task in body_bounds


@dataclass
class Lighting:
    """One directional light plus ambient; colours are linear RGB in [0, 1]."""

    light_dir: np.ndarray = field(default_factory=lambda: np.array([0.35, 1.0, 0.55]))  # towards the light
    light_color: np.ndarray = field(default_factory=lambda: np.array([0.72, 0.72, 0.72]))
    ambient: np.ndarray = field(default_factory=lambda: np.array([0.28, 0.28, 0.28]))
    background: np.ndarray = field(default_factory=lambda: np.array([0.13, 0.14, 0.17]))
    two_sided: bool = False  # False: max(n.l, 0) with outward normals; True: |n.l| (GGUI's two_sided)
    # the studio look (`Lighting.studio()`; the plain defaults keep GGUI's formula above, which tests use)
    fill_dir: np.ndarray = field(default_factory=lambda: np.array([-0.6, 0.35, -0.4]))  # towards the fill light
    fill_color: np.ndarray = field(default_factory=lambda: np.zeros(3))  # no shadows from the fill light
    shadows: bool = False  # the key light casts shadows (rasteriser: a filtered shadow map)
    specular: bool = False  # Blinn-Phong highlights of the key light, by each surface's roughness
    antialias: bool = False  # smooth the edges between primitives (rasteriser)

    @classmethod
    def studio(cls) -> "Lighting":
        """The look of headless frames: key light with soft shadows, a fill light, highlights, smooth edges."""
        return cls(light_dir=np.array([0.45, 1.0, 0.35]), light_color=np.array([0.78, 0.76, 0.72]),
                   ambient=np.array([0.22, 0.23, 0.26]), fill_color=np.array([0.16, 0.17, 0.2]),
                   background=np.array([0.15, 0.16, 0.19]), shadows=True, specular=True, antialias=True)

    def __post_init__(self) -> None:
        for name in ("light_dir", "fill_dir"):
            d = np.asarray(getattr(self, name), dtype=np.float64).reshape(3)
            if not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0.0:
                raise ConfigError(f"render.{name}", d.tolist(), "a finite non-zero 3-vector")
            setattr(self, name, d / np.linalg.norm(d))
        for name in ("light_color", "ambient", "background", "fill_color"):
            c = np.asarray(getattr(self, name), dtype=np.float64).reshape(3)
            if not np.all((c >= 0.0) & (c <= 1.0)):
                raise ConfigError(f"render.{name}", c.tolist(), "RGB components in [0, 1]")
            setattr(self, name, c)


def body_palette(n: int, saturation: float = 0.45, value: float = 0.92) -> np.ndarray:
    """(n, 3) distinct soft colours (golden-ratio hues), one per body or fragment, deterministic."""
    hues = (0.08 + 0.6180339887498949 * np.arange(n)) % 1.0
    return np.array([colorsys.hsv_to_rgb(h, saturation, value) for h in hues]).reshape(n, 3)


@dataclass
class MeshPart:
    """One triangle mesh on the host: vertices in its body's reference frame (or in the world for
    body -1), outward faces, body id (one int or one per vertex), colours: None (palette colour of
    the body), one RGB, (V, 3) per vertex or (F, 3) per face; when V == F, `color_per` says which
    ("vertex" or "face"; "auto" takes per-face). `roughness` (0 mirror-like .. 1 matte) sets the
    highlight, `opacity` < 1 draws the part see-through (glass)."""

    verts: np.ndarray  # (V, 3) m
    faces: np.ndarray  # (F, 3) int
    body: int | np.ndarray = -1
    colors: np.ndarray | None = None
    color_per: str = "auto"
    roughness: float = 0.7
    opacity: float = 1.0


def _colors_for(part: MeshPart, where: str) -> np.ndarray:
    """(F, 3, 3) corner colours of a part."""
    nf, nv = len(part.faces), len(part.verts)
    c = part.colors
    if c is None:
        body = np.broadcast_to(np.asarray(part.body, dtype=np.int64), (nv,))
        pal = body_palette(int(max(body.max(initial=0), 0)) + 1)
        vc = np.where(body[:, None] >= 0, pal[np.maximum(body, 0)], 0.75)
        return vc[part.faces]
    c = np.asarray(c, dtype=np.float64)
    if c.shape == (3,):
        out = np.broadcast_to(c, (nf, 3, 3))
    elif c.shape == (nv, 3) and (nv != nf or part.color_per == "vertex"):
        out = c[part.faces]
    elif c.shape == (nf, 3) and part.color_per != "vertex":
        out = np.broadcast_to(c[:, None, :], (nf, 3, 3))
    else:
        raise ConfigError(f"{where}.colors", f"shape {c.shape}", f"(3,), ({nv}, 3) per vertex or ({nf}, 3) per face")
    if not np.all((out >= 0.0) & (out <= 1.0)):
        raise ConfigError(f"{where}.colors", "values outside [0, 1]", "linear RGB in [0, 1]")
    return out


@ti.func
def _corner_world(c, n_body, corner_ref: ti.template(), corner_body: ti.template(), pose_x: ti.template(),
                  pose_q: ti.template(), pose_ref_com: ti.template()):
    b = corner_body[c]
    x = corner_ref[c]
    if b >= 0 and b < n_body:
        x = q_to_mat(pose_q[b] / pose_q[b].norm()) @ (x - pose_ref_com[b]) + pose_x[b]
    return x


@ti.kernel
def _k_transform(n_tri: ti.i32, n_body: ti.i32, corner_ref: ti.template(), corner_body: ti.template(),
                 pose_x: ti.template(), pose_q: ti.template(), pose_ref_com: ti.template(),
                 corner_x: ti.template(), corner_n: ti.template()):
    for t in range(n_tri):
        for k in range(3):  # a runtime loop: one inlined copy of the transform to compile, not three
            corner_x[3 * t + k] = _corner_world(3 * t + k, n_body, corner_ref, corner_body, pose_x, pose_q,
                                                pose_ref_com)
        x0 = corner_x[3 * t]
        n = (corner_x[3 * t + 1] - x0).cross(corner_x[3 * t + 2] - x0)  # outward for counter-clockwise faces
        ln = n.norm()
        if ln > 0:
            n = n / ln
        for k in ti.static(range(3)):
            corner_n[3 * t + k] = n


@ti.kernel
def _k_body_bounds(n_tri: ti.i32, n_p: ti.i32, corner_x: ti.template(), corner_body: ti.template(),
                     particle_x: ti.template(), particle_r: ti.template(), bounds: ti.template(),
                     out: ti.types.ndarray()):
    """World box of the bodies' triangles (not static world geometry such as the floor) and of n_p
    particles: out[0] = lo, out[1] = hi (2, 3), through the field `bounds`. Each parallel task reduces
    a block of BOUNDS_BLOCK corners in registers and then updates the box once: one atomic per block
    instead of one per corner (they all hit the same six numbers). One launch a frame, no from_numpy
    or to_numpy (each a kernel of Taichi's own, compiled at the first frame)."""
    bounds[0] = ti.Vector([1e30, 1e30, 1e30])
    bounds[1] = -bounds[0]
    nc = 3 * n_tri
    for blk in range((nc + n_p + BOUNDS_BLOCK - 1) // BOUNDS_BLOCK):
        lo = ti.Vector([1e30, 1e30, 1e30])
        hi = -lo
        for j in range(blk * BOUNDS_BLOCK, ti.min((blk + 1) * BOUNDS_BLOCK, nc + n_p)):
            if j < nc:
                if corner_body[j] >= 0:
                    lo = ti.min(lo, corner_x[j])
                    hi = ti.max(hi, corner_x[j])
            else:
                r = particle_r[j - nc]
                lo = ti.min(lo, particle_x[j - nc] - r)
                hi = ti.max(hi, particle_x[j - nc] + r)
        for k in ti.static(range(3)):
            ti.atomic_min(bounds[0][k], lo[k])
            ti.atomic_max(bounds[1][k], hi[k])
    for k in range(3):
        out[0, k] = bounds[0][k]
        out[1, k] = bounds[1][k]


@ti.kernel
def _k_copy_poses(n: ti.i32, src_x: ti.template(), src_q: ti.template(), src_com: ti.template(),
                  pose_x: ti.template(), pose_q: ti.template(), pose_ref_com: ti.template()):
    for b in range(n):
        pose_x[b] = src_x[b]
        pose_q[b] = src_q[b]
        pose_ref_com[b] = src_com[b]
    for b in range(n, pose_q.shape[0]):  # unused slots hold the identity (set_poses does the same)
        pose_q[b] = ti.Vector([1.0, 0.0, 0.0, 0.0])


# Host arrays come in through one kernel per kind (all rows of the buffers, as `from_numpy` would
# write them): a field's `from_numpy` compiles a kernel of Taichi's for every field, six for a first
# frame (0.2 s of the drawing process's start, render/prewarm.py).
@ti.kernel
def _k_put_poses(x: ti.types.ndarray(), q: ti.types.ndarray(), com: ti.types.ndarray(), pose_x: ti.template(),
                 pose_q: ti.template(), pose_ref_com: ti.template()):
    for b in range(pose_q.shape[0]):
        pose_x[b] = ti.Vector([x[b, 0], x[b, 1], x[b, 2]])
        pose_q[b] = ti.Vector([q[b, 0], q[b, 1], q[b, 2], q[b, 3]])
        pose_ref_com[b] = ti.Vector([com[b, 0], com[b, 1], com[b, 2]])


@ti.kernel
def _k_put_particles(x: ti.types.ndarray(), r: ti.types.ndarray(), c: ti.types.ndarray(), particle_x: ti.template(),
                     particle_r: ti.template(), particle_color: ti.template()):
    for i in range(particle_r.shape[0]):
        particle_x[i] = ti.Vector([x[i, 0], x[i, 1], x[i, 2]])
        particle_r[i] = r[i]
        particle_color[i] = ti.Vector([c[i, 0], c[i, 1], c[i, 2]])


@ti.kernel
def _k_put_lines(x: ti.types.ndarray(), c: ti.types.ndarray(), line_x: ti.template(), line_color: ti.template()):
    for i in range(line_x.shape[0]):
        line_x[i] = ti.Vector([x[i, 0], x[i, 1], x[i, 2]])
        line_color[i] = ti.Vector([c[i, 0], c[i, 1], c[i, 2]])


@ti.kernel
def _k_copy_particles(n: ti.i32, src_x: ti.template(), src_r: ti.template(), particle_x: ti.template(),
                      particle_r: ti.template(), particle_color: ti.template(), color: ti.math.vec3):
    for i in range(n):
        particle_x[i] = src_x[i]
        particle_r[i] = src_r[i]
        particle_color[i] = color


def _corner_arrays(parts: list[MeshPart], where: str) -> tuple:
    """Host arrays of the corners of `parts`, three per triangle in the run's precision: reference
    positions (3T, 3) m, body ids (3T,) int32, linear RGB (3T, 3), (roughness, opacity) (3T, 2). Bad
    parts raise ConfigError naming `where`[k]."""
    refs, bodies, colors, looks = [np.zeros((0, 3))], [np.zeros(0, np.int64)], [np.zeros((0, 3))], [np.zeros((0, 2))]
    for k, part in enumerate(parts):
        at = f"{where}[{k}]"
        if not (0.0 <= part.roughness <= 1.0 and 0.0 < part.opacity <= 1.0):
            raise ConfigError(f"{at}.look", (part.roughness, part.opacity), "roughness in [0, 1] and opacity in (0, 1]")
        v = np.asarray(part.verts, dtype=np.float64).reshape(-1, 3)
        f = np.asarray(part.faces, dtype=np.int64).reshape(-1, 3)
        if len(f) and (f.min() < 0 or f.max() >= len(v)):
            raise ConfigError(f"{at}.faces", f"index range {f.min()}..{f.max()}", f"0..{len(v) - 1}")
        if not np.all(np.isfinite(v)):
            raise ConfigError(f"{at}.verts", "non-finite coordinates", "finite coordinates (m)")
        body = np.broadcast_to(np.asarray(part.body, dtype=np.int64), (len(v),))
        refs.append(v[f].reshape(-1, 3))
        bodies.append(body[f].reshape(-1))
        colors.append(_colors_for(MeshPart(v, f, body, part.colors, part.color_per), at).reshape(-1, 3))
        looks.append(np.broadcast_to([part.roughness, part.opacity], (3 * len(f), 2)))
    fdt = numpy_float()
    return (np.concatenate(refs).astype(fdt), np.concatenate(bodies).astype(np.int32),
            np.concatenate(colors).astype(fdt), np.concatenate(looks).astype(fdt))


class RenderScene:
    """Renderer-independent frame buffers (module docstring). Counts: n_tris, n_bodies, n_particles,
    n_lines; `surface_version` changes when surfaces are replaced, `generation` when a tree is rebuilt."""

    def __init__(self, tri_capacity: int = 0, body_capacity: int = 0, particle_capacity: int = 0,
                 line_capacity: int = 0, lighting: Lighting | None = None) -> None:
        self.lighting = lighting or Lighting()
        self.line_width = 2.0  # px: width of line segments, as GGUI's `lines(width=...)`
        self.n_tris = 0
        self.n_bodies = 0
        self.n_particles = 0
        self.n_lines = 0
        self.surface_version = 0
        self.generation = 0
        self._buffers: dict[str, dict] = {}  # kind -> {attribute name: field} of its current tree
        self._blocks: dict = {}  # surface block key -> (first triangle, triangles) in the buffers
        self._block_data: dict = {}  # surface block key -> host copy (ref, body, colour, look) of its corners
        self._blank = 0  # triangles of removed blocks still in the buffers (blanked)
        self._bounds = None
        self.cap = dict(surf=0, pose=0, part=0, line=0, bounds=0)
        self._alloc("surf", tri_capacity)
        self._alloc("pose", body_capacity)
        self._alloc("part", particle_capacity)
        self._alloc("line", line_capacity)
        # compiled now, not at the first fracture event's refresh: the blanking, and the corner writes
        # (blocks and compaction) through the first write of the (empty) buffers
        _k_blank_corners(0, 0, self.corner_ref, self.corner_body)
        self._write_all_blocks()

    # ---- allocation ------------------------------------------------------------------------------
    def _alloc(self, kind: str, needed: int) -> None:
        """(Re)build the buffers of one kind with capacity >= needed (never shrinks). Buffers come from
        and go back to core/field_pool.py: destroying a tree clears every compiled kernel of the
        program (Taichi 1.7.4, SNodeTree.destroy), and the next frame recompiled them all, simulation
        and rendering (about 1 s a time in Pots' drawn frames, 7 s for the next scene's first frame)."""
        cap = field_pool.pow2_at_least(max(needed, self.cap[kind]), MIN_CAPACITY)
        old, old_cap = self._buffers.get(kind), self.cap[kind]
        if old is not None and cap == old_cap:
            return
        new = field_pool.acquire(("render", kind, cap), lambda: make_buffers(kind, cap))
        for name, f in new.items():
            setattr(self, name, f)
        self._buffers[kind] = new
        self.cap[kind] = cap
        if old is not None:
            field_pool.recycle(("render", kind, old_cap), old)
            self.generation += 1

    def release(self) -> None:
        """Give every buffer back to the pool (the renderers must not draw this scene afterwards)."""
        for kind, buffers in self._buffers.items():
            field_pool.recycle(("render", kind, self.cap[kind]), buffers)
        self._buffers.clear()
        self._bounds = None
        self.n_tris = self.n_bodies = self.n_particles = self.n_lines = 0

    # ---- surfaces --------------------------------------------------------------------------------
    def set_surfaces(self, parts: list[MeshPart]) -> None:
        """Replace all surfaces (a scene build); bumps surface_version."""
        self.update_surfaces({"all": parts}, drop=list(self._blocks))

    def update_surfaces(self, blocks: dict, drop=()) -> None:
        """Surfaces kept in blocks (a body's, the floor's), so that a fracture event uploads only what
        it changed: the blocks named in `blocks` (key -> list of MeshPart) are written anew, those in
        `drop` removed, the others stay where they are in the buffers. A removed block's triangles
        are blanked (degenerate, static: nothing draws them); when the new ones do not fit after the
        last triangle, or blanks outnumber the live triangles, every block is written again from its
        host copy (in the order the blocks were first given). Bumps surface_version."""
        new = {key: _corner_arrays(parts, "render.surfaces" if key == "all" else f"render.surfaces[{key!r}]")
               for key, parts in blocks.items()}  # first: a bad part changes nothing
        for key in (*drop, *blocks):
            if key in self._blocks:
                start, n = self._blocks.pop(key)
                del self._block_data[key]
                _k_blank_corners(3 * start, 3 * n, self.corner_ref, self.corner_body)
                self._blank += n
        self._block_data.update(new)
        n_new = sum(len(d[1]) // 3 for d in new.values())
        live = sum(len(d[1]) // 3 for d in self._block_data.values())
        if self.n_tris + n_new > self.cap["surf"] or self._blank > live:
            self._write_all_blocks()
        else:
            for key, (ref, body, col, look) in new.items():
                _k_put_corners(3 * self.n_tris, len(body), ref, body, col, look, self.corner_ref, self.corner_body,
                               self.corner_color, self.corner_look)
                self._blocks[key] = (self.n_tris, len(body) // 3)
                self.n_tris += len(body) // 3
        self.surface_version += 1
        self.update()

    def _write_all_blocks(self) -> None:
        """Every block's host copy, one after the other from triangle 0 (the buffers grow to fit)."""
        data = list(self._block_data.values()) or [_corner_arrays([], "render.surfaces")]
        n_tri = sum(len(d[1]) // 3 for d in data)
        self._alloc("surf", n_tri)
        nc = 3 * self.cap["surf"]
        padded = []  # the corners, then the unused slots (static, blank) up to the capacity
        for k, fill in enumerate((0.0, -1, 0.0, 1.0)):
            a = np.concatenate([d[k] for d in data])
            padded.append(np.full((nc,) + a.shape[1:], fill, dtype=a.dtype))
            padded[-1][: len(a)] = a
        # the kernel a fracture event writes its blocks with (compiled with the scene), not a
        # from_numpy per field (four of Taichi's own kernels, compiled at the first frame)
        _k_put_corners(0, nc, *padded, self.corner_ref, self.corner_body, self.corner_color, self.corner_look)
        start = 0
        for key, d in self._block_data.items():
            self._blocks[key] = (start, len(d[1]) // 3)
            start += len(d[1]) // 3
        self.n_tris, self._blank = n_tri, 0

    def set_surface_mesh(self, mesh, label_body=None, colors=None) -> None:
        """Surfaces from a `geometry.surface.SurfaceMesh` (reference frame, `vert_label` = fragment).
        label_body[label] gives the body of each fragment (default: body = label)."""
        lab = np.asarray(mesh.vert_label, dtype=np.int64)
        body = lab if label_body is None else np.asarray(label_body, dtype=np.int64)[lab]
        self.set_surfaces([MeshPart(mesh.verts, mesh.faces, body, colors)])

    # ---- poses -----------------------------------------------------------------------------------
    def set_poses(self, x, q, ref_com) -> None:
        """Body poses from host arrays: x (B, 3) m, q (B, 4) w-x-y-z, ref_com (B, 3) m."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, 3)
        q = np.asarray(q, dtype=np.float64).reshape(-1, 4)
        com = np.asarray(ref_com, dtype=np.float64).reshape(-1, 3)
        if not (len(x) == len(q) == len(com)):
            raise ConfigError("render.poses", (len(x), len(q), len(com)), "equal numbers of x, q and ref_com rows")
        if not np.all(np.isfinite(q)) or np.any(np.linalg.norm(q, axis=1) == 0.0):
            raise ConfigError("render.poses.q", "zero or non-finite quaternion", "unit quaternions w-x-y-z")
        nb = len(x)
        self._alloc("pose", nb)
        cap = self.cap["pose"]
        fdt = numpy_float()
        qq = np.zeros((cap, 4), fdt)
        qq[:, 0] = 1.0
        qq[:nb] = q
        xx = np.zeros((cap, 3), fdt)
        xx[:nb] = x
        cc = np.zeros((cap, 3), fdt)
        cc[:nb] = com
        _k_put_poses(xx, qq, cc, self.pose_x, self.pose_q, self.pose_ref_com)
        self.n_bodies = nb

    def copy_poses_from(self, body_x, body_q, body_ref_com, n: int) -> None:
        """Body poses from Taichi fields (e.g. a rigid store's body_x, body_q, body_ref_com), no host trip."""
        self._alloc("pose", n)
        _k_copy_poses(int(n), body_x, body_q, body_ref_com, self.pose_x, self.pose_q, self.pose_ref_com)
        self.n_bodies = int(n)

    def update(self) -> None:
        """World corners and face normals from the current poses (one kernel; call once per frame)."""
        if self.n_tris:
            _k_transform(self.n_tris, self.n_bodies, self.corner_ref, self.corner_body, self.pose_x,
                         self.pose_q, self.pose_ref_com, self.corner_x, self.corner_n)

    # ---- particles and lines -----------------------------------------------------------------------
    def set_particles(self, x, radius, colors=(0.9, 0.55, 0.2)) -> None:
        """World-space spheres: x (P, 3) m, radius scalar or (P,) m, colours one RGB or (P, 3)."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, 3)
        n = len(x)
        r = np.broadcast_to(np.asarray(radius, dtype=np.float64), (n,))
        c = np.broadcast_to(np.asarray(colors, dtype=np.float64), (n, 3))
        if n and (not np.all(np.isfinite(x)) or not np.all(r > 0.0)):
            raise ConfigError("render.particles", "non-finite position or radius <= 0", "finite x, radius > 0 m")
        self._alloc("part", n)
        cap, fdt = self.cap["part"], numpy_float()
        bufs = []
        for a, shape in ((x, (cap, 3)), (r, (cap,)), (c, (cap, 3))):
            bufs.append(np.zeros(shape, fdt))
            bufs[-1][:n] = a
        _k_put_particles(*bufs, self.particle_x, self.particle_r, self.particle_color)
        self.n_particles = n

    def copy_particles_from(self, x_field, r_field, n: int, color=(0.9, 0.55, 0.2)) -> None:
        """World-space spheres from Taichi fields (positions vec3, radii scalar), one colour."""
        self._alloc("part", n)
        _k_copy_particles(int(n), x_field, r_field, self.particle_x, self.particle_r, self.particle_color,
                          ti.math.vec3(*color))
        self.n_particles = int(n)

    def set_lines(self, a, b, colors=(1.0, 0.85, 0.2), width: float | None = None) -> None:
        """Segments from a (L, 3) to b (L, 3) m, flat colour per segment (one RGB or (L, 3)), width in px."""
        a = np.asarray(a, dtype=np.float64).reshape(-1, 3)
        b = np.asarray(b, dtype=np.float64).reshape(-1, 3)
        if a.shape != b.shape:
            raise ConfigError("render.lines", (a.shape, b.shape), "equal shapes (L, 3) for both end points")
        n = len(a)
        c = np.broadcast_to(np.asarray(colors, dtype=np.float64), (n, 3))
        if width is not None:
            if not 0.5 <= width <= 32.0:
                raise ConfigError("render.line_width", width, "0.5 .. 32 px")
            self.line_width = float(width)
        self._alloc("line", n)
        cap, fdt = self.cap["line"], numpy_float()
        xs = np.zeros((2 * cap, 3), fdt)
        xs[0 : 2 * n : 2], xs[1 : 2 * n : 2] = a, b
        cs = np.zeros((2 * cap, 3), fdt)
        cs[0 : 2 * n : 2], cs[1 : 2 * n : 2] = c, c
        _k_put_lines(xs, cs, self.line_x, self.line_color)
        self.n_lines = n

    # ---- queries ---------------------------------------------------------------------------------
    def body_bounds(self, particles: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """World box (lo, hi) m of the bodies' surfaces (not the floor or other static geometry) and,
        with `particles`, of the particles: one kernel and six numbers to the host (every frame is fine).
        lo > hi when there is nothing."""
        if self._bounds is None:
            self._alloc("bounds", 2)
        out = np.empty((2, 3), dtype=np.float64)
        _k_body_bounds(self.n_tris, self.n_particles if particles else 0, self.corner_x, self.corner_body,
                       self.particle_x, self.particle_r, self._bounds, out)
        return out[0], out[1]

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World axis-aligned bounds (lo, hi) of everything drawn (host copy: not for every frame)."""
        pts = []
        if self.n_tris:
            pts.append(self.corner_x.to_numpy()[: 3 * self.n_tris])
        if self.n_particles:
            x = self.particle_x.to_numpy()[: self.n_particles]
            r = self.particle_r.to_numpy()[: self.n_particles, None]
            pts += [x - r, x + r]
        if self.n_lines:
            pts.append(self.line_x.to_numpy()[: 2 * self.n_lines])
        if not pts:
            return np.zeros(3), np.zeros(3)
        p = np.concatenate(pts)
        return p.min(0), p.max(0)


def disc_outline(center, normal, radius: float, segments: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """Segments (a, b), each (segments, 3), of the circle of a crack disc (centre, unit normal, radius m)."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    t = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    t /= np.linalg.norm(t)
    s = np.cross(n, t)
    ang = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    ring = np.asarray(center, dtype=np.float64) + radius * (np.cos(ang)[:, None] * t + np.sin(ang)[:, None] * s)
    return ring[:-1], ring[1:]
