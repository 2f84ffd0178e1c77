"""Load and validate scene files; apply `--set key.path=value` overrides before validation.

Nothing is built from a scene that fails: `load_scene` returns a validated `SceneConfig` or raises
a `ConfigError` naming the file, the key path, the value and the allowed range.
"""

from __future__ import annotations

import copy
import re
import sys
from pathlib import Path

from core.errors import ConfigError
from core.spec import from_dict
from scenes.config import SceneConfig

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

SCENE_DIR = Path(__file__).resolve().parent


def scene_names() -> list[str]:
    return sorted(p.stem for p in SCENE_DIR.glob("*.toml"))


def scene_path(name_or_path: str) -> Path:
    """A scene name from scenes/ or a path to a .toml file."""
    p = Path(name_or_path)
    if p.suffix == ".toml":
        if not p.exists():
            raise ConfigError("scene", str(p), "an existing .toml file")
        return p
    candidate = SCENE_DIR / f"{name_or_path}.toml"
    try:
        found = candidate.is_file()
    except OSError:  # not a usable file name at all (too long, a NUL byte)
        found = False
    if not found:
        raise ConfigError("scene", name_or_path, "one of " + ", ".join(scene_names()) + ", or a .toml path")
    return candidate


_INDEX = re.compile(r"\[\s*([^\]\s]+)\s*\]")  # objects[1] -> objects.1


def resolve_mesh_path(mesh: str, source: str = "") -> str:
    """A scene's `mesh` path: absolute, or relative to the working folder, else to the scene file's
    folder, else to the project root (so `assets/vase.ply` works from anywhere). Unfound paths are
    returned as written: the mesh loader then names the missing file."""
    p = Path(mesh).expanduser()
    if p.is_absolute() or p.exists():
        return str(p)
    bases = ([Path(source).resolve().parent] if source and Path(source).exists() else []) + [SCENE_DIR.parent]
    for base in bases:
        if (base / p).exists():
            return str(base / p)
    return mesh


def _parse_value(text: str, key: str):
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text  # a bare word is a string


def apply_override(data: dict, assignment: str) -> None:
    """Apply one `key.path=value` (value in TOML syntax) to raw scene data.

    Array-of-table items are addressed by index, dotted or in brackets (`objects.0.velocity`,
    `objects[0].velocity`, the form error messages use), or by name
    (`materials.porcelain.tensile_strength`).
    """
    if "=" not in assignment:
        raise ConfigError("--set", assignment, "key.path=value")
    path, text = assignment.split("=", 1)
    path = _INDEX.sub(r".\1", path.strip())
    keys = path.split(".")
    if any(not k for k in keys):
        raise ConfigError("--set", assignment, "key.path=value with no empty key (a.b.c, objects[0].velocity)")
    node = data
    for i, key in enumerate(keys[:-1]):
        where = ".".join(keys[: i + 1])
        if isinstance(node, list):
            match = [t for t in node if isinstance(t, dict) and t.get("name") == key]
            if key.isdigit() and int(key) < len(node):
                node = node[int(key)]
            elif match:
                node = match[0]
            else:
                names = [t["name"] for t in node if isinstance(t, dict) and "name" in t]
                allowed = f"an index 0..{len(node) - 1}" if node else "nothing (the list is empty)"
                raise ConfigError(f"--set {where}", key, allowed + (" or a name: " + ", ".join(names) if names else ""))
        elif isinstance(node, dict):
            node = node.setdefault(key, {})
        else:
            raise ConfigError(f"--set {where}", node, "a table or an array of tables")
    if not isinstance(node, dict):
        raise ConfigError(f"--set {path}", text, "a key inside a table")
    node[keys[-1]] = _parse_value(text.strip(), path)


def load_scene(name_or_path: str, overrides: list[str] | None = None) -> SceneConfig:
    path = scene_path(name_or_path)
    try:
        raw = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError("scene file", str(path), f"valid TOML ({exc})") from None
    return scene_from_dict(raw, str(path), overrides)


def scene_from_dict(raw: dict, source: str = "<dict>", overrides: list[str] | None = None) -> SceneConfig:
    data = copy.deepcopy(raw)
    for assignment in overrides or []:
        apply_override(data, assignment)
    cfg = from_dict(SceneConfig, data, "", source)
    cfg.source = source
    return cfg
