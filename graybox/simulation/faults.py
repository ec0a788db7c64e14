"""Faults injected into a simulated vehicle, and their level over time."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from graybox.simulation.checks import finite, unknown_keys

FAULT_KINDS = ("friction", "nonlinear", "noise", "bias", "heavy_tails")


@dataclass(frozen=True)
class Fault:
    """An incipient fault injected into one vehicle.

    Parameters
    ----------
    kind : {"friction", "nonlinear", "noise", "bias", "heavy_tails"}
        ``"friction"``: the damping rate around the moving equilibrium changes by the relative
        amount ``magnitude`` (0.3 = +30 %); the equilibrium does not move. ``"nonlinear"``:
        blade flutter, ``kappa = magnitude`` in the moment's innovations
        ``u_k = e_k + kappa He3(e_{k-1})``. ``"noise"``: sensor noise std times
        ``1 + magnitude``. ``"heavy_tails"``: Student-t sensor noise with
        ``df = max(2.1, 2 + 4 / magnitude)`` and the same std. ``"bias"``: a step of
        ``magnitude`` rad/s on the measured shaft speed. Several faults of one kind add up.
    onset_day : float
        Days after the fleet start when the fault starts to act.
    magnitude : float
        Size of the fault (see ``kind``). ``friction`` needs ``> -1``, ``noise`` ``>= -1``,
        ``heavy_tails`` ``> 0``.
    ramp_days : float, default 0.0
        ``0``: full magnitude at onset; otherwise the magnitude grows linearly from 0 at onset
        to full after ``ramp_days``. The plant's faults (``friction``, ``nonlinear``) take
        the level at the start of each 10-s moment step, the sensor's at each sample.

    Raises
    ------
    ValueError
        If the kind is unknown or a field is out of range.
    """

    kind: str
    onset_day: float
    magnitude: float
    ramp_days: float = 0.0

    def __post_init__(self):
        if self.kind not in FAULT_KINDS:
            raise ValueError(f"fault kind must be one of {FAULT_KINDS}, got {self.kind!r}")
        onset = finite(self.onset_day, "Fault.onset_day")
        magnitude = finite(self.magnitude, "Fault.magnitude")
        ramp = finite(self.ramp_days, "Fault.ramp_days")
        if onset < 0 or ramp < 0:
            raise ValueError(f"Fault.onset_day and ramp_days must be >= 0, got {onset}, {ramp}")
        low = {"friction": (-1.0, False), "noise": (-1.0, True), "heavy_tails": (0.0, False)}
        if self.kind in low:
            bound, inclusive = low[self.kind]
            if magnitude < bound or (magnitude == bound and not inclusive):
                relation = ">=" if inclusive else ">"
                raise ValueError(f"a {self.kind!r} fault needs magnitude {relation} {bound}, "
                                 f"got {magnitude}")
        object.__setattr__(self, "onset_day", onset)
        object.__setattr__(self, "magnitude", magnitude)
        object.__setattr__(self, "ramp_days", ramp)

    def level(self, days: np.ndarray) -> np.ndarray:
        """Magnitude acting at ``days`` after the fleet start (0 before onset)."""
        days = np.asarray(days, dtype=float)
        if self.ramp_days > 0:
            fraction = np.clip((days - self.onset_day) / self.ramp_days, 0.0, 1.0)
        else:
            fraction = (days >= self.onset_day).astype(float)
        return self.magnitude * fraction

    def to_dict(self) -> dict:
        """JSON-friendly dict; :meth:`from_dict` rebuilds an equal fault."""
        return {"kind": self.kind, "onset_day": self.onset_day, "magnitude": self.magnitude,
                "ramp_days": self.ramp_days}

    @classmethod
    def from_dict(cls, d: Mapping) -> "Fault":
        """Inverse of :meth:`to_dict`."""
        unknown_keys(d, ("kind", "onset_day", "magnitude", "ramp_days"), "Fault")
        return cls(**d)


def fault_level(faults: tuple[Fault, ...], kind: str, days: np.ndarray) -> np.ndarray:
    """Sum of the levels of ``faults`` of ``kind`` at ``days`` after the fleet start."""
    total = np.zeros_like(days)
    for fault in faults:
        if fault.kind == kind:
            total = total + fault.level(days)
    return total
