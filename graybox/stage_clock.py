"""CPU and wall seconds spent per named stage of the pipeline, for measurement.

The fits and the flows take an optional clock and time their stages with it; nothing is
timed when none is given. A clock belongs to its caller (no global state), and clocks of
several batches add up with :meth:`StageClock.add`.
"""
from __future__ import annotations

import contextlib
import time
from typing import Iterator


class StageClock:
    """Accumulated CPU (this process, all threads) and wall seconds per stage.

    Examples
    --------
    >>> clock = StageClock()
    >>> with clock("residual"):
    ...     pass
    >>> sorted(clock.to_dict())
    ['residual']
    """

    def __init__(self):
        self.cpu: dict[str, float] = {}
        self.wall: dict[str, float] = {}

    @contextlib.contextmanager
    def __call__(self, stage: str) -> Iterator[None]:
        cpu, wall = time.process_time(), time.perf_counter()
        try:
            yield
        finally:
            self.cpu[stage] = self.cpu.get(stage, 0.0) + time.process_time() - cpu
            self.wall[stage] = self.wall.get(stage, 0.0) + time.perf_counter() - wall

    def add(self, other: "StageClock | dict") -> "StageClock":
        """Add another clock's (or its :meth:`to_dict`'s) seconds to this one; returns self."""
        data = other.to_dict() if isinstance(other, StageClock) else other
        for stage, seconds in data.items():
            self.cpu[stage] = self.cpu.get(stage, 0.0) + seconds["cpu"]
            self.wall[stage] = self.wall.get(stage, 0.0) + seconds["wall"]
        return self

    def to_dict(self) -> dict[str, dict[str, float]]:
        """``{stage: {"cpu": seconds, "wall": seconds}}``."""
        return {stage: {"cpu": self.cpu[stage], "wall": self.wall[stage]} for stage in self.cpu}


def timed(clock: StageClock | None, stage: str):
    """``clock(stage)``, or a no-op context when there is no clock."""
    return contextlib.nullcontext() if clock is None else clock(stage)
