"""The drawing process compiles its renderer for the scene it will get before the scene comes (issue 16:
the first frame in under 3 s).

A frame's kernels take the scene's buffers as template arguments, so Taichi compiles them for those
buffers, whose sizes (powers of two, render/scene_data.py) only the built World knows: the renderer's
first frame waited about 1.1 s for them after the World was built (the pot, docs/decisions.md session
36). The drawing process remembers the buffer sizes each scene asked for (`remember`: a small JSON
file in the project's cache, `~/.cache/anisofrac/render/` (geometry/build_cache.py: the test suite
uses a cache of its own), keyed by the scene's settings and the image's), and at its start, while
the World builds, draws a one-triangle scene with the sizes remembered for this key (`prewarm`). It
gives the buffers back to core/field_pool.py, where the scene takes them with the kernels compiled for
them. A scene whose sizes differ (a changed mesh file, a new scene) compiles at its first frame, as
before; a frame never depends on the guess.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

HINTS_FILE = "render_buffers.json"  # in the project cache's render folder (draw_process.HINTS_KIND)
MOST_HINTS = 64  # scenes remembered; the oldest are forgotten first
SIZES = ("tri_capacity", "body_capacity", "particle_capacity", "line_capacity")


def _read(folder: Path) -> dict:
    try:
        data = json.loads((folder / HINTS_FILE).read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def remembered(folder: Path, key: str) -> dict | None:
    """The buffer sizes last asked for under `key`, or None."""
    sizes = _read(folder).get(key)
    if not isinstance(sizes, dict) or set(sizes) != set(SIZES):
        return None
    if not all(isinstance(v, int) and 0 <= v < 1 << 30 for v in sizes.values()):
        return None
    return sizes


def remember(folder: Path, key: str, scene_args: dict) -> None:
    """Keep the sizes of a RenderScene's arguments under `key` (written to a temporary name and renamed;
    an unwritable folder only loses the hint)."""
    sizes = {k: int(scene_args.get(k, 0)) for k in SIZES}
    hints = _read(folder)
    if hints.get(key) == sizes:
        return
    hints.pop(key, None)
    hints[key] = sizes
    while len(hints) > MOST_HINTS:
        hints.pop(next(iter(hints)))
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tmp = folder / f".{HINTS_FILE}.{os.getpid()}.tmp"
        tmp.write_text(json.dumps(hints))
        os.replace(tmp, folder / HINTS_FILE)
    except OSError:
        pass


def prewarm(renderer, sizes: dict) -> None:
    """Draw a one-triangle scene with buffers of `sizes` (and a pose, a particle): every kernel of a
    first frame compiles for the buffers the scene will take from the pool; nothing is written."""
    import numpy as np

    from render.camera import Camera
    from render.scene_data import Lighting, MeshPart, RenderScene

    scene = RenderScene(**sizes, lighting=Lighting.studio())
    try:
        tri = MeshPart(np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]]), np.array([[0, 1, 2]]), body=0)
        scene.update_surfaces({"floor": [tri]})
        scene.set_poses(np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0, 0.0]]), np.zeros((1, 3)))
        scene.set_particles(np.zeros((1, 3)), 0.01)
        scene.update()
        scene.body_bounds()
        renderer.render(scene, Camera())
    finally:
        scene.release()


__all__ = ["prewarm", "remember", "remembered"]
