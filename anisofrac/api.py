"""Module-level functions of the public API: start Taichi, list and load scenes (docs/api.md)."""

from __future__ import annotations

import datetime
import json
import math
from pathlib import Path

from core.errors import ConfigError


def init(arch: str = "cpu", precision: str = "f32", threads: int = 1):
    """Start Taichi: arch 'cpu', 'cuda' or 'auto'; precision 'f32' or 'f64'; CPU threads (1: runs
    are bitwise reproducible, 0: all cores). Once per process: calling again with the same settings
    does nothing, other settings raise BackendError. Returns the runtime (arch, precision, device)."""
    from core.runtime import init_taichi

    return init_taichi(arch=arch, precision=precision, threads=threads)


def scene_names() -> list[str]:
    """The scenes shipped in scenes/ (load them by name)."""
    from scenes.loader import scene_names as names

    return names()


def toml_literal(value, key: str = "overrides") -> str:
    """A Python value (as TOML parses it, or numpy) written as one canonical TOML literal, the form
    `--set` takes and sweep rows are keyed by. Other types raise ConfigError naming `key`."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_literal(v, key) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {toml_literal(v, key)}" for k, v in value.items()) + "}"
    if isinstance(value, (datetime.date, datetime.time)):
        return str(value)  # as TOML writes dates and times
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        return toml_literal(value.tolist(), key)
    raise ConfigError(key, value, "a number, string, bool, date, list or table")


def overrides_as_text(overrides) -> list[str]:
    """`{"materials.glass.cracks": 8}` or `["materials.glass.cracks=8"]` -> the `--set` strings."""
    if overrides is None:
        return []
    if isinstance(overrides, dict):
        return [f"{k}={toml_literal(v, f'overrides.{k}')}" for k, v in overrides.items()]
    if isinstance(overrides, (list, tuple)) and all(isinstance(o, str) for o in overrides):
        return list(overrides)
    raise ConfigError("overrides", overrides, "a dict of key paths to values, or a list of 'key.path=value'")


def load_config(scene: str | Path, overrides=None):
    """The validated scene (scenes.config.SceneConfig) by name (`scene_names()`) or .toml path, with
    overrides by the same key paths as `--set` (`objects.0.velocity`, `materials.glass.cracks`)."""
    from scenes.loader import load_scene

    return load_scene(str(scene), overrides_as_text(overrides))


def load(scene, overrides=None, seed: int | None = None):
    """Build a scene (a name, a .toml path, or a SceneConfig from `load_config`) and return its
    Simulation (anisofrac.simulation.Simulation). Starts Taichi with the defaults unless `init` was
    called. Bad names, paths and values raise ConfigError naming the key path, the value and what is
    allowed, exactly as the command line reports them."""
    from anisofrac.simulation import Simulation
    from scenes.config import SceneConfig

    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise ConfigError("load.seed", seed, "an integer >= 0")
    if isinstance(scene, SceneConfig):
        if overrides:
            raise ConfigError("load.overrides", overrides, "none with a SceneConfig (pass them to load_config)")
        return Simulation(scene, seed=seed)
    if not isinstance(scene, (str, Path)):
        raise ConfigError("load.scene", type(scene).__name__, "a scene name, a .toml path or a SceneConfig")
    return Simulation(load_config(scene, overrides), seed=seed)
