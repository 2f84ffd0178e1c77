"""Lighting of the rasteriser (render/raster.py, steps 2-4 of its module doc): the key light's shadow
map (casters rasterised orthographically along the light), shading of the visibility buffer (ambient,
fill and key light with a percentage-closer-filtered shadow, a Blinn-Phong highlight by roughness,
see-through layers blended over the opaque surface) and the edge-filter resolve to uint8."""

import taichi as ti

from render.raster_core import ID_MASK, SHADOW_FILTER, _particle_screen, _raster_triangle


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
    """The key light's depth map: for every texel the largest height (x . light_dir) of a caster
    (cleared first in the same kernel: one kernel less to compile at a start)."""
    for ty, tx in ti.ndrange(size, size):
        shadow[ty, tx] = -1e30
    ldir = ti.Vector([lbasis[2, 0], lbasis[2, 1], lbasis[2, 2]])
    for t in range(n_tri):
        # a closed caster's faces turned away from the light lie below its lit faces: skip them
        # see-through (glass) transmits most of the light: it casts no shadow
        if corner_body[3 * t] >= 0 and corner_n[3 * t].dot(ldir) >= 0.0 and corner_look[3 * t][1] >= 1.0:
            a = _to_light(corner_x[3 * t], lbasis, lmap)
            b = _to_light(corner_x[3 * t + 1], lbasis, lmap)
            c = _to_light(corner_x[3 * t + 2], lbasis, lmap)
            _raster_triangle(a, b, c, t, size, size, shadow, shadow, 0, True)
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


@ti.func
def _resolve(w_px: ti.i32, h_px: ti.i32, antialias: ti.i32, pix_id: ti.template(), pix_rgb: ti.template(),
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


@ti.kernel
def _k_shade(w_px: ti.i32, h_px: ti.i32, n_tri: ti.i32, n_p: ti.i32, eye: ti.math.vec3, right: ti.math.vec3,
             up: ti.math.vec3, back: ti.math.vec3, ndc_sx: float, ndc_sy: float, view_t: ti.math.mat4,
             focal_px: float, lt: ti.types.matrix(6, 3, float), background: ti.math.vec3, two_sided: ti.i32,
             lbasis: ti.math.mat3, lmap: ti.math.vec3, size: ti.i32, shadow: ti.template(),
             corner_x: ti.template(), corner_n: ti.template(), corner_color: ti.template(),
             corner_look: ti.template(), particle_x: ti.template(), particle_r: ti.template(),
             particle_color: ti.template(), line_color: ti.template(), pix_key: ti.template(),
             pix_key_t: ti.template(), pix_rgb: ti.template(), pix_id: ti.template(), antialias: ti.i32,
             out: ti.types.ndarray(ndim=3)):
    """Steps 3-4 of render/raster.py: shading, then (`_resolve`) the edge filter into `out`; one
    kernel, not two, to compile at a start."""
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
    _resolve(w_px, h_px, antialias, pix_id, pix_rgb, out)
