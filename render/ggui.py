"""Offscreen frames through Taichi's GGUI (Vulkan), without a window (DESIGN.md section 2, render/).

`GGUIRenderer` opens `ti.ui.Window(..., show_window=False)` once and draws a `RenderScene` into it:
the triangle corners as one non-indexed mesh (`vertex_count` = 3 x triangles of capacity-sized
fields), the particles with `index_count`, the line segments with `vertex_count`. The light is the
scene's directional light, given to GGUI as a point light LIGHT_DISTANCE_FAR_PLANES far planes away
along `light_dir` (GGUI has no directional light); GGUI's shading is then the rasteriser's:
`c (ambient + light max(n.l, 0))` (|n.l| for two-sided meshes), checked in tests.

Vertex data reaches GGUI through float32 staging arrays owned by the renderer (see `draw`: Taichi
1.7.4's own `scene.mesh` frees its staging array before GGUI reads it, which gave empty frames).

GGUI draws a particle of radius r with a screen radius of r W / (2 tan(fov/2) w) pixels (it uses the
window *width* where the vertical field of view needs the height; measured, Taichi 1.7.4), so radii
are scaled by H / W on their way to GGUI: spheres then have their true projected size.

`get_image_buffer_as_numpy()` returns (W, H, 4) floats indexed [x, y from the bottom]; `np.rot90`
turns it into rows from the top. Reading the image ends the frame, so each frame is drawn once and
read once. `window.show()` is never called (it crashes without a window).

`vulkan_available()` answers whether GGUI can start here without risking this process: it runs a
tiny GGUI program in a subprocess once and caches the answer (ANISOFRAC_VULKAN=0/1 overrides it).
"""

import os
import subprocess
import sys
import tempfile

import numpy as np
import taichi as ti

from core.errors import BackendError
from render.camera import Camera
from render.raster import check_size
from render.scene_data import RenderScene

LIGHT_DISTANCE_FAR_PLANES = 1e4  # -: point light distance from the target, in units of max(far, 1 m)
PROBE_TIMEOUT_S = 120.0  # s: limit for the Vulkan probe subprocess
_LOG_LEVELS = ("trace", "debug", "info", "warn", "error", "critical")

_PROBE = r"""
import taichi as ti
ti.init(arch=ti.cpu, log_level=ti.ERROR)
w = ti.ui.Window("anisofrac-probe", (16, 8), show_window=False)
c = w.get_canvas()
c.set_background_color((1.0, 0.0, 0.0))
s = w.get_scene()
cam = ti.ui.Camera()
s.set_camera(cam)
c.scene(s)
img = w.get_image_buffer_as_numpy()
ok = img.shape == (16, 8, 4) and float(img[..., 0].min()) > 0.9 and float(img[..., 1].max()) < 0.1
print("ANISOFRAC_VULKAN_OK" if ok else "ANISOFRAC_VULKAN_BAD_IMAGE", flush=True)
w.destroy()
"""

_vulkan_status: tuple[bool, str] | None = None


def vulkan_status() -> tuple[bool, str]:
    """(available, reason): whether headless GGUI works on this machine, probed once in a subprocess."""
    global _vulkan_status
    if _vulkan_status is not None:
        return _vulkan_status
    env = os.environ.get("ANISOFRAC_VULKAN", "").strip()
    if env in ("0", "1"):
        _vulkan_status = (env == "1", f"set by ANISOFRAC_VULKAN={env}")
        return _vulkan_status
    try:
        with tempfile.TemporaryDirectory(prefix="anisofrac-vkprobe-") as cwd:  # ImGui drops imgui.ini in the cwd
            out = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, cwd=cwd,
                                 timeout=PROBE_TIMEOUT_S, env={**os.environ, "TI_LOG_LEVEL": "error"})
        if out.returncode == 0 and "ANISOFRAC_VULKAN_OK" in out.stdout:
            _vulkan_status = (True, "GGUI offscreen probe rendered a frame")
        else:
            tail = (out.stdout + out.stderr).strip().splitlines()[-3:]
            why = f"exit status {out.returncode}" if out.returncode else "wrong probe image"
            _vulkan_status = (False, f"GGUI probe failed ({why}): {' | '.join(tail)[:300]}")
    except subprocess.TimeoutExpired:
        _vulkan_status = (False, f"GGUI probe did not finish in {PROBE_TIMEOUT_S:.0f} s")
    except OSError as exc:
        _vulkan_status = (False, f"GGUI probe could not start: {exc}")
    return _vulkan_status


def known_vulkan_status() -> tuple[bool, str] | None:
    """`vulkan_status()` where this process has it already, else None (nothing is probed)."""
    return _vulkan_status


