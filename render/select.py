"""Renderer choice for `--renderer ggui|raster|auto|none` (DESIGN.md section 7).

`make_renderer(kind, width, height)` returns an object with `.name` ('ggui', 'raster' or 'none'),
`.message` (one line saying which renderer runs and why), `render(scene, camera)` -> (H, W, 3) uint8
(None for 'none') and `release()`. 'auto' takes the Taichi rasteriser: it is deterministic, casts
shadows, needs no Vulkan and is faster than GGUI on a CPU (docs/decisions.md, "Headless frames");
'ggui' draws through Vulkan (the interactive window's renderer) without shadows.
"""

from __future__ import annotations

from core.errors import ConfigError
from render.raster import RasterRenderer, check_size

RENDERER_KINDS = ("ggui", "raster", "auto", "none")


class NullRenderer:
    """`--renderer none`: draws nothing (statistics and meshes only)."""

    name = "none"

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = check_size(width, height)
        self.message = "renderer: none (no frames are drawn)"

    def render(self, scene, camera) -> None:
        return None

    def release(self) -> None:
        pass


def make_renderer(kind: str, width: int = 640, height: int = 480):
    """A renderer by name (module docstring); raises ConfigError for an unknown name and BackendError
    for 'ggui' without Vulkan."""
    key = str(kind).lower()
    if key not in RENDERER_KINDS:
        raise ConfigError("--renderer", kind, ", ".join(RENDERER_KINDS))
    check_size(width, height)
    if key == "none":
        return NullRenderer(width, height)
    if key == "raster":
        return RasterRenderer(width, height)
    from render.ggui import GGUIRenderer

    if key == "ggui":
        return GGUIRenderer(width, height)
    r = RasterRenderer(width, height)  # auto: frames the project controls (docs/decisions.md, "Headless frames")
    r.message = f"renderer: auto -> raster (Taichi software rasteriser, {width}x{height}; soft shadows)"
    return r
