"""Rendering: camera, renderer-independent frame buffers, a Taichi rasteriser, headless GGUI, writers.

See docs/notes_render.md for the conventions (image orientation, camera matrices, colours).
"""

from render.camera import Camera
from render.scene_data import Lighting, MeshPart, RenderScene, body_palette, disc_outline
from render.select import RENDERER_KINDS, make_renderer
from render.writers import GifWriter, Mp4Writer, PngSequenceWriter, make_writer

__all__ = [
    "RENDERER_KINDS",
    "Camera",
    "GifWriter",
    "Lighting",
    "MeshPart",
    "Mp4Writer",
    "PngSequenceWriter",
    "RenderScene",
    "body_palette",
    "disc_outline",
    "make_renderer",
    "make_writer",
]
