"""Stage timers: wall-clock seconds per named stage, per frame and in total (for stats.json)."""

from __future__ import annotations

import time
from collections import defaultdict
from contextlib import contextmanager


class StageTimers:
    def __init__(self) -> None:
        self.total: dict[str, float] = defaultdict(float)  # s per stage over the run
        self.frame: dict[str, float] = defaultdict(float)  # s per stage in the current frame
        self.frames: list[dict[str, float]] = []  # one dict per finished frame

    @contextmanager
    def stage(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            dt = time.perf_counter() - t0
            self.total[name] += dt
            self.frame[name] += dt

    def add(self, name: str, seconds: float) -> None:
        """Book seconds measured elsewhere (the stages inside a fracture event) under a stage name."""
        self.total[name] += seconds
        self.frame[name] += seconds

    def end_frame(self) -> dict[str, float]:
        done = {k: round(v * 1e3, 4) for k, v in self.frame.items()}
        self.frames.append(done)
        self.frame = defaultdict(float)
        return done
