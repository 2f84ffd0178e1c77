"""The interactive viewer (`python main.py view SCENE`, DESIGN.md sections 1 and 7): a GGUI window on
a World built from the scene. Orbit, shoot a ball, click to strike, tune the number of cracks, the
tensile strength or the kernel anisotropy, and watch the paper's Table 1 counts and Table 2 timings.

One window frame:
    input (keys, mouse, panel buttons) -> scripted actions of this frame -> one World frame (unless
    paused) -> surfaces and poses (viewer.overlay.ViewerScene) -> the point under the cursor
    (render.pick) -> crack preview (viewer.actions.preview_strike, throttled) ->
    overlays (particles, links, kernels, crack discs) -> GGUIDrawer + ImGui panel -> screenshot -> show.

The pieces live in viewer/input.py (keys, mouse), panel.py (ImGui), overlay.py (what is drawn over
the bodies, colour modes), actions.py (what is done to the World, through the Python API) and
script.py (`--script`); ray casting is render/pick.py. The viewer is an application on top of the
API (anisofrac): it holds a Simulation. Controls: docs/viewer.md.
"""

from __future__ import annotations

import os
import sys
import time
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from anisofrac.simulation import Simulation
from anisofrac.strikes import body_frames, breakable, to_reference
from core.errors import BackendError, SandboxError
from render.pick import Hit, pick, scene_triangles
from render.session import camera_for, debris_color
from viewer.actions import (
    Tuning,
    ball_bodies,
    ball_radius,
    copy_config,
    event_cracks,
    preview_strike,
    shoot_ball,
    strike,
)
from viewer.input import ZOOM_KEY_RATE, MouseState, drag_camera, poll
from viewer.overlay import (
    COLOUR_MODES,
    KERNEL_COLOUR,
    LINK_COLOUR,
    AnalysisValues,
    ViewerScene,
    crack_segments,
    kernel_segments,
    link_segments,
    particle_overlay,
    preview_particles,
)
from viewer.panel import draw_panel, panel_fraction
from viewer.script import Action, parse_pixel, parse_script

BALL_START_RADII = 4.0  # ball radii: a shot ball starts this far in front of the eye (plus the near plane)
PREVIEW_MOVE_M = 0.003  # m: the preview is recomputed when the hit point moves farther (reference frame)
LINE_WIDTH_PX = 2.0  # px: overlay lines
FPS_SMOOTHING = 0.1  # -: exponential smoothing of the frame rate shown


def _failure(what: str, exc: Exception) -> str:
    """Report an error of an action without closing the window: the traceback goes to stderr (a
    SandboxError is an input problem and needs none), a one-line message to the panel."""
    if not isinstance(exc, SandboxError):
        traceback.print_exc(file=sys.stderr)
    return f"{what} failed: {type(exc).__name__}: {exc}"[:200]


@dataclass
class Toggles:
    """What is drawn (docs/viewer.md)."""

    surfaces: bool = True
    physical: bool = False
    subdivided: bool = False
    boundary: bool = False
    links: bool = False
    kernels: bool = False
    cracks: bool = True
    preview: bool = False
    panel: bool = True


