"""Files a run leaves behind: every file is written to a temporary name and renamed into place."""

from __future__ import annotations

import functools
import json
import os
import tempfile
from pathlib import Path

from core.errors import ConfigError


@functools.cache
def _file_mode() -> int:
    """The mode a plainly created file gets under the process's umask (mkstemp's own is 0600, which
    would hide a run's outputs from the other users of a shared server)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def temporary_beside(path: Path, suffix: str = ".tmp") -> Path:
    """A new empty file beside `path` (hidden name ending in `suffix`) with a plain file's mode: write
    the output there, then `os.replace` it onto `path`."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    os.chmod(tmp, _file_mode())
    return Path(tmp)


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write `data` to a temporary file beside `path`, then rename it into place."""
    path = Path(path)
    tmp = temporary_beside(path)
    try:
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_text(path: Path, text: str) -> None:
    atomic_write_bytes(path, text.encode())


def atomic_write_json(path: Path, data: dict) -> None:
    atomic_write_text(path, json.dumps(data, indent=2, sort_keys=False) + "\n")


# The numbered sequences a run writes into its folder, one file per frame (render/writers.py
# FRAME_PATTERN, sim/export_frames.py): (subfolder, file glob). A run that overwrites a folder removes
# an earlier run's first, or a shorter run would leave that run's later frames beside its own.
FRAME_SEQUENCES = (("frames", "frame_*.png"), ("meshes", "frame_*.*"), ("vtu", "particles_*.vtu"),
                   ("vtu", "particles.pvd"))


def remove_frame_sequences(path: Path) -> None:
    """Delete the per-frame files of an earlier run in the output folder `path` (FRAME_SEQUENCES)."""
    for sub, pattern in FRAME_SEQUENCES:
        for f in (Path(path) / sub).glob(pattern):
            if f.is_file():
                f.unlink()


def prepare_output_dir(path: Path, overwrite: bool) -> Path:
    """Create the output folder; refuse a non-empty one without `overwrite`, or an unwritable one."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ConfigError("--out", str(path), "a folder (a file of that name exists)")
    if path.exists() and any(path.iterdir()) and not overwrite:
        raise ConfigError("--out", str(path), "a new or empty folder, or pass --overwrite to replace its files")
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".write_probe"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise ConfigError("--out", str(path), f"a writable folder ({exc.strerror})") from None
    return path
