"""The Taichi field trees of a RenderScene (render/scene_data.py), one per kind of buffer, and the
kernels that write a range of its triangle corners (a body's block after a fracture event, or blanks
where a block was). Trees are taken from and given back to core/field_pool.py by the scene.
"""

import taichi as ti


def make_buffers(kind: str, cap: int) -> dict:
    """A new field tree of one kind of RenderScene buffers for `cap` items: {attribute name: field}."""
    vec3, vec4 = ti.math.vec3, ti.math.vec4
    fb = ti.FieldsBuilder()
    if kind == "surf":
        f = dict(
            corner_ref=vec3.field(),  # (3T,) m: corner position in its body's reference frame
            corner_body=ti.field(ti.i32),  # (3T,) -: body id of the corner, -1 = static world geometry
            corner_color=vec3.field(),  # (3T,) -: linear RGB in [0, 1]
            corner_look=ti.math.vec2.field(),  # (3T,) -: (roughness, opacity) of the corner's part
            corner_x=vec3.field(),  # (3T,) m: world position (changing, written by update())
            corner_n=vec3.field(),  # (3T,) -: unit world normal of the corner's face (changing)
        )
        n = 3 * cap
    elif kind == "pose":
        f = dict(
            pose_x=vec3.field(),  # (B,) m: world position of the body's centre of mass
            pose_q=vec4.field(),  # (B,) -: unit quaternion w-x-y-z, body frame -> world
            pose_ref_com=vec3.field(),  # (B,) m: centre of mass in reference coordinates
        )
        n = cap
    elif kind == "part":
        f = dict(
            particle_x=vec3.field(),  # (P,) m: world position
            particle_r=ti.field(float),  # (P,) m: radius
            particle_color=vec3.field(),  # (P,) -: linear RGB in [0, 1]
        )
        n = cap
    elif kind == "line":
        f = dict(
            line_x=vec3.field(),  # (2L,) m: segment end points, segment j = (2j, 2j + 1)
            line_color=vec3.field(),  # (2L,) -: linear RGB per end point (both ends equal)
        )
        n = 2 * cap
    else:
        f = dict(_bounds=vec3.field())  # (2,) m: lo, hi of the last body_bounds query
        n = 2
    for field_ in f.values():
        fb.dense(ti.i, n).place(field_)
    fb.finalize()
    return f


@ti.kernel
def _k_put_corners(start: ti.i32, n: ti.i32, ref: ti.types.ndarray(), body: ti.types.ndarray(),
                   col: ti.types.ndarray(), look: ti.types.ndarray(), corner_ref: ti.template(),
                   corner_body: ti.template(), corner_color: ti.template(), corner_look: ti.template()):
    for c in range(n):
        corner_ref[start + c] = ti.Vector([ref[c, 0], ref[c, 1], ref[c, 2]])
        corner_body[start + c] = body[c]
        corner_color[start + c] = ti.Vector([col[c, 0], col[c, 1], col[c, 2]])
        corner_look[start + c] = ti.Vector([look[c, 0], look[c, 1]])


@ti.kernel
def _k_blank_corners(start: ti.i32, n: ti.i32, corner_ref: ti.template(), corner_body: ti.template()):
    """Degenerate static triangles (every corner at the origin, body -1): no renderer covers a pixel
    with them, no shadow or bounds query counts them."""
    for c in range(n):
        corner_ref[start + c] = ti.Vector([0.0, 0.0, 0.0])
        corner_body[start + c] = -1