class Viewer:
    """State and frame loop of the viewer. Without `open_window()` every action still works (tests)."""

    def __init__(self, cfg, width: int = 1280, height: int = 800, frames: int = 0,
                 script: list[Action] | None = None) -> None:
        self.base_cfg = copy_config(cfg)
        self.width, self.height = int(width), int(height)
        self.max_frames = int(frames)
        self.script = sorted(script or [], key=lambda a: a.frame)
        self.tuning = Tuning.from_config(cfg)
        self.toggles = Toggles()
        self.colour_mode = "fragment"
        self.paused = False
        self.step_once = False
        self.quit = False
        self.frame = 0  # window frames drawn
        self.fps = 0.0
        self.message = ""
        self.mouse = MouseState()
        self.virtual_cursor: tuple[float, float] | None = None  # px, set by scripts ('hover')
        self.hit: Hit | None = None  # surface point under the cursor this frame
        self.preview = None
        self._preview_key = None
        self._link_cache = (None, None)
        self.window = None
        self._build_world()
        self.home = camera_for(self.world, self.width / self.height)
        self.camera = self.home.copy()

    # ------------------------------------------------------------------ world
    def _build_world(self) -> None:
        self.sim = Simulation(copy_config(self.base_cfg))  # the Python API's object (docs/api.md)
        self.world = self.sim.world
        self.view = ViewerScene(self.world)
        self.view.scene.line_width = LINE_WIDTH_PX
        self.preview = None
        self._preview_key = None
        self.tuning.new_world()
        self.tuning.apply(self.world, self.base_cfg)

    def reset_scene(self) -> None:
        """Rebuild the World from the scene file (sliders and toggles are kept)."""
        self.view.release()
        self.sim.close()
        self._build_world()
        self.say("scene reset")

    def say(self, message: str) -> None:
        """Show a message in the panel and print it to stderr (scripts and logs)."""
        self.message = message
        print(f"viewer frame {self.frame}: {message}", file=sys.stderr, flush=True)

    def balls(self) -> int:
        return len(ball_bodies(self.world))

    def has_rigid(self) -> bool:
        return "rigid" in self.world.stages

    # ------------------------------------------------------------------ aiming
    def cursor(self) -> tuple[float, float]:
        return self.virtual_cursor if self.virtual_cursor is not None else (self.mouse.x, self.mouse.y)

    def pick_at(self, x: float, y: float) -> Hit | None:
        tris, bodies = scene_triangles(self.view.scene)
        return pick(tris, bodies, self.camera, x, y, self.width, self.height)

    def default_target(self) -> tuple[float, float] | None:
        """Pixel of the centre of mass of the largest breakable body (scripted strikes and balls)."""
        if not self.has_rigid():
            return None
        cands = [b for b in self.world.bodies if breakable(self.world, b)]
        if not cands:
            return None
        b = max(cands, key=lambda k: self.world.rigid.body_mass(k))
        px, _, _ = self.camera.project(self.world.rigid.body_state().x[b], self.width, self.height)
        return float(px[0, 0]), float(px[0, 1])

    def _aim(self, arg: str = "") -> tuple[float, float] | None:
        if arg:
            return parse_pixel(arg, "viewer aim")
        return self.default_target()

    # ------------------------------------------------------------------ actions
    def do_strike(self, xy: tuple[float, float] | None) -> dict | None:
        """Strike the surface point under pixel xy at the slider speed."""
        if xy is None or not self.has_rigid():
            self.say("strike: nothing to strike")
            return None
        hit = self.pick_at(*xy)
        if hit is None or not breakable(self.world, hit.body):
            self.say("strike: no breakable surface there")
            return None
        self.tuning.apply(self.world, self.base_cfg)
        n_before = len(self.world.particles)
        try:
            pre = preview_strike(self.world, hit, self.tuning.strike_speed)  # the same analysis, for the colours
            record = strike(self.world, hit, self.tuning.strike_speed)
        except Exception as exc:  # noqa: BLE001 - reported in the panel; the window stays open
            self.say(_failure("strike", exc))
            return None
        if pre is not None:
            self.view.data = AnalysisValues.from_analysis(n_before, pre.particle_ids, pre.analysis)
        self.preview = None
        self._preview_key = None
        if record is None:
            self.say(f"strike body {hit.body} at {self.tuning.strike_speed:.3g} m/s: no crack")
        else:
            self.say(f"strike body {hit.body}: {record['cracks']} cracks, {record['fragments']} frags, "
                     f"{record['debris']} debris")
        return record

    def do_ball(self, xy: tuple[float, float] | None) -> int | None:
        """Shoot a ball from the eye towards pixel xy (default: the screen centre)."""
        if not self.has_rigid():
            self.say("ball: this scene has no rigid bodies")
            return None
        x, y = xy if xy is not None else (0.5 * self.width, 0.5 * self.height)
        eye, d = self.camera.ray(x, y, self.width, self.height)
        origin = eye + d * (self.camera.near + BALL_START_RADII * ball_radius(self.world))  # in front of the eye
        self.tuning.apply(self.world, self.base_cfg)
        try:
            bid = shoot_ball(self.world, origin, d, self.tuning.ball_speed)
        except Exception as exc:  # noqa: BLE001 - reported in the panel; the window stays open
            self.say(_failure("ball", exc))
            return None
        self.say(f"ball {bid} shot at {self.tuning.ball_speed:.3g} m/s")
        return bid

    def toggle(self, name: str) -> None:
        if name == "particles":
            on = not (self.toggles.physical or self.toggles.subdivided or self.toggles.boundary)
            self.toggles.physical = self.toggles.subdivided = self.toggles.boundary = on
        else:
            setattr(self.toggles, name, not getattr(self.toggles, name))

    def set_value(self, arg: str) -> None:
        key, _, val = arg.partition("=")
        t = self.tuning
        if key == "cracks":
            t.cracks = int(float(val))
        elif key == "strength":
            t.strength_factor = float(val)
        elif key == "axis":
            t.axis_factor = float(val)
        elif key == "speed":
            t.strike_speed = float(val)
        elif key == "ball_speed":
            t.ball_speed = float(val)

    def command(self, cmd: str, arg: str = "") -> None:
        """Run one command (from a key, a button or a script)."""
        if cmd == "quit":
            self.quit = True
        elif cmd == "pause":
            self.paused = not self.paused
        elif cmd == "resume":
            self.paused = False
        elif cmd == "step":
            self.paused = True
            self.step_once = True
        elif cmd == "reset":
            self.reset_scene()
        elif cmd == "view":
            self.camera = self.home.copy()
        elif cmd == "fit":
            tris, bodies = scene_triangles(self.view.scene)
            pts = tris[bodies >= 0].reshape(-1, 3)  # the bodies, not the floor
            if len(pts):
                self.camera.fit(pts.min(0), pts.max(0), self.width / self.height)
        elif cmd == "ball":
            self.do_ball(self._aim(arg) if arg or self.window is None else self.cursor())
        elif cmd == "strike":
            self.do_strike(self._aim(arg) if arg or self.window is None else self.cursor())
        elif cmd.startswith("toggle:"):
            self.toggle(cmd.split(":", 1)[1])
        elif cmd == "colour":
            self.colour_mode = arg or COLOUR_MODES[(COLOUR_MODES.index(self.colour_mode) + 1) % len(COLOUR_MODES)]
        elif cmd == "zoom_in":
            self.camera.zoom(ZOOM_KEY_RATE)
        elif cmd == "zoom_out":
            self.camera.zoom(1.0 / ZOOM_KEY_RATE)

    def run_script(self) -> list[str]:
        """Run this frame's scripted actions; returns the screenshot paths to take after drawing."""
        shots = []
        for a in [a for a in self.script if a.frame == self.frame]:
            if a.name == "shot":
                shots.append(a.arg)
            elif a.name == "strike":
                self.do_strike(self._aim(a.arg))
            elif a.name == "ball":
                self.do_ball(self._aim(a.arg))
            elif a.name == "hover":
                self.virtual_cursor = self._aim(a.arg)
            elif a.name == "toggle":
                self.toggle(a.arg)
            elif a.name == "colour":
                self.colour_mode = a.arg
            elif a.name == "set":
                self.set_value(a.arg)
            elif a.name == "orbit":
                yaw, pitch = parse_pixel(a.arg, "orbit")
                self.camera.orbit(np.radians(yaw), np.radians(pitch))
            elif a.name == "zoom":
                self.camera.zoom(float(a.arg))
            else:
                self.command(a.name)
        return shots

    # ------------------------------------------------------------------ one frame
    def step(self) -> None:
        """One World frame unless paused (a requested single step runs even when paused)."""
        if self.paused and not self.step_once:
            return
        self.step_once = False
        self.tuning.apply(self.world, self.base_cfg)
        try:
            self.world.step_frame()
        except Exception as exc:  # noqa: BLE001 - reported in the panel; the window stays open
            self.paused = True
            self.say(_failure("simulation (paused)", exc))

    def update_hover(self) -> None:
        """The surface point under the cursor, and the throttled crack preview there."""
        self.hit = None
        if not (self.toggles.preview or self.toggles.kernels) or not self.has_rigid():
            self.preview = None
            return
        x, y = self.cursor()
        if self.window is not None and self.virtual_cursor is None and self.over_panel(x, y):
            return
        self.hit = self.pick_at(x, y)
        if not self.toggles.preview:
            self.preview = None
            return
        hit = self.hit
        if hit is None or not breakable(self.world, hit.body):
            self.preview = None
            self._preview_key = None
            return
        frames = body_frames(self.world)
        ref = to_reference(frames, hit.body, hit.point)
        key = (hit.body, self.world.surface_version, self.tuning.key())
        if self._preview_key is not None and self._preview_key[0] == key and \
                np.linalg.norm(ref - self._preview_key[1]) <= PREVIEW_MOVE_M:
            self.preview.refresh_world(self.world)
            return
        self.tuning.apply(self.world, self.base_cfg)
        try:
            self.preview = preview_strike(self.world, hit, self.tuning.strike_speed)
        except Exception as exc:  # noqa: BLE001 - reported in the panel; the window stays open
            self.preview = None
            self._preview_key = (key, ref)  # do not retry every frame at the same point
            self.say(_failure("preview", exc))
            return
        self._preview_key = (key, ref)
        if self.preview is not None:
            self.view.data = AnalysisValues.from_analysis(len(self.world.particles), self.preview.particle_ids,
                                                          self.preview.analysis)

    def overlays(self) -> None:
        """Particles and line segments drawn over (or instead of) the surfaces this frame."""
        scene, w, tg = self.view.scene, self.world, self.toggles
        if not self.has_rigid():
            scene.set_lines(np.zeros((0, 3)), np.zeros((0, 3)))
            return
        frames = body_frames(w)
        xs, rs, cs = [], [], []
        if tg.physical or tg.subdivided or tg.boundary:
            x, r, c = particle_overlay(w, frames, tg.physical, tg.subdivided, tg.boundary, self.colour_mode,
                                       self.view.data)
            xs.append(x), rs.append(r), cs.append(c)
        if tg.preview and self.preview is not None:
            x, r, c = preview_particles(w, self.preview)
            xs.append(x), rs.append(r), cs.append(c)
        if "debris" in w.stages and w.debris.count:  # the shattered grains (SceneView draws them headless)
            d = w.debris.state()
            xs.append(d["x"]), rs.append(d["r"]), cs.append(np.tile(debris_color(w), (len(d["r"]), 1)))
        if xs and sum(len(x) for x in xs):
            scene.set_particles(np.concatenate(xs), np.concatenate(rs), np.concatenate(cs))
        else:
            scene.set_particles(np.zeros((0, 3)), 1.0)
        A, B, C = [], [], []
        if tg.links:
            if self._link_cache[0] != (id(w), w.surface_version):
                self._link_cache = ((id(w), w.surface_version), w.particles.link_pairs())
            a, b = link_segments(w, frames, self._link_cache[1])
            A.append(a), B.append(b), C.append(np.broadcast_to(np.array(LINK_COLOUR), (len(a), 3)))
        if tg.kernels and self.hit is not None and self.hit.body >= 0:
            a, b = kernel_segments(w, frames, self.hit.point, self.hit.body)
            A.append(a), B.append(b), C.append(np.broadcast_to(np.array(KERNEL_COLOUR), (len(a), 3)))
        if tg.cracks:
            shapes, normal = [], None
            if tg.preview and self.preview is not None:
                shapes, normal = self.preview.cracks, self.preview.normal
            elif w.events:
                shapes = event_cracks(w, w.events[-1])
            a, b, c = crack_segments(shapes, normal)
            A.append(a), B.append(b), C.append(c)
        n = sum(len(a) for a in A)
        if n:
            scene.set_lines(np.concatenate(A), np.concatenate(B), np.concatenate(C))
        else:
            scene.set_lines(np.zeros((0, 3)), np.zeros((0, 3)))

    def prepare_frame(self) -> list[str]:
        """Everything of one frame before drawing: script, simulation, surfaces, hover, overlays.
        Returns the screenshot paths of this frame."""
        shots = self.run_script()
        self.step()
        self.view.colour_mode = self.colour_mode
        self.view.refresh()
        self.update_hover()
        self.overlays()
        return shots

    # ------------------------------------------------------------------ window
    def over_panel(self, x: float, y: float) -> bool:
        return self.toggles.panel and x >= (1.0 - panel_fraction(self.width)) * self.width

    def open_window(self) -> None:
        import taichi as ti

        from render.ggui import GGUIDrawer, _quiet_taichi, vulkan_status

        if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            raise BackendError("main.py view needs a display (DISPLAY is not set): run it on a desktop, or under "
                               "xvfb-run -a -s \"-screen 0 1280x1024x24\" python main.py view ...; for files "
                               "without a window use main.py run")
        ok, why = vulkan_status()
        if not ok:
            raise BackendError(f"main.py view needs Vulkan for its GGUI window, which is not available here: "
                               f"{why}; install mesa-vulkan-drivers (tools/system_deps.sh) or use main.py run "
                               "--renderer raster")
        self._imgui_ini = os.path.abspath("imgui.ini")
        self._imgui_ini_existed = os.path.exists(self._imgui_ini)
        with _quiet_taichi():
            self.window = ti.ui.Window(f"anisofrac: {self.world.cfg.scene.name}", (self.width, self.height),
                                       show_window=True, vsync=False)
        self.canvas = self.window.get_canvas()
        self.ti_scene = self.window.get_scene()
        self.gui = self.window.get_gui()
        self.drawer = GGUIDrawer()
        self._quiet = _quiet_taichi

    def handle_input(self) -> None:
        cmds, dx, dy = poll(self.window, self.mouse, self.width, self.height, self.over_panel)
        if dx or dy:
            self.virtual_cursor = None  # the real mouse moved: it takes over from a scripted 'hover'
        drag_camera(self.camera, self.mouse, dx, dy, self.height)
        for c in cmds:
            self.command(c)

    def draw(self, shots: list[str]) -> None:
        surfaces = self.view.scene.n_tris
        if not self.toggles.surfaces:  # draw the floor only (SceneView puts it first), this frame only
            self.view.scene.n_tris = min(surfaces, sum(len(p.faces) for p in self.view._floor))
        with self._quiet():
            self.drawer.draw(self.view.scene, self.camera, self.ti_scene, self.canvas, self.width, self.height)
        self.view.scene.n_tris = surfaces
        if self.toggles.panel:
            for c in draw_panel(self.gui, self):
                self.command(c)
        for path in shots:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            self.window.save_image(str(path))
            self.say(f"saved {path}")
        self.window.show()

    def run(self) -> int:
        """The frame loop; returns the exit status."""
        self.open_window()
        t_last = time.perf_counter()
        try:
            while self.window.running and not self.quit:
                self.handle_input()
                if self.quit:
                    break
                shots = self.prepare_frame()
                self.draw(shots)
                self.frame += 1
                now = time.perf_counter()
                inst = 1.0 / max(now - t_last, 1e-6)
                self.fps = inst if self.fps == 0.0 else (1 - FPS_SMOOTHING) * self.fps + FPS_SMOOTHING * inst
                t_last = now
                if self.max_frames and self.frame >= self.max_frames:
                    break
        finally:
            self.close()
        return 0

    def close(self) -> None:
        if self.window is not None:
            self.window.destroy()
            self.window = None
            if not self._imgui_ini_existed and os.path.exists(self._imgui_ini):
                os.remove(self._imgui_ini)
            self.drawer.release()
        self.view.release()
        self.sim.close()


def run_viewer(cfg, args) -> int:
    """Entry point of `main.py view`: args has width, height, frames, script (and the runtime options)."""
    script = parse_script(getattr(args, "script", None))
    viewer = Viewer(cfg, width=args.width, height=args.height, frames=args.frames, script=script)
    print(f"viewer: {cfg.scene.name} ({', '.join(cfg.scene.effects)}); {len(script)} scripted actions; "
          "keys: docs/viewer.md", file=sys.stderr)
    return viewer.run()


__all__ = ["Toggles", "Viewer", "run_viewer"]
