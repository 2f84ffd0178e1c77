"""Keyboard and mouse of the interactive viewer (GGUI 1.7.4 window events -> viewer commands).

GGUI 1.7.4 reports letters, space, Escape, Return, Tab, BackSpace, the arrows, Shift/Ctrl/Alt and
the three mouse buttons; other keys (digits, +, -, F-keys) and the mouse wheel produce no event
(measured under Xvfb with synthetic X events), so every binding below uses reportable keys and
zoom has key and drag forms. The cursor is read every frame; a drag is a mouse button held since a
press outside the panel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import taichi as ti

from render.pick import cursor_pixels

# key (GGUI name) -> command; `docs/viewer.md` lists the same table
KEY_COMMANDS = {
    "Escape": "quit",
    " ": "pause",
    "n": "step",
    "Right": "step",
    "BackSpace": "reset",
    "r": "view",
    "f": "fit",
    "b": "ball",
    "t": "toggle:surfaces",
    "p": "toggle:physical",
    "u": "toggle:subdivided",
    "g": "toggle:boundary",
    "l": "toggle:links",
    "k": "toggle:kernels",
    "c": "toggle:cracks",
    "v": "toggle:preview",
    "h": "toggle:panel",
    "m": "colour",
}
ZOOM_IN_KEYS = ("Up", "i")  # held: zoom in by ZOOM_KEY_RATE per frame
ZOOM_OUT_KEYS = ("Down", "o")
ZOOM_KEY_RATE = 1.04  # -: zoom factor per frame while a zoom key is held
ORBIT_RAD_PER_PX = 0.008  # rad per pixel of right-drag
DOLLY_PER_PX = 0.01  # -: Ctrl + right-drag zooms by exp(-dy * this)


@dataclass
class MouseState:
    x: float = 0.0  # px from the left
    y: float = 0.0  # px from the top
    drag: str = ""  # "orbit", "pan", "dolly" or ""
    button: str = ""  # GGUI button name held for the drag


def poll(window, mouse: MouseState, width: int, height: int, over_panel) -> tuple[list[str], float, float]:
    """Read this frame's events. Returns (commands, dx, dy): commands from keys and clicks ("strike"
    = left click outside the panel), and the cursor motion in pixels since the last frame."""
    x, y = cursor_pixels(window.get_cursor_pos(), width, height)
    dx, dy = x - mouse.x, y - mouse.y
    mouse.x, mouse.y = x, y
    commands: list[str] = []
    for e in window.get_events(ti.ui.PRESS):
        key = e.key
        if key in KEY_COMMANDS:
            commands.append(KEY_COMMANDS[key])
        elif key == ti.ui.LMB and not over_panel(x, y):
            commands.append("strike")
        elif key in (ti.ui.RMB, ti.ui.MMB) and not over_panel(x, y):
            shift, ctrl = window.is_pressed(ti.ui.SHIFT), window.is_pressed(ti.ui.CTRL)
            if key == ti.ui.MMB or shift:
                mouse.drag = "pan"
            else:
                mouse.drag = "dolly" if ctrl else "orbit"
            mouse.button = key
    if mouse.drag and not window.is_pressed(mouse.button):
        mouse.drag = mouse.button = ""
    if window.is_pressed(*ZOOM_IN_KEYS):
        commands.append("zoom_in")
    if window.is_pressed(*ZOOM_OUT_KEYS):
        commands.append("zoom_out")
    return commands, dx, dy


def drag_camera(camera, mouse: MouseState, dx: float, dy: float, height: int) -> None:
    """Apply this frame's drag to the camera (orbit, pan or dolly)."""
    if not mouse.drag or (dx == 0.0 and dy == 0.0):
        return
    if mouse.drag == "orbit":
        camera.orbit(-dx * ORBIT_RAD_PER_PX, dy * ORBIT_RAD_PER_PX)
    elif mouse.drag == "pan":
        camera.pan(dx, dy, height)
    else:
        camera.zoom(math.exp(-dy * DOLLY_PER_PX))
