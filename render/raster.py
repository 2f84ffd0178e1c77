"""A software renderer in Taichi: needs no Vulkan, runs on CPU or CUDA (DESIGN.md section 2, render/).

Visibility-buffer rasterisation in two passes, deterministic for any number of threads:
  1. *Coverage.* One parallel loop per primitive kind (triangles, particles, line segments). Each
     primitive is projected with GGUI's matrices (`clip = [p, 1] @ V @ P`, reversed Z, render/camera.py)
     and its screen bounding box is scanned; a pixel is covered when its centre passes the three edge
     functions (triangles), lies inside the projected disc (particles) or on the stepped segment
     (lines). The depth is z_ndc, which is affine in screen space (perspective-correct depth); the
     pixel keeps `atomic_max((depth << 32) | id)`: reversed Z makes the nearest fragment the largest
     key, and the id breaks ties, so the result does not depend on the order of the loops.
     Triangles crossing the near plane are clipped against `w = near` in clip space (up to two
     triangles); fragments beyond the far plane (z_ndc < 0) are dropped.
  2. *Shading.* One loop over pixels decodes the id. Triangles: the pixel's view ray meets the
     triangle's world corners (Moller-Trumbore), which gives perspective-correct barycentrics for the
     colour; the face normal gives Lambert + ambient with the scene's light, exactly GGUI's formula
     `c (ambient + light max(n.l, 0))` (|n.l| when two-sided). Particles: shaded spheres (the normal
     of the sphere under the pixel), as GGUI draws them. Lines: flat colour.
Output: an (H, W, 3) uint8 array, row 0 at the top, colours rounded from [0, 1].
"""


import numpy as np
import taichi as ti

from render.camera import Camera
from render.scene_data import RenderScene
from sim.errors import ConfigError

DEPTH_LEVELS = 2**31 - 1  # z_ndc in [0, 1] is quantised to this many levels in the upper 32 bits of a key
ID_MASK = 2**32 - 1  # lower 32 bits of a key: 1 + primitive id (0 = empty pixel)
MAX_SIZE_PX = 8192  # px: largest image side accepted


@ti.func
def _to_screen(c, w_px, h_px):
    """Clip vec4 -> (x px, y px from the top, z_ndc)."""
    iw = 1.0 / c[3]
    return ti.Vector([(c[0] * iw + 1.0) * 0.5 * w_px, (1.0 - c[1] * iw) * 0.5 * h_px, c[2] * iw])


@ti.func
def _key(z, pid):
    zq = ti.cast(ti.min(ti.max(z, 0.0), 1.0) * DEPTH_LEVELS, ti.i64)
    return (zq << 32) | ti.cast(pid + 1, ti.i64)


@ti.func
def _edge(u, v, px, py):
    return (v[0] - u[0]) * (py - u[1]) - (v[1] - u[1]) * (px - u[0])


@ti.func
def _raster_triangle(a, b, c, pid, w_px: ti.i32, h_px: ti.i32, pix_key: ti.template()):
    """Cover the pixels whose centres lie in the screen triangle (a, b, c) = (x, y, z_ndc)."""
    area = _edge(a, b, c[0], c[1])
    if area != 0.0:
        sgn = 1.0
        if area < 0.0:
            sgn = -1.0
        inv_area = 1.0 / (area * sgn)
        x0 = ti.max(ti.cast(ti.ceil(ti.min(a[0], b[0], c[0]) - 0.5), ti.i32), 0)
        x1 = ti.min(ti.cast(ti.floor(ti.max(a[0], b[0], c[0]) - 0.5), ti.i32), w_px - 1)
        y0 = ti.max(ti.cast(ti.ceil(ti.min(a[1], b[1], c[1]) - 0.5), ti.i32), 0)
        y1 = ti.min(ti.cast(ti.floor(ti.max(a[1], b[1], c[1]) - 0.5), ti.i32), h_px - 1)
        for py in range(y0, y1 + 1):
            fy = py + 0.5
            for px in range(x0, x1 + 1):
                fx = px + 0.5
                e0 = _edge(b, c, fx, fy) * sgn
                e1 = _edge(c, a, fx, fy) * sgn
                e2 = _edge(a, b, fx, fy) * sgn
                if e0 >= 0.0 and e1 >= 0.0 and e2 >= 0.0:
                    z = (e0 * a[2] + e1 * b[2] + e2 * c[2]) * inv_area  # z_ndc is affine in screen space
                    if z >= 0.0:
                        ti.atomic_max(pix_key[py, px], _key(z, pid))


