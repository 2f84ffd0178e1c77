"""anisofrac: the Python API of the brittle-fracture sandbox (docs/api.md).

    import anisofrac as af
    sim = af.load("glass_r3", {"materials.glass.cracks": 8})
    sim.step(10)
    pre = sim.preview("pane", point, velocity)     # Algorithm 1's groups and cracks, nothing applied
    image = sim.render()                            # (H, W, 3) uint8

The command line (`main.py run`, `main.py view`) and the viewer are built on the same functions.
Importing this package starts nothing: Taichi starts at `init()` or at the first `load()`.
"""

from anisofrac.api import init, load, load_config, scene_names
from anisofrac.simulation import Body, Particles, Simulation
from anisofrac.strikes import CrackShape, Preview
from core.errors import BackendError, ConfigError, MaterialError, MeshError, SandboxError

__all__ = [
    "init", "load", "load_config", "scene_names",
    "Simulation", "Body", "Particles", "Preview", "CrackShape",
    "SandboxError", "ConfigError", "MaterialError", "MeshError", "BackendError",
]
