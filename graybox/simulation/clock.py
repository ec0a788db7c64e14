"""The simulator's time grids: output samples, integration steps and the 10-s moment clock.

The random moment lives on a fixed physical clock of :data:`MOMENT_STEP` seconds; a sampling
interval either divides it (the plant is integrated per sample) or is a multiple of it (the
plant is integrated per moment step and every ``dt / 10``-th state is a sample).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from graybox.simulation.checks import finite

if TYPE_CHECKING:
    from graybox.simulation.specs import FleetSpec

SECONDS_PER_DAY = 86_400.0
MOMENT_STEP = 10.0  # s, the physical clock of the random moment and the fuel wander


def moment_steps_ratio(sample_interval: float) -> tuple[int, int]:
    """How a sampling interval meets the moment clock of :data:`MOMENT_STEP` seconds.

    Parameters
    ----------
    sample_interval : float
        Seconds between samples: ``MOMENT_STEP / p`` or ``MOMENT_STEP * q`` for integers
        ``p, q >= 1`` (1, 2, 2.5, 5, 10, 20, 30, 60 s, ...).

    Returns
    -------
    per_step : int
        Samples per moment step (``p``; 1 from 10 s up).
    stride : int
        Moment steps per sample (``q``; 1 up to 10 s).

    Raises
    ------
    ValueError
        For any other interval.
    """
    dt = finite(sample_interval, "sample_interval")
    if 0 < dt <= MOMENT_STEP:
        per_step = round(MOMENT_STEP / dt)
        if abs(per_step * dt - MOMENT_STEP) <= 1e-9 * MOMENT_STEP:
            return per_step, 1
    elif dt > MOMENT_STEP:
        stride = round(dt / MOMENT_STEP)
        if abs(stride * MOMENT_STEP - dt) <= 1e-9 * dt:
            return 1, stride
    raise ValueError(
        f"sample_interval must divide the {MOMENT_STEP:g}-s moment step (10 / an integer: 1, 2, "
        f"2.5, 5, 10 s, ...) or be a multiple of it (20, 30, 60 s, ...), got {sample_interval!r}")



@dataclass(frozen=True)
class Clock:
    """The three time grids of a simulation.

    Output samples ``k dt``, ``k < n``; integration instants ``j h``, ``j < n_int``, with
    ``h = min(dt, MOMENT_STEP)`` (sample ``k`` is instant ``k stride``); moment steps
    ``i MOMENT_STEP``, ``i < n_moment`` (integration step ``j`` lies in step ``j // per_step``).
    ``n_moment`` is the number of 10-s samples of the fleet's days, whatever ``dt``.
    """

    n: int
    dt: float
    h: float
    per_step: int
    stride: int
    n_int: int
    n_moment: int

    @classmethod
    def of(cls, spec: FleetSpec) -> "Clock":
        """The grids of ``spec``."""
        n, dt = spec.n_samples, spec.sample_interval
        per_step, stride = moment_steps_ratio(dt)
        n_moment = int(math.ceil(spec.days * SECONDS_PER_DAY / MOMENT_STEP - 1e-9))
        return cls(n=n, dt=dt, h=min(dt, MOMENT_STEP), per_step=per_step, stride=stride,
                   n_int=(n - 1) * stride + 1, n_moment=n_moment)

    def step_of_sample(self) -> np.ndarray:
        """The moment step each output sample starts in."""
        return np.arange(self.n) * self.stride // self.per_step