def assume_vulkan_status(status: tuple[bool, str]) -> None:
    """Take another process's `vulkan_status()` (the drawing process takes the simulation's)."""
    global _vulkan_status
    _vulkan_status = (bool(status[0]), str(status[1]))


def vulkan_available() -> bool:
    """True when GGUI can render offscreen here (Vulkan driver present and working)."""
    return vulkan_status()[0]


class _quiet_taichi:
    """Raise Taichi's log level to 'error' for a block: the staging kernels (f64 fields -> GGUI's float32
    vertices) and GGUI's own kernels warn about precision loss when they compile under default_fp=f64."""

    def __enter__(self):
        self.level = next((lv for lv in _LOG_LEVELS if ti.is_logging_effective(lv)), "warn")
        if _LOG_LEVELS.index(self.level) < _LOG_LEVELS.index("error"):
            ti.set_logging_level("error")
        return self

    def __exit__(self, *exc):
        ti.set_logging_level(self.level)
        return False


# GGUI's vertex layout (taichi/ui/staging_buffer.py): 12 float32 per vertex = position (3), normal or
# particle radius (3), texture coordinates (2), RGBA (4).
VBO_STRIDE = 12


@ti.kernel
def _k_fill_mesh_vbo(n: ti.i32, vbo: ti.types.ndarray(ndim=2), x: ti.template(), nrm: ti.template(),
                     col: ti.template()):
    for i in range(n):
        for k in ti.static(range(3)):
            vbo[i, k] = x[i][k]
            vbo[i, 3 + k] = nrm[i][k]
            vbo[i, 8 + k] = col[i][k]
        vbo[i, 11] = 1.0


@ti.kernel
def _k_fill_particle_vbo(n: ti.i32, scale: float, vbo: ti.types.ndarray(ndim=2), x: ti.template(),
                         r: ti.template(), col: ti.template()):
    for i in range(n):
        for k in ti.static(range(3)):
            vbo[i, k] = x[i][k]
            vbo[i, 8 + k] = col[i][k]
        vbo[i, 3] = r[i] * scale
        vbo[i, 11] = 1.0


@ti.kernel
def _k_fill_line_vbo(n: ti.i32, vbo: ti.types.ndarray(ndim=2), x: ti.template(), col: ti.template()):
    for i in range(n):
        for k in ti.static(range(3)):
            vbo[i, k] = x[i][k]
            vbo[i, 8 + k] = col[i][k]
        vbo[i, 11] = 1.0


class GGUIDrawer:
    """Declares a `RenderScene` into any GGUI scene and canvas: the offscreen renderer below and, later,
    the interactive viewer's window share it. Holds the GGUI camera and the vertex staging arrays."""

    def __init__(self) -> None:
        self.ti_camera = ti.ui.Camera()
        self._vbos: dict = {}

    def _vbo(self, kind: str, field) -> np.ndarray:
        """GGUI staging array for one drawn field, kept alive by this object (see `draw`)."""
        cur = self._vbos.get(kind)
        if cur is None or cur[0] is not field:
            # float32: GGUI's vertex format, whatever the simulation precision
            self._vbos[kind] = (field, np.zeros((field.shape[0], VBO_STRIDE), dtype=np.float32))
        return self._vbos[kind][1]

    def draw(self, scene: RenderScene, camera: Camera, ti_scene, canvas, width: int, height: int) -> None:
        """Declare one frame of `scene` seen by `camera` into a GGUI scene/canvas of width x height px.

        Uses GGUI's lower-level calls (`SceneV2.scene.mesh/particles/lines` with `FieldInfo`s of numpy
        staging arrays) because Taichi 1.7.4's `SceneV2.mesh/particles/lines` hand GGUI the address of a
        numpy array allocated inside the call and freed when it returns; GGUI reads it when the frame is
        rendered, so frames came out empty at random (measured: in roughly a third of the processes
        tried). Our staging arrays live as long as this object, and only the used part is filled.
        """
        from taichi.ui.utils import get_field_info

        lt = scene.lighting
        camera.to_ggui(self.ti_camera)
        ti_scene.set_camera(self.ti_camera)
        ti_scene.ambient_light(tuple(float(c) for c in lt.ambient))
        dist = LIGHT_DISTANCE_FAR_PLANES * max(float(camera.far), 1.0)
        ti_scene.point_light(tuple(float(c) for c in camera.target + lt.light_dir * dist),
                             tuple(float(c) for c in lt.light_color))
        if np.any(lt.fill_color > 0.0):  # the studio look's fill light; GGUI has no shadows or highlights
            ti_scene.point_light(tuple(float(c) for c in camera.target + lt.fill_dir * dist),
                                 tuple(float(c) for c in lt.fill_color))
        grey = (0.5, 0.5, 0.5)  # GGUI's uniform colour argument, unused with per-vertex colours
        no_indices = get_field_info(None)
        if scene.n_tris:
            n = 3 * scene.n_tris
            vbo = self._vbo("mesh", scene.corner_x)
            _k_fill_mesh_vbo(n, vbo, scene.corner_x, scene.corner_n, scene.corner_color)
            ti_scene.scene.mesh(get_field_info(vbo), True, no_indices, grey, bool(lt.two_sided), n, 0, n, 0, False)
        if scene.n_particles:
            n = scene.n_particles
            vbo = self._vbo("particles", scene.particle_x)
            _k_fill_particle_vbo(n, height / width, vbo, scene.particle_x, scene.particle_r, scene.particle_color)
            ti_scene.scene.particles(get_field_info(vbo), True, True, grey, 0.0, n, 0)
        if scene.n_lines:
            n = 2 * scene.n_lines
            vbo = self._vbo("lines", scene.line_x)
            _k_fill_line_vbo(n, vbo, scene.line_x, scene.line_color)
            ti_scene.scene.lines(get_field_info(vbo), no_indices, True, grey, float(scene.line_width), n, 0, n, 0)
        canvas.set_background_color(tuple(float(c) for c in lt.background))
        canvas.scene(ti_scene)

    def release(self) -> None:
        self._vbos = {}


