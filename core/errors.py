"""Errors a user can act on.

Every failure caused by input (a file, a scene key, a command-line option, a material constant)
raises a subclass of `SandboxError` whose message names where the problem is and what is allowed.
The command line prints the message and exits non-zero; it never shows a traceback for these.
"""

from __future__ import annotations


class SandboxError(Exception):
    """Base of every error the command line reports as a plain message. It pickles as it is (its
    message and attributes, whatever its constructor takes): the drawing process sends its errors
    back to the simulation (render/draw_process.py)."""

    def __reduce__(self):
        return _restore, (type(self), self.args, dict(self.__dict__))


def _restore(cls, args: tuple, state: dict) -> SandboxError:
    error = cls.__new__(cls)
    Exception.__init__(error, *args)
    error.__dict__.update(state)
    return error


class MeshError(SandboxError):
    """A mesh file or generated mesh is unusable: names the file, the problem and a count or index."""

    def __init__(self, source: str, problem: str, detail: str = "") -> None:
        self.source = source
        self.problem = problem
        self.detail = detail
        text = f"{source}: {problem}"
        if detail:
            text += f" ({detail})"
        super().__init__(text)


class ConfigError(SandboxError):
    """A configuration value is wrong: names the key path, the value and the allowed range."""

    def __init__(self, key_path: str, value: object, allowed: str, source: str = "") -> None:
        self.key_path = key_path
        self.value = value
        self.allowed = allowed
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{key_path} = {value!r} is invalid; allowed: {allowed}")


class MaterialError(ConfigError):
    """A material constant is out of range or the stiffness it implies is not physical."""


class CapacityError(SandboxError):
    """A store would overflow; names the store and the scene option to raise."""


class BackendError(SandboxError):
    """The requested Taichi backend is not available on this machine."""
