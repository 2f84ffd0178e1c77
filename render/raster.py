"""A software renderer in Taichi: needs no Vulkan, runs on CPU or CUDA (DESIGN.md section 2, render/).

Visibility-buffer rasterisation, deterministic for any number of threads:
  1. *Coverage.* One parallel loop per primitive kind (triangles, particles, line segments). Each
     primitive is projected with GGUI's matrices (`clip = [p, 1] @ V @ P`, reversed Z, render/camera.py)
     and its screen bounding box is scanned; a pixel is covered when its centre passes the three edge
     functions (triangles), lies inside the projected disc (particles) or on the stepped segment
     (lines). The depth is z_ndc, which is affine in screen space (perspective-correct depth); the
     pixel keeps `atomic_max((depth << 32) | id)`: reversed Z makes the nearest fragment the largest
     key, and the id breaks ties, so the result does not depend on the order of the loops.
     Triangles crossing the near plane are clipped against `w = near` in clip space (up to two
     triangles); fragments beyond the far plane (z_ndc < 0) are dropped.
  2. *Shadow map* (Lighting.shadows). The key light is directional: the casters (bodies' triangles
     that face the light, and particles; not the static floor) are rasterised orthographically along
     the light into a SHADOW_TEXELS^2 map of the largest height x . light_dir, fitted to the casters'
     bounds each frame.
  3. *Shading.* One loop over pixels decodes the id. Triangles: the pixel's view ray meets the
     triangle's world corners (Moller-Trumbore), which gives perspective-correct barycentrics for the
     colour and the surface point; particles: the sphere point under the pixel; lines: flat colour.
     Colour = c (ambient + fill light + key light x lit fraction) + a Blinn-Phong highlight of the key
     light whose sharpness follows the part's roughness. With the studio terms off this is exactly
     GGUI's `c (ambient + light max(n.l, 0))` (|n.l| when two-sided). The lit fraction is a
     percentage-closer filter of (2 SHADOW_FILTER + 1)^2 texels (soft edges). Faces turned away from
     the eye are culled unless two-sided (surfaces are closed).
     See-through triangles (opacity < 1, glass) are covered into a second key buffer; where the
     nearest one lies in front of the opaque surface, it is shaded (two-sided) and blended over it.
  4. *Resolve.* With Lighting.antialias, a pixel whose primitives differ from a 4-neighbour's (an
     edge) is blended half with its neighbours; then uint8. The key buffers are cleared during
     shading, so a frame costs no separate clearing pass.
Output: an (H, W, 3) uint8 array, row 0 at the top, colours rounded from [0, 1].
Where: coverage (step 1) and the renderer are here; the key layout and the triangle scan are in
render/raster_core.py, steps 2-4 in render/raster_light.py.
"""


import numpy as np
import taichi as ti

from core import field_pool
from core.errors import ConfigError
from render.camera import Camera, box_corners
from render.raster_core import (
    MAX_SIZE_PX,
    SHADOW_MARGIN,
    SHADOW_TEXELS,
    _key,
    _particle_screen,
    _put_row,
    _raster_triangle,
    _row,
    _to_screen,
)
from render.raster_light import _k_shade, _k_shadow_casters
from render.scene_data import RenderScene


@ti.func
def _cover_clipped(c0, c1, c2, t, near, w_px: ti.i32, h_px: ti.i32, buf: ti.template(), buf_see: ti.template(), see):
    """Cover one clip-space triangle, clipped against w >= near (Sutherland-Hodgman: a polygon of 3 or
    4 vertices, covered as a fan of 1 or 2 triangles by one inlined scan)."""
    n_in = ti.cast(c0[3] >= near, ti.i32) + ti.cast(c1[3] >= near, ti.i32) + ti.cast(c2[3] >= near, ti.i32)
    poly = ti.Matrix.zero(float, 4, 4)
    m = 0
    if n_in == 3:
        for j in ti.static(range(4)):
            poly[0, j] = c0[j]
            poly[1, j] = c1[j]
            poly[2, j] = c2[j]
        m = 3
    elif n_in > 0:
        cs = [c0, c1, c2]
        for k in ti.static(range(3)):
            p = cs[k]
            q = cs[(k + 1) % 3]
            p_in = p[3] >= near
            q_in = q[3] >= near
            if p_in:
                poly = _put_row(poly, m, p)
                m += 1
            if p_in != q_in:
                s = (near - p[3]) / (q[3] - p[3])
                poly = _put_row(poly, m, p + s * (q - p))
                m += 1
    if m >= 3:
        s0 = _to_screen(_row(poly, 0), w_px, h_px)
        for k in range(m - 2):  # the fan (0, 1, 2), then (0, 2, 3)
            sb = _to_screen(_row(poly, 1), w_px, h_px)
            sc = _to_screen(_row(poly, 2), w_px, h_px)
            if k == 1:
                sb = sc
                sc = _to_screen(_row(poly, 3), w_px, h_px)
            _raster_triangle(s0, sb, sc, t, w_px, h_px, buf, buf_see, see, False)


