"""Typed configuration with units and ranges: the checking behind every scene table (scenes/config.py).

Each dataclass field carries a `Spec` (type, allowed range or choices, unit); `from_dict` builds a
dataclass from plain data and rejects unknown keys, wrong types, NaN/inf and out-of-range values with
a ConfigError that names the key path, the value and the allowed range.
"""

from __future__ import annotations

import copy
import math
from dataclasses import MISSING, dataclass, field, fields
from typing import Any

from core.errors import ConfigError


@dataclass(frozen=True)
class Spec:
    """What a configuration value may be."""

    kind: str  # "float", "int", "int_or_auto", "bool", "str", "strs", "vec3", "floats", "dict", "table", "tables"
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    unit: str = ""
    choices: tuple = ()
    table: type | None = None  # dataclass for "table" / "tables"
    length: int | None = None  # for "floats"

    def allowed(self) -> str:
        if self.choices:
            return "one of " + ", ".join(map(str, self.choices))
        parts = []
        if self.lo is not None:
            parts.append(f"{'>' if self.lo_open else '>='} {self.lo:g}")
        if self.hi is not None:
            parts.append(f"{'<' if self.hi_open else '<='} {self.hi:g}")
        what = {
            "float": "a finite number",
            "int": "an integer",
            "int_or_auto": "\"auto\" or an integer",
            "bool": "true or false",
            "str": "a string",
            "vec3": "3 finite numbers",
            "floats": f"a list of {self.length or 'any number of'} finite numbers",
            "strs": "a list of names",
            "dict": "a table",
            "table": "a table",
            "tables": "an array of tables",
        }[self.kind]
        rng = (" " + " and ".join(parts)) if parts else ""
        unit = f" ({self.unit})" if self.unit else ""
        return what + rng + unit


def spec_field(kind: str, default: Any = MISSING, **kw) -> Any:
    """A dataclass field with its Spec; no default means the key is required."""
    s = Spec(kind, **kw)
    if default is MISSING:
        return field(metadata={"spec": s})
    if isinstance(default, (list, dict)) or hasattr(default, "__dataclass_fields__"):
        return field(default_factory=lambda d=default: copy.deepcopy(d), metadata={"spec": s})
    return field(default=default, metadata={"spec": s})


def _number(value: Any, spec: Spec, path: str, source: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(path, value, spec.allowed(), source)
    v = float(value)
    if not math.isfinite(v):
        raise ConfigError(path, value, spec.allowed(), source)
    if spec.lo is not None and (v < spec.lo or (spec.lo_open and v == spec.lo)):
        raise ConfigError(path, value, spec.allowed(), source)
    if spec.hi is not None and (v > spec.hi or (spec.hi_open and v == spec.hi)):
        raise ConfigError(path, value, spec.allowed(), source)
    return v


def check_value(value: Any, spec: Spec, path: str, source: str = "") -> Any:
    """Validate one value against its Spec; returns it converted (ints to floats and so on)."""
    k = spec.kind
    if k == "float":
        return _number(value, spec, path, source)
    if k == "int_or_auto" and value == "auto":
        return value
    if k in ("int", "int_or_auto"):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(path, value, spec.allowed(), source)
        _number(value, spec, path, source)
        return int(value)
    if k == "bool":
        if not isinstance(value, bool):
            raise ConfigError(path, value, spec.allowed(), source)
        return value
    if k == "str":
        if not isinstance(value, str) or (spec.choices and value not in spec.choices):
            raise ConfigError(path, value, spec.allowed(), source)
        return value
    if k == "strs":
        if not isinstance(value, list):
            raise ConfigError(path, value, "a list of: " + ", ".join(spec.choices), source)
        for i, v in enumerate(value):
            if not isinstance(v, str) or (spec.choices and v not in spec.choices):
                raise ConfigError(f"{path}[{i}]", v, spec.allowed(), source)
        return list(value)
    if k in ("vec3", "floats"):
        n = 3 if k == "vec3" else spec.length
        if not isinstance(value, list) or (n is not None and len(value) != n):
            raise ConfigError(path, value, spec.allowed(), source)
        return [_number(v, spec, f"{path}[{i}]", source) for i, v in enumerate(value)]
    if k == "dict":
        if not isinstance(value, dict):
            raise ConfigError(path, value, spec.allowed(), source)
        _reject_non_finite(value, path, source)
        return value
    if k == "table":
        if not isinstance(value, dict):
            raise ConfigError(path, value, spec.allowed(), source)
        return from_dict(spec.table, value, path, source)
    if k == "tables":
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise ConfigError(path, value, spec.allowed(), source)
        return [from_dict(spec.table, v, f"{path}[{i}]", source) for i, v in enumerate(value)]
    raise AssertionError(f"unknown spec kind {k}")


def _reject_non_finite(value: Any, path: str, source: str) -> None:
    """Free-form tables (shape and stiffness parameters) still may not hold NaN or inf."""
    if isinstance(value, dict):
        for key, v in value.items():
            _reject_non_finite(v, f"{path}.{key}", source)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _reject_non_finite(v, f"{path}[{i}]", source)
    elif isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(path, value, "a finite number", source)


def from_dict(cls: type, data: dict, path: str, source: str = "") -> Any:
    """Build dataclass `cls` from a dict, validating every key (see module docstring)."""
    known = {f.name: f for f in fields(cls) if "spec" in f.metadata}
    for key in data:
        if key not in known:
            raise ConfigError(
                f"{path}.{key}" if path else key, data[key], "a known key: " + ", ".join(sorted(known)), source
            )
    kwargs = {}
    for name, f in known.items():
        sub = f"{path}.{name}" if path else name
        if name in data:
            kwargs[name] = check_value(data[name], f.metadata["spec"], sub, source)
        elif f.default is MISSING and f.default_factory is MISSING:
            raise ConfigError(sub, None, "required: " + f.metadata["spec"].allowed(), source)
    obj = cls(**kwargs)
    check = getattr(obj, "check", None)
    if check is not None:
        check(path, source)
    return obj
