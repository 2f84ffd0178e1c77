"""Rendering: camera, renderer-independent frame buffers, a Taichi rasteriser, headless GGUI, writers.

See docs/notes_render.md for the conventions (image orientation, camera matrices, colours).

The names below are imported when first used (PEP 562): importing a light module of the package
(`render.looks`, which the scene check reads) does not import Taichi or define the render kernels,
so they are defined after `core.runtime.init_taichi` has installed its faster frontend.
"""

import importlib

_HOME = {
    "Camera": "render.camera",
    "Lighting": "render.scene_data",
    "MeshPart": "render.scene_data",
    "RenderScene": "render.scene_data",
    "body_palette": "render.scene_data",
    "disc_outline": "render.scene_data",
    "RENDERER_KINDS": "render.select",
    "make_renderer": "render.select",
    "GifWriter": "render.writers",
    "Mp4Writer": "render.writers",
    "PngSequenceWriter": "render.writers",
    "make_writer": "render.writers",
}


def __getattr__(name: str):
    if name not in _HOME:
        raise AttributeError(f"module 'render' has no attribute {name!r}")
    return getattr(importlib.import_module(_HOME[name]), name)


__all__ = sorted(_HOME)