@ti.func
def _cover_triangles(n_tri: ti.i32, vp_t: ti.math.mat4, near: float, w_px: ti.i32, h_px: ti.i32, eye: ti.math.vec3,
                     cull: ti.i32, corner_x: ti.template(), corner_n: ti.template(), corner_look: ti.template(),
                     pix_key: ti.template(), pix_key_t: ti.template()):
    for t in range(n_tri):
        # a face turned away from the eye is hidden by the front of its closed surface (one-sided shading)
        if cull and (corner_x[3 * t] - eye).dot(corner_n[3 * t]) > 0.0:
            continue
        c0 = vp_t @ ti.Vector([corner_x[3 * t][0], corner_x[3 * t][1], corner_x[3 * t][2], 1.0])
        c1 = vp_t @ ti.Vector([corner_x[3 * t + 1][0], corner_x[3 * t + 1][1], corner_x[3 * t + 1][2], 1.0])
        c2 = vp_t @ ti.Vector([corner_x[3 * t + 2][0], corner_x[3 * t + 2][1], corner_x[3 * t + 2][2], 1.0])
        # see-through: its own layer, blended over the opaque one
        _cover_clipped(c0, c1, c2, t, near, w_px, h_px, pix_key, pix_key_t, corner_look[3 * t][1] < 1.0)


@ti.func
def _cover_particles(n_p: ti.i32, id0: ti.i32, view_t: ti.math.mat4, ndc_sx: float, ndc_sy: float,
                     p22: float, p32: float, focal_px: float, near: float, w_px: ti.i32, h_px: ti.i32,
                     particle_x: ti.template(), particle_r: ti.template(), pix_key: ti.template()):
    for i in range(n_p):
        r = particle_r[i]
        cv, w, sx, sy = _particle_screen(particle_x[i], view_t, w_px, h_px, ndc_sx, ndc_sy)
        if w - r > near:
            rad = focal_px * r / w  # px: projected radius (the sphere's silhouette, small-angle)
            x0 = ti.max(ti.cast(ti.ceil(sx - rad - 0.5), ti.i32), 0)
            x1 = ti.min(ti.cast(ti.floor(sx + rad - 0.5), ti.i32), w_px - 1)
            y0 = ti.max(ti.cast(ti.ceil(sy - rad - 0.5), ti.i32), 0)
            y1 = ti.min(ti.cast(ti.floor(sy + rad - 0.5), ti.i32), h_px - 1)
            for py in range(y0, y1 + 1):
                for px in range(x0, x1 + 1):
                    dx = (px + 0.5 - sx) / rad
                    dy = (py + 0.5 - sy) / rad
                    d2 = dx * dx + dy * dy
                    if d2 <= 1.0:
                        zv = cv[2] + r * ti.sqrt(1.0 - d2)  # view z of the sphere point under the pixel
                        z = (zv * p22 + p32) / (-zv)
                        if z >= 0.0:
                            ti.atomic_max(pix_key[py, px], _key(z, id0 + i))