class GGUIRenderer:
    """Headless GGUI renderer (module docstring): `render(scene, camera)` -> (H, W, 3) uint8, row 0 on top."""

    name = "ggui"

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = check_size(width, height)
        ok, why = vulkan_status()
        if not ok:
            raise BackendError(f"renderer 'ggui' needs Vulkan, which is not available here: {why}; "
                               "use --renderer raster (or install mesa-vulkan-drivers)")
        # GGUI's ImGui writes imgui.ini into the working directory when the window is destroyed
        self._imgui_ini = os.path.abspath("imgui.ini")
        self._imgui_ini_existed = os.path.exists(self._imgui_ini)
        with _quiet_taichi():
            self.window = ti.ui.Window("anisofrac", (self.width, self.height), show_window=False)
        self.canvas = self.window.get_canvas()
        self.ti_scene = self.window.get_scene()
        self.drawer = GGUIDrawer()
        self.message = f"renderer: ggui (Vulkan offscreen, {self.width}x{self.height}; {why})"
        self._warm_up()

    def _warm_up(self) -> None:
        """Draw and discard a frame of every kind of primitive (a one- and a two-sided mesh, particles,
        lines). Taichi 1.7.4 frees a frame's vertex buffers right after its asynchronous submit, before
        lavapipe's submit thread has drawn it (docs/decisions.md, "Headless frames"); the frames that came
        back empty (sessions 10 and 16, in full test runs under load) were each the first draw of a new
        renderer, whose pipelines lavapipe builds at that draw: the longest way from submit to reading
        the buffers. A mitigation of the upstream race, not a cure: later draws find the pipelines built."""
        from render.primitives import box_mesh
        from render.scene_data import Lighting, MeshPart

        scene = RenderScene(tri_capacity=12, body_capacity=1, particle_capacity=1, line_capacity=1)
        try:
            v, f = box_mesh([0.1, 0.1, 0.1])
            scene.set_surfaces([MeshPart(v, f, -1)])
            scene.set_particles([[0.15, 0.0, 0.0]], 0.02)
            scene.set_lines([[-0.1, 0.1, 0.0]], [[0.1, 0.1, 0.0]])
            camera = Camera(eye=[0.5, 0.4, 0.6], target=[0.0, 0.0, 0.0])
            for two_sided in (False, True):
                scene.lighting = Lighting(two_sided=two_sided)
                self.render(scene, camera)
        finally:
            scene.release()

    def render(self, scene: RenderScene, camera: Camera) -> np.ndarray:
        """Draw the scene's current buffers offscreen and read the frame back."""
        if self.window is None:
            raise RuntimeError("GGUIRenderer.render after release()")
        with _quiet_taichi():
            self.drawer.draw(scene, camera, self.ti_scene, self.canvas, self.width, self.height)
            img = self.window.get_image_buffer_as_numpy()  # (W, H, 4) float, [x, y from the bottom]
        rgb = np.rot90(img)[:, :, :3]
        return np.ascontiguousarray(np.rint(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8))

    def release(self) -> None:
        if self.window is not None:
            self.window.destroy()
            self.window = None
            if not self._imgui_ini_existed and os.path.exists(self._imgui_ini):
                os.remove(self._imgui_ini)  # not ours to leave behind
        self.drawer.release()
