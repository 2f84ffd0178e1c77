"""The viewer's scripted actions (`main.py view SCENE --script ...`), for tests and demos.

Grammar (docs/viewer.md):

    script  := action ("," action)*
    action  := NAME "@" FRAME [":" ARG]

FRAME is the viewer's frame counter (0 = the first window frame; the same counter `--frames` counts,
paused frames included). Actions of one frame run in the order written, after that frame's input
and before its simulation step; `shot` captures the frame after it is drawn. NAMEs and ARGs:

    strike@F[:XxY]     strike at pixel (X, Y) from the top-left, or at the centre of the largest breakable body
    ball@F[:XxY]       shoot a ball towards pixel (X, Y) (default: the same aim as strike)
    hover@F[:XxY]      put the (virtual) cursor at pixel (X, Y) (default: the strike aim); preview and
                       kernels follow it until the real mouse moves
    toggle@F:NAME      flip a display toggle (surfaces, physical, subdivided, boundary, particles = the
                       three kinds together, links, kernels, cracks, preview, panel)
    colour@F:MODE      fragment, material, energy or stress
    set@F:KEY=VALUE    cracks (int), strength (factor), axis (factor), speed (m/s), ball_speed (m/s)
    pause@F, resume@F, step@F, reset@F (rebuild the World), view@F (reset the camera), fit@F (frame the bodies)
    orbit@F:YAWxPITCH  orbit the camera by degrees;  zoom@F:FACTOR (> 1 zooms in)
    shot@F:PATH        save the window image (PNG) after frame F is drawn
    quit@F             close the viewer after frame F
"""

from __future__ import annotations

from dataclasses import dataclass

from core.errors import ConfigError

ACTIONS = ("strike", "ball", "hover", "toggle", "colour", "set", "pause", "resume", "step", "reset", "view", "fit",
           "orbit", "zoom", "shot", "quit")
NEEDS_ARG = ("toggle", "colour", "set", "orbit", "zoom", "shot")
TOGGLES = ("surfaces", "physical", "subdivided", "boundary", "particles", "links", "kernels", "cracks", "preview",
           "panel")
SETTINGS = ("cracks", "strength", "axis", "speed", "ball_speed")


@dataclass(frozen=True)
class Action:
    name: str
    frame: int
    arg: str = ""


def parse_pixel(text: str, where: str) -> tuple[float, float]:
    """'XxY' -> (x, y) pixels."""
    try:
        x, y = (float(v) for v in text.lower().split("x"))
    except ValueError:
        raise ConfigError(where, text, "pixel coordinates XxY, e.g. 320x240") from None
    return x, y


def parse_script(text: str | None) -> list[Action]:
    """Parse a script (module docstring); raises ConfigError naming the bad action."""
    actions: list[Action] = []
    if not text:
        return actions
    for i, item in enumerate(s.strip() for s in text.split(",")):
        where = f"--script action {i + 1} ({item!r})"
        if not item:
            continue
        head, _, arg = item.partition(":")
        name, at, frame = head.partition("@")
        name = name.strip().lower()
        if name == "color":
            name = "colour"
        if name not in ACTIONS:
            raise ConfigError(where, name, "one of " + ", ".join(ACTIONS))
        if not at or not frame.strip().isdigit():
            raise ConfigError(where, frame, "NAME@FRAME with FRAME an integer >= 0")
        if name in NEEDS_ARG and not arg:
            raise ConfigError(where, item, f"'{name}' needs an argument: {name}@FRAME:ARG")
        if name in ("strike", "ball", "hover") and arg:
            parse_pixel(arg, where)
        if name == "toggle" and arg not in TOGGLES:
            raise ConfigError(where, arg, "a toggle: " + ", ".join(TOGGLES))
        if name == "colour" and arg not in ("fragment", "material", "energy", "stress"):
            raise ConfigError(where, arg, "fragment, material, energy or stress")
        if name == "set":
            key, eq, val = arg.partition("=")
            try:
                float(val)
            except ValueError:
                raise ConfigError(where, arg, "KEY=NUMBER") from None
            if not eq or key not in SETTINGS:
                raise ConfigError(where, key, "KEY=VALUE with KEY one of " + ", ".join(SETTINGS))
        if name == "orbit":
            parse_pixel(arg, where)
        if name == "zoom":
            try:
                ok = float(arg) > 0.0
            except ValueError:
                ok = False
            if not ok:
                raise ConfigError(where, arg, "a zoom factor > 0")
        actions.append(Action(name, int(frame), arg))
    return actions