@ti.func
def _cover_lines(n_l: ti.i32, id0: ti.i32, vp_t: ti.math.mat4, near: float, width: ti.i32, w_px: ti.i32,
                 h_px: ti.i32, line_x: ti.template(), pix_key: ti.template()):
    for j in range(n_l):
        ca = vp_t @ ti.Vector([line_x[2 * j][0], line_x[2 * j][1], line_x[2 * j][2], 1.0])
        cb = vp_t @ ti.Vector([line_x[2 * j + 1][0], line_x[2 * j + 1][1], line_x[2 * j + 1][2], 1.0])
        if ca[3] >= near or cb[3] >= near:
            if ca[3] < near:
                ca = ca + (near - ca[3]) / (cb[3] - ca[3]) * (cb - ca)
            if cb[3] < near:
                cb = cb + (near - cb[3]) / (ca[3] - cb[3]) * (ca - cb)
            a = _to_screen(ca, w_px, h_px)
            b = _to_screen(cb, w_px, h_px)
            d = b - a
            steep = ti.abs(d[1]) > ti.abs(d[0])
            length = ti.max(ti.abs(d[0]), ti.abs(d[1]))
            # clamp the walk to the screen (a clipped line can reach far outside it)
            ns = ti.cast(ti.min(ti.ceil(length), 4.0 * (w_px + h_px)), ti.i32)
            ns = ti.max(ns, 1)
            for s in range(ns + 1):
                f = s / ns
                p = a + f * d  # z_ndc is affine along the screen segment
                px = ti.cast(ti.floor(p[0]), ti.i32)
                py = ti.cast(ti.floor(p[1]), ti.i32)
                for o in range(width):
                    qx, qy = px, py
                    if steep:
                        qx = px + o - (width - 1) // 2
                    else:
                        qy = py + o - (width - 1) // 2
                    if 0 <= qx and qx < w_px and 0 <= qy and qy < h_px and p[2] >= 0.0 and p[2] <= 1.0:
                        ti.atomic_max(pix_key[qy, qx], _key(p[2], id0 + j))


@ti.kernel
def _k_cover(n_tri: ti.i32, n_p: ti.i32, n_l: ti.i32, vp_t: ti.math.mat4, view_t: ti.math.mat4, near: float,
             w_px: ti.i32, h_px: ti.i32, eye: ti.math.vec3, cull: ti.i32, ndc_sx: float, ndc_sy: float, p22: float,
             p32: float, focal_px: float, line_width: ti.i32, corner_x: ti.template(), corner_n: ti.template(),
             corner_look: ti.template(), particle_x: ti.template(), particle_r: ti.template(),
             line_x: ti.template(), pix_key: ti.template(), pix_key_t: ti.template()):
    """Coverage (module doc, step 1) in one kernel, one loop per primitive kind: ids are triangles,
    then particles, then line segments. One kernel, not three, to compile at a start (a kernel's
    first launch in a process is about 30 ms of JIT whatever it does)."""
    _cover_triangles(n_tri, vp_t, near, w_px, h_px, eye, cull, corner_x, corner_n, corner_look, pix_key, pix_key_t)
    _cover_particles(n_p, n_tri, view_t, ndc_sx, ndc_sy, p22, p32, focal_px, near, w_px, h_px, particle_x,
                     particle_r, pix_key)
    _cover_lines(n_l, n_tri + n_p, vp_t, near, line_width, w_px, h_px, line_x, pix_key)


def check_size(width: int, height: int) -> tuple[int, int]:
    """Validate an image size (px)."""
    if not (isinstance(width, int | np.integer) and isinstance(height, int | np.integer)):
        raise ConfigError("render.size", (width, height), "integer width and height in pixels")
    if not (1 <= width <= MAX_SIZE_PX and 1 <= height <= MAX_SIZE_PX):
        raise ConfigError("render.size", (width, height), f"1 .. {MAX_SIZE_PX} px per side")
    return int(width), int(height)


def _pixel_buffers(height: int, width: int) -> dict:
    """A new field tree of one image size's buffers: {attribute name: field}."""
    fb = ti.FieldsBuilder()
    f = dict(
        pix_key=ti.field(ti.i64),  # (H, W) -: (depth << 32) | (1 + primitive id) of opaque ones, 0 = none
        pix_key_t=ti.field(ti.i64),  # (H, W) -: the same for the nearest see-through triangle
        pix_rgb=ti.math.vec3.field(),  # (H, W) -: shaded linear RGB before the edge filter
        pix_id=ti.field(ti.i32),  # (H, W) -: a hash of the primitives drawn there (edges differ)
        shadow=ti.field(float),  # (S, S) m: largest caster height towards the key light per texel
    )
    fb.dense(ti.ij, (height, width)).place(f["pix_key"], f["pix_key_t"], f["pix_rgb"], f["pix_id"])
    fb.dense(ti.ij, (SHADOW_TEXELS, SHADOW_TEXELS)).place(f["shadow"])
    fb.finalize()
    return f


