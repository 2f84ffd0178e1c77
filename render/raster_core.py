"""Shared pieces of the software rasteriser (render/raster.py): the key layout of the visibility
buffer (depth in the upper 32 bits, 1 + primitive id in the lower), projection to pixels, and the
edge-function scan of one triangle (used for coverage and for the shadow map)."""

import taichi as ti

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
def _raster_triangle(a, b, c, pid, w_px: ti.i32, h_px: ti.i32, buf: ti.template(), buf_see: ti.template(), see,
                     depth_only: ti.template()):
    """Cover the pixels whose centres lie in the screen triangle (a, b, c) = (x, y, depth): keys
    (depth z_ndc, id) into a visibility buffer (`buf_see` where `see` is set: a see-through
    triangle's layer), or (depth_only) the largest depth into a shadow map `buf`. One scan for both
    layers, the layer picked per write: each inlined copy of this loop costs the kernel that calls it
    frontend and JIT time at every start (docs/decisions.md, "Smaller kernels, sooner start")."""
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
                        if see:
                            ti.atomic_max(buf_see[py, px], _key(z, pid))
                        else:
                            ti.atomic_max(buf[py, px], _key(z, pid))


@ti.func
def _put_row(poly, m, v):
    for j in ti.static(range(4)):
        poly[m, j] = v[j]
    return poly


@ti.func
def _row(poly, s):
    return ti.Vector([poly[s, 0], poly[s, 1], poly[s, 2], poly[s, 3]])


@ti.func
def _particle_screen(x, view_t, w_px: ti.i32, h_px: ti.i32, ndc_sx: float, ndc_sy: float):
    """View position, view distance w and screen centre (x, y) px of a particle centre."""
    cv = view_t @ ti.Vector([x[0], x[1], x[2], 1.0])
    w = -cv[2]
    sx = (cv[0] * ndc_sx / w + 1.0) * 0.5 * w_px
    sy = (1.0 - cv[1] * ndc_sy / w) * 0.5 * h_px
    return cv, w, sx, sy
