"""Renderer choice for `--renderer ggui|raster|auto|none` (DESIGN.md section 7).

`make_renderer(kind, width, height)` returns an object with `.name` ('ggui', 'raster' or 'none'),
`.message` (one line saying which renderer runs and why), `render(scene, camera)` -> (H, W, 3) uint8
(None for 'none') and `release()`. 'auto' takes GGUI when the Vulkan probe succeeds
(render.ggui.vulkan_status) and the Taichi rasteriser otherwise; both draw the same image.
"""

from __future__ import annotations

from render.raster import RasterRenderer, check_size
from sim.errors import ConfigError

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
    from render.ggui import GGUIRenderer, vulkan_status

    if key == "ggui":
        return GGUIRenderer(width, height)
    ok, why = vulkan_status()
    if ok:
        r = GGUIRenderer(width, height)
        r.message = f"renderer: auto -> ggui (Vulkan works: {why})"
        return r
    r = RasterRenderer(width, height)
    r.message = f"renderer: auto -> raster (Vulkan unavailable: {why})"
    return r