class RasterRenderer:
    """Software renderer (module docstring): `render(scene, camera)` -> (H, W, 3) uint8, row 0 at the top."""

    name = "raster"

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = check_size(width, height)
        self._key = ("raster", self.height, self.width)
        self._buffers = field_pool.acquire(self._key, lambda: _pixel_buffers(self.height, self.width))
        for name, f in self._buffers.items():
            setattr(self, name, f)
        self.message = f"renderer: raster (Taichi software rasteriser, {self.width}x{self.height})"

    def release(self) -> None:
        """Give the pixel buffers back to core/field_pool.py (never destroyed: that clears every
        compiled kernel of the program)."""
        if self._buffers is not None:
            field_pool.recycle(self._key, self._buffers)
            self._buffers = None

    def _shadow_map(self, scene: RenderScene) -> tuple:
        """Render the key light's depth map over the casters' bounds; returns (lbasis, lmap) for the
        shading kernel (lmap[2] = 0: nothing to shadow)."""
        lt = scene.lighting
        ld = lt.light_dir
        lu = np.cross(ld, [0.0, 0.0, 1.0] if abs(ld[2]) < 0.9 else [1.0, 0.0, 0.0])
        lu /= np.linalg.norm(lu)
        lv = np.cross(ld, lu)
        basis = np.stack([lu, lv, ld])
        off = ti.math.mat3(np.eye(3)), ti.math.vec3(0.0, 0.0, 0.0)
        if not lt.shadows or not (scene.n_tris or scene.n_particles):
            return off
        lo, hi = scene.body_bounds(particles=True)
        if not np.all(hi >= lo):
            return off
        q = box_corners(lo, hi) @ basis.T
        q_lo, q_hi = q.min(0), q.max(0)
        extent = max(float(np.max(q_hi[:2] - q_lo[:2])), 1e-6) * (1.0 + 2.0 * SHADOW_MARGIN)
        centre = 0.5 * (q_lo + q_hi)
        scale = SHADOW_TEXELS / extent  # texels per metre
        lmap = ti.math.vec3(centre[0] - 0.5 * extent, centre[1] - 0.5 * extent, scale)
        lbasis = ti.math.mat3(basis)
        _k_shadow_casters(scene.n_tris, scene.n_particles, lbasis, lmap, SHADOW_TEXELS, scene.corner_x,
                          scene.corner_n, scene.corner_body, scene.corner_look, scene.particle_x, scene.particle_r,
                          self.shadow)
        return lbasis, lmap

    def render(self, scene: RenderScene, camera: Camera) -> np.ndarray:
        """Draw the scene's current buffers (call scene.update() after changing poses)."""
        if self._buffers is None:
            raise RuntimeError("RasterRenderer.render after release()")
        w, h = self.width, self.height
        aspect = w / h
        view = camera.view_matrix()
        proj = camera.projection_matrix(aspect)
        vp_t = ti.math.mat4((view @ proj).T)
        view_t = ti.math.mat4(view.T)
        right, up, back = camera.basis()
        ndc_sx, ndc_sy = float(proj[0, 0]), float(proj[1, 1])
        p22, p32 = float(proj[2, 2]), float(proj[3, 2])
        focal_px = ndc_sy * 0.5 * h
        near = float(camera.near)
        lt = scene.lighting
        width_px = max(int(round(scene.line_width)), 1)
        _k_cover(scene.n_tris, scene.n_particles, scene.n_lines, vp_t, view_t, near, w, h, ti.math.vec3(*camera.eye),
                 int(not lt.two_sided), ndc_sx, ndc_sy, p22, p32, focal_px, width_px, scene.corner_x, scene.corner_n,
                 scene.corner_look, scene.particle_x, scene.particle_r, scene.line_x, self.pix_key, self.pix_key_t)
        lbasis, lmap = self._shadow_map(scene)
        vec3 = ti.math.vec3
        lights = ti.types.matrix(6, 3, float)(np.stack([
            lt.light_dir, lt.light_color, lt.ambient, lt.fill_dir, lt.fill_color, [float(lt.specular), 0.0, 0.0]]))
        img = np.empty((h, w, 3), dtype=np.uint8)  # written in place by the kernel (row 0 = top)
        _k_shade(w, h, scene.n_tris, scene.n_particles, vec3(*camera.eye), vec3(*right), vec3(*up), vec3(*back),
                 ndc_sx, ndc_sy, view_t, focal_px, lights, vec3(*lt.background), int(lt.two_sided), lbasis, lmap,
                 SHADOW_TEXELS, self.shadow, scene.corner_x, scene.corner_n, scene.corner_color, scene.corner_look,
                 scene.particle_x, scene.particle_r, scene.particle_color, scene.line_color, self.pix_key,
                 self.pix_key_t, self.pix_rgb, self.pix_id, int(lt.antialias), img)
        return img
