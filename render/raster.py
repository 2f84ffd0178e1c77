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
"""


import numpy as np
import taichi as ti

from core.errors import ConfigError
from render.camera import Camera, box_corners
from render.scene_data import RenderScene

DEPTH_LEVELS = 2**31 - 1  # z_ndc in [0, 1] is quantised to this many levels in the upper 32 bits of a key
ID_MASK = 2**32 - 1  # lower 32 bits of a key: 1 + primitive id (0 = empty pixel)
MAX_SIZE_PX = 8192  # px: largest image side accepted
SHADOW_TEXELS = 512  # texels per side of the key light's shadow map
SHADOW_FILTER = 2  # texels: half-width of the percentage-closer filter (soft shadow edges)
SHADOW_MARGIN = 0.02  # -: the map covers the casters' bounds grown by this share of their size


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
def _raster_triangle(a, b, c, pid, w_px: ti.i32, h_px: ti.i32, buf: ti.template(), depth_only: ti.template()):
    """Cover the pixels whose centres lie in the screen triangle (a, b, c) = (x, y, depth): keys
    (depth z_ndc, id) into a visibility buffer, or (depth_only) the largest depth into a shadow map."""
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
                    z = (e0 * a[2] + e1 * b[2] + e2 * c[2]) * inv_area  # depth is affine in screen space
                    if ti.static(depth_only):
                        ti.atomic_max(buf[py, px], z)
                    elif z >= 0.0:
                        ti.atomic_max(buf[py, px], _key(z, pid))


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


@ti.func
def _cover_clipped(c0, c1, c2, t, near, w_px: ti.i32, h_px: ti.i32, buf: ti.template()):
    """Cover one clip-space triangle, clipped against w >= near (Sutherland-Hodgman: 3 or 4 vertices)."""
    n_in = ti.cast(c0[3] >= near, ti.i32) + ti.cast(c1[3] >= near, ti.i32) + ti.cast(c2[3] >= near, ti.i32)
    if n_in == 3:
        _raster_triangle(_to_screen(c0, w_px, h_px), _to_screen(c1, w_px, h_px), _to_screen(c2, w_px, h_px),
                         t, w_px, h_px, buf, False)
    elif n_in > 0:
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
        _raster_triangle(s0, s1, s2, t, w_px, h_px, buf, False)
        if m == 4:
            s3 = _to_screen(_row(poly, 3), w_px, h_px)
            _raster_triangle(s0, s2, s3, t, w_px, h_px, buf, False)


@ti.kernel
def _k_cover_triangles(n_tri: ti.i32, vp_t: ti.math.mat4, near: float, w_px: ti.i32, h_px: ti.i32, eye: ti.math.vec3,
                       cull: ti.i32, corner_x: ti.template(), corner_n: ti.template(), corner_look: ti.template(),
                       pix_key: ti.template(), pix_key_t: ti.template()):
    for t in range(n_tri):
        # a face turned away from the eye is hidden by the front of its closed surface (one-sided shading)
        if cull and (corner_x[3 * t] - eye).dot(corner_n[3 * t]) > 0.0:
            continue
        c0 = vp_t @ ti.Vector([corner_x[3 * t][0], corner_x[3 * t][1], corner_x[3 * t][2], 1.0])
        c1 = vp_t @ ti.Vector([corner_x[3 * t + 1][0], corner_x[3 * t + 1][1], corner_x[3 * t + 1][2], 1.0])
        c2 = vp_t @ ti.Vector([corner_x[3 * t + 2][0], corner_x[3 * t + 2][1], corner_x[3 * t + 2][2], 1.0])
        if corner_look[3 * t][1] < 1.0:  # see-through: its own layer, blended over the opaque one
            _cover_clipped(c0, c1, c2, t, near, w_px, h_px, pix_key_t)
        else:
            _cover_clipped(c0, c1, c2, t, near, w_px, h_px, pix_key)


@ti.func
def _to_light(x, lbasis, lmap):
    """World point -> (u texel, v texel, height towards the light) in the shadow map's frame."""
    q = lbasis @ x
    return ti.Vector([(q[0] - lmap[0]) * lmap[2], (q[1] - lmap[1]) * lmap[2], q[2]])