@ti.func
def _put_row(poly, m, v):
    for s in ti.static(range(4)):
        if s == m:
            for j in ti.static(range(4)):
                poly[s, j] = v[j]
    return poly


@ti.func
def _row(poly, s):
    return ti.Vector([poly[s, 0], poly[s, 1], poly[s, 2], poly[s, 3]])


@ti.kernel
def _k_cover_triangles(n_tri: ti.i32, vp_t: ti.math.mat4, near: float, w_px: ti.i32, h_px: ti.i32,
                       corner_x: ti.template(), pix_key: ti.template()):
    for t in range(n_tri):
        c0 = vp_t @ ti.Vector([corner_x[3 * t][0], corner_x[3 * t][1], corner_x[3 * t][2], 1.0])
        c1 = vp_t @ ti.Vector([corner_x[3 * t + 1][0], corner_x[3 * t + 1][1], corner_x[3 * t + 1][2], 1.0])
        c2 = vp_t @ ti.Vector([corner_x[3 * t + 2][0], corner_x[3 * t + 2][1], corner_x[3 * t + 2][2], 1.0])
        n_in = ti.cast(c0[3] >= near, ti.i32) + ti.cast(c1[3] >= near, ti.i32) + ti.cast(c2[3] >= near, ti.i32)
        if n_in == 3:
            _raster_triangle(_to_screen(c0, w_px, h_px), _to_screen(c1, w_px, h_px), _to_screen(c2, w_px, h_px),
                             t, w_px, h_px, pix_key)
        elif n_in > 0:
            # Sutherland-Hodgman against w >= near: a triangle gives 3 or 4 vertices
            poly = ti.Matrix.zero(float, 4, 4)
            m = 0
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
            s0 = _to_screen(_row(poly, 0), w_px, h_px)
            s1 = _to_screen(_row(poly, 1), w_px, h_px)
            s2 = _to_screen(_row(poly, 2), w_px, h_px)
            _raster_triangle(s0, s1, s2, t, w_px, h_px, pix_key)
            if m == 4:
                s3 = _to_screen(_row(poly, 3), w_px, h_px)
                _raster_triangle(s0, s2, s3, t, w_px, h_px, pix_key)


@ti.func
def _particle_screen(x, view_t, w_px: ti.i32, h_px: ti.i32, ndc_sx: float, ndc_sy: float):
    """View position, view distance w and screen centre (x, y) px of a particle centre."""
    cv = view_t @ ti.Vector([x[0], x[1], x[2], 1.0])
    w = -cv[2]
    sx = (cv[0] * ndc_sx / w + 1.0) * 0.5 * w_px
    sy = (1.0 - cv[1] * ndc_sy / w) * 0.5 * h_px
    return cv, w, sx, sy


