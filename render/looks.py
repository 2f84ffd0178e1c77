"""How a material looks in frames (issue 15, "Materials that read"): base colour, roughness, opacity
and the shade of the faces its cracks create. Scene files may set `look = { ... }` per material;
what they leave out comes from the material's kind, recognised by a word in its name (glass,
porcelain, steel, marble, slate, jade, ...), or from neutral defaults. Pure data: no Taichi here.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from core.errors import ConfigError

CRACK_MIX = 0.35  # -: a crack face's default shade: base colour mixed this much with CRACK_GREY
CRACK_GREY = (0.45, 0.43, 0.40)  # -: fresh fracture surfaces scatter light: lighter on dark stone, greyer on white


@dataclass(frozen=True)
class Look:
    color: tuple  # linear RGB in [0, 1]
    roughness: float = 0.7  # 0: polished (sharp highlight) .. 1: matte
    opacity: float = 1.0  # < 1: see-through (glass)
    crack_color: tuple | None = None  # faces created by cracks; None: mixed from `color` (CRACK_MIX)

    def crack(self) -> tuple:
        if self.crack_color is not None:
            return self.crack_color
        c = (1.0 - CRACK_MIX) * np.asarray(self.color) + CRACK_MIX * np.asarray(CRACK_GREY)
        return tuple(float(v) for v in c)


# kind word in the material's name -> its look (first match wins; order matters: "black_slate" is slate)
KIND_LOOKS = (
    (("glass", "window", "pane"), Look((0.72, 0.86, 0.90), roughness=0.05, opacity=0.35,
                                       crack_color=(0.55, 0.75, 0.80))),
    (("steel", "iron", "metal", "alumin"), Look((0.62, 0.64, 0.68), roughness=0.25)),
    (("slate", "basalt", "black", "obsidian"), Look((0.10, 0.10, 0.11), roughness=0.45)),
    (("marble", "white"), Look((0.93, 0.92, 0.89), roughness=0.35)),
    (("porcelain", "china"), Look((0.95, 0.94, 0.90), roughness=0.2)),
    (("ceramic", "stoneware", "terracotta", "clay", "pot"), Look((0.80, 0.52, 0.36), roughness=0.6)),
    (("jade",), Look((0.35, 0.62, 0.42), roughness=0.3)),
    (("wood",), Look((0.62, 0.45, 0.28), roughness=0.8)),
    (("stone", "concrete", "granite", "rock"), Look((0.58, 0.57, 0.55), roughness=0.85)),
    (("ice",), Look((0.85, 0.93, 0.97), roughness=0.1, opacity=0.6)),
)
DEFAULT_LOOK = Look((0.78, 0.70, 0.58), roughness=0.6)


def _rgb(value, path: str, source: str) -> tuple:
    try:
        c = np.asarray(value, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise ConfigError(path, value, "3 numbers in [0, 1] (linear RGB)", source) from None
    if not np.all(np.isfinite(c)) or np.any(c < 0.0) or np.any(c > 1.0):
        raise ConfigError(path, value, "3 numbers in [0, 1] (linear RGB)", source)
    return tuple(float(v) for v in c)


def _unit_number(value, path: str, source: str, lo_open: bool) -> float:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and np.isfinite(value)
    if not ok or not ((0.0 < value) if lo_open else (0.0 <= value)) or value > 1.0:
        raise ConfigError(path, value, f"a number in {'(' if lo_open else '['}0, 1]", source)
    return float(value)


def material_look(name: str, look: dict | None = None, path: str = "materials[].look", source: str = "") -> Look:
    """The look of a material: its kind's defaults overridden by the scene file's `look` table."""
    base = next((lk for words, lk in KIND_LOOKS if any(w in name.lower() for w in words)), DEFAULT_LOOK)
    look = dict(look or {})
    unknown = set(look) - {"color", "roughness", "opacity", "crack_color"}
    if unknown:
        raise ConfigError(f"{path}.{sorted(unknown)[0]}", look[sorted(unknown)[0]],
                          "one of color, roughness, opacity, crack_color", source)
    changes = {}
    if "color" in look:
        changes["color"] = _rgb(look["color"], f"{path}.color", source)
        if "crack_color" not in look:
            changes["crack_color"] = None  # mixed from the new colour
    if "crack_color" in look:
        changes["crack_color"] = _rgb(look["crack_color"], f"{path}.crack_color", source)
    if "roughness" in look:
        changes["roughness"] = _unit_number(look["roughness"], f"{path}.roughness", source, lo_open=False)
    if "opacity" in look:
        changes["opacity"] = _unit_number(look["opacity"], f"{path}.opacity", source, lo_open=True)
    return replace(base, **changes)