@ti.kernel
def _k_shadow_casters(n_tri: ti.i32, n_p: ti.i32, lbasis: ti.math.mat3, lmap: ti.math.vec3, size: ti.i32,
                      corner_x: ti.template(), corner_n: ti.template(), corner_body: ti.template(),
                      corner_look: ti.template(), particle_x: ti.template(), particle_r: ti.template(),
                      shadow: ti.template()):
    """The key light's depth map: for every texel the largest height (x . light_dir) of a caster."""
    ldir = ti.Vector([lbasis[2, 0], lbasis[2, 1], lbasis[2, 2]])
    for t in range(n_tri):
        # a closed caster's faces turned away from the light lie below its lit faces: skip them
        # see-through (glass) transmits most of the light: it casts no shadow
        if corner_body[3 * t] >= 0 and corner_n[3 * t].dot(ldir) >= 0.0 and corner_look[3 * t][1] >= 1.0:
            a = _to_light(corner_x[3 * t], lbasis, lmap)
            b = _to_light(corner_x[3 * t + 1], lbasis, lmap)
            c = _to_light(corner_x[3 * t + 2], lbasis, lmap)
            _raster_triangle(a, b, c, t, size, size, shadow, True)
    for i in range(n_p):
        ctr = _to_light(particle_x[i], lbasis, lmap)
        rad = particle_r[i] * lmap[2]
        x0 = ti.max(ti.cast(ti.floor(ctr[0] - rad), ti.i32), 0)
        x1 = ti.min(ti.cast(ti.ceil(ctr[0] + rad), ti.i32), size - 1)
        y0 = ti.max(ti.cast(ti.floor(ctr[1] - rad), ti.i32), 0)
        y1 = ti.min(ti.cast(ti.ceil(ctr[1] + rad), ti.i32), size - 1)
        for py in range(y0, y1 + 1):
            for px in range(x0, x1 + 1):
                dx = px + 0.5 - ctr[0]
                dy = py + 0.5 - ctr[1]
                if dx * dx + dy * dy <= ti.max(rad * rad, 0.5):
                    ti.atomic_max(shadow[py, px], ctr[2] + particle_r[i])


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
def _lit_fraction(p, n, lbasis, lmap, size: ti.i32, shadow: ti.template()):
    """Share of the key light reaching p (normal n, facing the light): percentage-closer filtering of
    (2 SHADOW_FILTER + 1)^2 texels, which softens the shadow's edge over that many texels. Offsets:
    1.5 texels along the normal and one texel towards the light keep a lit face from shadowing itself."""
    texel = 1.0 / lmap[2]
    q = _to_light(p + n * (1.5 * texel), lbasis, lmap)
    d = q[2] + texel
    cx = ti.cast(ti.floor(q[0]), ti.i32)
    cy = ti.cast(ti.floor(q[1]), ti.i32)
    k = SHADOW_FILTER
    lit = 1.0
    if -k <= cx and cx < size + k and -k <= cy and cy < size + k:  # outside the map nothing is above p
        # the filter's four corner taps agree away from a shadow's rim: then the whole filter does
        corners = 0.0
        for c in range(4):
            corners += _tap(cx + (2 * (c % 2) - 1) * k, cy + (2 * (c // 2) - 1) * k, d, size, shadow)
        lit = corners / 4.0
        if 0.0 < corners and corners < 4.0:
            lit = 0.0
            for t in range((2 * k + 1) ** 2):  # runtime loops: a small kernel to compile
                lit += _tap(cx + t % (2 * k + 1) - k, cy + t // (2 * k + 1) - k, d, size, shadow)
            lit /= (2 * k + 1) ** 2
    return lit


@ti.func
def _tap(tx, ty, d, size: ti.i32, shadow: ti.template()):
    """1.0 where the point at height d is above every caster of texel (tx, ty) (or off the map)."""
    r = 1.0
    if 0 <= tx and tx < size and 0 <= ty and ty < size and d < shadow[ty, tx]:
        r = 0.0
    return r


@ti.func
def _shade_point(c, n, p, to_eye, rough, two_sided: ti.i32, lt: ti.template(), lbasis, lmap, size: ti.i32,
                 shadow: ti.template()):
    """Colour of a surface point: ambient + fill light + key light (Lambert, GGUI's formula when the
    studio terms are off) x the lit fraction, + a Blinn-Phong highlight whose sharpness follows the
    roughness. lt = (light_dir, light_color, ambient, fill_dir, fill_color) as rows; lbasis, lmap:
    the shadow map's frame (lmap[2] = 0: no shadows)."""
    ldir = ti.Vector([lt[0, 0], lt[0, 1], lt[0, 2]])
    lcol = ti.Vector([lt[1, 0], lt[1, 1], lt[1, 2]])
    amb = ti.Vector([lt[2, 0], lt[2, 1], lt[2, 2]])
    fdir = ti.Vector([lt[3, 0], lt[3, 1], lt[3, 2]])
    fcol = ti.Vector([lt[4, 0], lt[4, 1], lt[4, 2]])
    ndl = n.dot(ldir)
    ndf = n.dot(fdir)
    nl = n  # the normal on the light's side (a two-sided face is lit on both)
    if two_sided:
        if ndl < 0.0:
            nl = -n
        ndl = ti.abs(ndl)
        ndf = ti.abs(ndf)
    ndl = ti.max(ndl, 0.0)
    lit = 1.0
    if lmap[2] > 0.0 and ndl > 0.0:
        lit = _lit_fraction(p, nl, lbasis, lmap, size, shadow)
    col = c * (amb + fcol * ti.max(ndf, 0.0) + lcol * (ndl * lit))
    if lt[5, 0] > 0.0 and ndl > 0.0:  # specular
        h = (ldir + to_eye).normalized()
        r2 = ti.max(rough * rough, 1e-3)
        shininess = 2.0 / r2 - 2.0 + 1.0
        ks = 0.04 + 0.5 * (1.0 - rough) ** 2
        col += lcol * (ks * lit * ti.max(nl.dot(h), 0.0) ** shininess)
    return col


@ti.func
def _triangle_hit(pid, d, eye, corner_x):
    """Barycentrics (u, v) and point where the view ray eye + s d meets triangle pid (Moller-Trumbore)."""
    x0 = corner_x[3 * pid]
    e1 = corner_x[3 * pid + 1] - x0
    e2 = corner_x[3 * pid + 2] - x0
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
    return u, v, x0 + u * e1 + v * e2


@ti.kernel
def _k_shade(w_px: ti.i32, h_px: ti.i32, n_tri: ti.i32, n_p: ti.i32, eye: ti.math.vec3, right: ti.math.vec3,
             up: ti.math.vec3, back: ti.math.vec3, ndc_sx: float, ndc_sy: float, view_t: ti.math.mat4,
             focal_px: float, lt: ti.types.matrix(6, 3, float), background: ti.math.vec3, two_sided: ti.i32,
             lbasis: ti.math.mat3, lmap: ti.math.vec3, size: ti.i32, shadow: ti.template(),
             corner_x: ti.template(), corner_n: ti.template(), corner_color: ti.template(),
             corner_look: ti.template(), particle_x: ti.template(), particle_r: ti.template(),
             particle_color: ti.template(), line_color: ti.template(), pix_key: ti.template(),
             pix_key_t: ti.template(), pix_rgb: ti.template(), pix_id: ti.template()):
    for py, px in pix_key:
        key = pix_key[py, px]
        ndc_x = 2.0 * (px + 0.5) / w_px - 1.0
        ndc_y = 1.0 - 2.0 * (py + 0.5) / h_px
        d = right * (ndc_x / ndc_sx) + up * (ndc_y / ndc_sy) - back  # view ray through the pixel
        to_eye = -d.normalized()
        col = background
        # the surface under the pixel: the opaque one (triangle or particle), then the see-through
        # triangle in front of it; one call site of _shade_point keeps the kernel small to compile
        for layer in range(2):
            k = key if layer == 0 else pix_key_t[py, px]
            pid = ti.cast(k & ti.i64(ID_MASK), ti.i32) - 1
            if k == 0 or (layer == 1 and k <= key):  # nothing there, or the see-through one is behind
                continue
            if layer == 0 and pid >= n_tri + n_p:
                col = line_color[2 * (pid - n_tri - n_p)]
                continue
            c = ti.Vector([0.0, 0.0, 0.0])
            n = ti.Vector([0.0, 0.0, 1.0])
            p = ti.Vector([0.0, 0.0, 0.0])
            rough = 0.6
            opacity = 1.0
            sided = two_sided
            if layer == 1 or pid < n_tri:
                u, v, hit = _triangle_hit(pid, d, eye, corner_x)
                c = (1.0 - u - v) * corner_color[3 * pid] + u * corner_color[3 * pid + 1] + v * corner_color[
                    3 * pid + 2]
                n = corner_n[3 * pid]
                p = hit
                rough = corner_look[3 * pid][0]
                opacity = corner_look[3 * pid][1]
                if layer == 1:
                    sided = 1  # both faces of a pane are lit
            else:
                i = pid - n_tri
                r = particle_r[i]
                cv, w, sx, sy = _particle_screen(particle_x[i], view_t, w_px, h_px, ndc_sx, ndc_sy)
                rad = focal_px * r / w
                dx = (px + 0.5 - sx) / rad
                dy = (py + 0.5 - sy) / rad
                nz = ti.sqrt(ti.max(1.0 - dx * dx - dy * dy, 0.0))
                n = right * dx - up * dy + back * nz  # sphere normal under the pixel, world frame
                c = particle_color[i]
                p = particle_x[i] + r * n
                sided = 0
            shaded = _shade_point(c, n, p, to_eye, rough, sided, lt, lbasis, lmap, size, shadow)
            if layer == 0:
                col = shaded
            else:
                col = opacity * shaded + (1.0 - opacity) * col
        key_t = pix_key_t[py, px]
        pix_rgb[py, px] = col
        pix_id[py, px] = ti.cast((key & ti.i64(ID_MASK)) * 7919 + (key_t & ti.i64(ID_MASK)), ti.i32)  # edge filter
        pix_key[py, px] = 0  # cleared for the next frame: no separate fill pass
        pix_key_t[py, px] = 0


@ti.kernel
def _k_resolve(w_px: ti.i32, h_px: ti.i32, antialias: ti.i32, pix_id: ti.template(), pix_rgb: ti.template(),
               out: ti.types.ndarray(ndim=3)):
    """Colours -> uint8 (row 0 on top). With antialias, a pixel on an edge between primitives (an id
    differing from a 4-neighbour's) is blended with its neighbours: a one-pixel edge filter."""
    for py, px in pix_rgb:
        col = pix_rgb[py, px]
        if antialias:
            me = pix_id[py, px]
            acc = ti.Vector([0.0, 0.0, 0.0])
            edge = 0
            for k in ti.static(range(4)):
                qx = ti.min(ti.max(px + (k == 0) - (k == 1), 0), w_px - 1)
                qy = ti.min(ti.max(py + (k == 2) - (k == 3), 0), h_px - 1)
                acc += pix_rgb[qy, qx]
                if pix_id[qy, qx] != me:
                    edge = 1
            if edge:
                col = 0.5 * col + 0.125 * acc
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
        self.pix_key = ti.field(ti.i64)  # (H, W) -: (depth << 32) | (1 + primitive id) of opaque ones, 0 = none
        self.pix_key_t = ti.field(ti.i64)  # (H, W) -: the same for the nearest see-through triangle
        self.pix_rgb = ti.math.vec3.field()  # (H, W) -: shaded linear RGB before the edge filter
        self.pix_id = ti.field(ti.i32)  # (H, W) -: a hash of the primitives drawn there (edges differ)
        fb.dense(ti.ij, (self.height, self.width)).place(self.pix_key, self.pix_key_t, self.pix_rgb, self.pix_id)
        self.shadow = ti.field(float)  # (S, S) m: largest caster height towards the key light per texel
        fb.dense(ti.ij, (SHADOW_TEXELS, SHADOW_TEXELS)).place(self.shadow)
        self._tree = fb.finalize()
        self.pix_key.fill(0)  # touch the tree: destroying one never touched makes the next one crash (Taichi 1.7.4)
        self.message = f"renderer: raster (Taichi software rasteriser, {self.width}x{self.height})"

    def release(self) -> None:
        if self._tree is not None:
            self._tree.destroy()
            self._tree = None

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
        self.shadow.fill(-1e30)
        _k_shadow_casters(scene.n_tris, scene.n_particles, lbasis, lmap, SHADOW_TEXELS, scene.corner_x,
                          scene.corner_n, scene.corner_body, scene.corner_look, scene.particle_x, scene.particle_r,
                          self.shadow)
        return lbasis, lmap

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
        if scene.n_tris:
            _k_cover_triangles(scene.n_tris, vp_t, near, w, h, ti.math.vec3(*camera.eye), int(not lt.two_sided),
                               scene.corner_x, scene.corner_n, scene.corner_look, self.pix_key, self.pix_key_t)
        if scene.n_particles:
            _k_cover_particles(scene.n_particles, scene.n_tris, view_t, ndc_sx, ndc_sy, p22, p32, focal_px, near,
                               w, h, scene.particle_x, scene.particle_r, self.pix_key)
        if scene.n_lines:
            width_px = max(int(round(scene.line_width)), 1)
            _k_cover_lines(scene.n_lines, scene.n_tris + scene.n_particles, vp_t, near, width_px, w, h,
                           scene.line_x, self.pix_key)
        lbasis, lmap = self._shadow_map(scene)
        vec3 = ti.math.vec3
        lights = ti.types.matrix(6, 3, float)(np.stack([
            lt.light_dir, lt.light_color, lt.ambient, lt.fill_dir, lt.fill_color, [float(lt.specular), 0.0, 0.0]]))
        _k_shade(w, h, scene.n_tris, scene.n_particles, vec3(*camera.eye), vec3(*right), vec3(*up), vec3(*back),
                 ndc_sx, ndc_sy, view_t, focal_px, lights, vec3(*lt.background), int(lt.two_sided), lbasis, lmap,
                 SHADOW_TEXELS, self.shadow, scene.corner_x, scene.corner_n, scene.corner_color, scene.corner_look,
                 scene.particle_x, scene.particle_r, scene.particle_color, scene.line_color, self.pix_key,
                 self.pix_key_t, self.pix_rgb, self.pix_id)
        img = np.empty((h, w, 3), dtype=np.uint8)  # written in place by the kernel (row 0 = top)
        _k_resolve(w, h, int(lt.antialias), self.pix_id, self.pix_rgb, img)
        return img