@ti.kernel
def _k_cover_particles(n_p: ti.i32, id0: ti.i32, view_t: ti.math.mat4, ndc_sx: float, ndc_sy: float,
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


@ti.kernel
def _k_cover_lines(n_l: ti.i32, id0: ti.i32, vp_t: ti.math.mat4, near: float, width: ti.i32, w_px: ti.i32,
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


@ti.func
def _lambert(c, n, light_dir, light_color, ambient, two_sided: ti.i32):
    ndl = n.dot(light_dir)
    if two_sided:
        ndl = ti.abs(ndl)
    else:
        ndl = ti.max(ndl, 0.0)
    return c * (ambient + light_color * ndl)


@ti.kernel
def _k_shade(w_px: ti.i32, h_px: ti.i32, n_tri: ti.i32, n_p: ti.i32, eye: ti.math.vec3, right: ti.math.vec3,
             up: ti.math.vec3, back: ti.math.vec3, ndc_sx: float, ndc_sy: float, view_t: ti.math.mat4,
             p22: float, p32: float, focal_px: float, light_dir: ti.math.vec3, light_color: ti.math.vec3,
             ambient: ti.math.vec3, background: ti.math.vec3, two_sided: ti.i32,
             corner_x: ti.template(), corner_n: ti.template(), corner_color: ti.template(),
             particle_x: ti.template(), particle_r: ti.template(), particle_color: ti.template(),
             line_color: ti.template(), pix_key: ti.template(), out: ti.types.ndarray(ndim=3)):
    for py, px in pix_key:
        key = pix_key[py, px]
        col = background
        if key != 0:
            pid = ti.cast(key & ti.i64(ID_MASK), ti.i32) - 1
            if pid < n_tri:
                x0 = corner_x[3 * pid]
                e1 = corner_x[3 * pid + 1] - x0
                e2 = corner_x[3 * pid + 2] - x0
                ndc_x = 2.0 * (px + 0.5) / w_px - 1.0
                ndc_y = 1.0 - 2.0 * (py + 0.5) / h_px
                d = right * (ndc_x / ndc_sx) + up * (ndc_y / ndc_sy) - back  # view ray through the pixel
                pv = d.cross(e2)
                det = e1.dot(pv)
                u = 1.0 / 3.0
                v = 1.0 / 3.0
                if ti.abs(det) > 1e-30:
                    tv = eye - x0
                    u = tv.dot(pv) / det
                    v = d.dot(tv.cross(e1)) / det
                u = ti.min(ti.max(u, 0.0), 1.0)
                v = ti.min(ti.max(v, 0.0), 1.0 - u)
                c = (1.0 - u - v) * corner_color[3 * pid] + u * corner_color[3 * pid + 1] + v * corner_color[
                    3 * pid + 2]
                col = _lambert(c, corner_n[3 * pid], light_dir, light_color, ambient, two_sided)
            elif pid < n_tri + n_p:
                i = pid - n_tri
                r = particle_r[i]
                cv, w, sx, sy = _particle_screen(particle_x[i], view_t, w_px, h_px, ndc_sx, ndc_sy)
                rad = focal_px * r / w
                dx = (px + 0.5 - sx) / rad
                dy = (py + 0.5 - sy) / rad
                nz = ti.sqrt(ti.max(1.0 - dx * dx - dy * dy, 0.0))
                n = right * dx - up * dy + back * nz  # sphere normal under the pixel, world frame
                col = _lambert(particle_color[i], n, light_dir, light_color, ambient, 0)
            else:
                col = line_color[2 * (pid - n_tri - n_p)]
        col = ti.min(ti.max(col, 0.0), 1.0) * 255.0 + 0.5
        for k in ti.static(range(3)):
            out[py, px, k] = ti.cast(col[k], ti.u8)


def check_size(width: int, height: int) -> tuple[int, int]:
    """Validate an image size (px)."""
    if not (isinstance(width, int | np.integer) and isinstance(height, int | np.integer)):
        raise ConfigError("render.size", (width, height), "integer width and height in pixels")
    if not (1 <= width <= MAX_SIZE_PX and 1 <= height <= MAX_SIZE_PX):
        raise ConfigError("render.size", (width, height), f"1 .. {MAX_SIZE_PX} px per side")
    return int(width), int(height)


class RasterRenderer:
    """Software renderer (module docstring): `render(scene, camera)` -> (H, W, 3) uint8, row 0 at the top."""

    name = "raster"

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = check_size(width, height)
        fb = ti.FieldsBuilder()
        self.pix_key = ti.field(ti.i64)  # (H, W) -: (depth << 32) | (1 + primitive id), 0 = background
        fb.dense(ti.ij, (self.height, self.width)).place(self.pix_key)
        self._tree = fb.finalize()
        self.message = f"renderer: raster (Taichi software rasteriser, {self.width}x{self.height})"

    def release(self) -> None:
        if self._tree is not None:
            self._tree.destroy()
            self._tree = None

    def render(self, scene: RenderScene, camera: Camera) -> np.ndarray:
        """Draw the scene's current buffers (call scene.update() after changing poses)."""
        if self._tree is None:
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
        self.pix_key.fill(0)
        if scene.n_tris:
            _k_cover_triangles(scene.n_tris, vp_t, near, w, h, scene.corner_x, self.pix_key)
        if scene.n_particles:
            _k_cover_particles(scene.n_particles, scene.n_tris, view_t, ndc_sx, ndc_sy, p22, p32, focal_px, near,
                               w, h, scene.particle_x, scene.particle_r, self.pix_key)
        if scene.n_lines:
            width_px = max(int(round(scene.line_width)), 1)
            _k_cover_lines(scene.n_lines, scene.n_tris + scene.n_particles, vp_t, near, width_px, w, h,
                           scene.line_x, self.pix_key)
        vec3 = ti.math.vec3
        img = np.empty((h, w, 3), dtype=np.uint8)  # written in place by the kernel (row 0 = top)
        _k_shade(w, h, scene.n_tris, scene.n_particles, vec3(*camera.eye), vec3(*right), vec3(*up), vec3(*back),
                 ndc_sx, ndc_sy, view_t, p22, p32, focal_px, vec3(*lt.light_dir), vec3(*lt.light_color),
                 vec3(*lt.ambient), vec3(*lt.background), int(lt.two_sided), scene.corner_x, scene.corner_n,
                 scene.corner_color, scene.particle_x, scene.particle_r, scene.particle_color, scene.line_color,
                 self.pix_key, img)
        return img
