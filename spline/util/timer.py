"""Named stage timings: the one stopwatch of builds, fits and re-fairs.

    clock = StageTimer(progress)        # progress(stage, seconds) after each stage, optional
    ...; clock("build")                  # time since the previous mark, added to "build"
    clock.timings                        # {"build": 0.12, ...}
"""
from __future__ import annotations

import time
from typing import Callable


class StageTimer:
    """Accumulates wall time per named stage; each call closes the stage that just ran."""

    def __init__(self, progress: Callable[[str, float], None] | None = None) -> None:
        self.timings: dict[str, float] = {}
        self._progress = progress
        self._last = time.perf_counter()

    def __call__(self, name: str) -> float:
        """Close stage ``name`` (time since the previous call or the start); returns its total."""
        now = time.perf_counter()
        total = self.timings.get(name, 0.0) + now - self._last
        self.timings[name] = total
        self._last = now
        if self._progress is not None:
            self._progress(name, total)
        return total
