"""A batch's memory budget: how many assets' telemetry to hold and fit at once.

A batch task reads its assets one after another and fits them in groups whose estimated
working memory stays within ``[nightly] memory_budget`` (the peak resident size the task's
process may reach), so the peak does not grow with the batch size or the fleet.

The estimate is the telemetry's in-memory size times a factor per kind of fit, measured at
1 Hz on this project's engine (``python -m benchmarks.nightly_scale`` prints the peaks): a
candidate holds its telemetry plus the native-rate residual while it is decimated (factor
:data:`CANDIDATE_FACTOR`); a baseline also holds every leave-one-window-out refit and the
calibration pieces (factor :data:`BASELINE_FACTOR`). The batched network computations are
bounded by their chunk size, not by the group, and are covered by :data:`FIXED_RESERVE`.
"""
from __future__ import annotations

import re
import resource
from dataclasses import dataclass

CANDIDATE_FACTOR = 4.0
#: measured: a 3-day 1-Hz baseline (6.2 MB of telemetry) adds about 50 MB to a batch's peak
BASELINE_FACTOR = 10.0
FIXED_RESERVE = 320 * 2 ** 20    # one batched network computation (graybox CHUNK_SAMPLES)

_UNITS = {"": 1, "B": 1, "KB": 10 ** 3, "MB": 10 ** 6, "GB": 10 ** 9, "TB": 10 ** 12,
          "KIB": 2 ** 10, "MIB": 2 ** 20, "GIB": 2 ** 30, "TIB": 2 ** 40}
_SIZE = re.compile(r"^\s*([0-9]+(?:\.[0-9]+)?)\s*([A-Za-z]*)\s*$")


def parse_bytes(text: str | int | float) -> int:
    """``"4GB"``, ``"512MiB"`` or a number of bytes, as an int.

    Raises
    ------
    ValueError
        For anything else (the message lists the units).
    """
    if isinstance(text, bool):
        raise ValueError(f"expected a size such as \"4GB\", got {text!r}")
    if isinstance(text, (int, float)):
        value, unit = float(text), ""
    else:
        match = _SIZE.match(str(text))
        if match is None or match.group(2).upper() not in _UNITS:
            raise ValueError(f"expected a size such as \"4GB\" or \"512MiB\" (units "
                             f"{', '.join(u for u in _UNITS if u)}), got {text!r}")
        value, unit = float(match.group(1)), match.group(2).upper()
    size = int(value * _UNITS[unit])
    if size <= 0:
        raise ValueError(f"a size must be positive, got {text!r}")
    return size


def resident_bytes() -> int:
    """The process's resident size now (Linux ``/proc``; elsewhere its peak so far)."""
    try:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[1]) * resource.getpagesize()
    except (OSError, ValueError, IndexError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


@dataclass(frozen=True)
class MemoryBudget:
    """Bytes a batch may use for its assets' telemetry and fits.

    Attributes
    ----------
    available : int
        The budget less the process's resident size when the batch started and
        :data:`FIXED_RESERVE`; at least one asset is always taken.
    factor : float
        Working memory per byte of telemetry held.
    """

    available: int
    factor: float

    @classmethod
    def for_batch(cls, budget: int, baseline: bool) -> "MemoryBudget":
        return cls(max(0, budget - resident_bytes() - FIXED_RESERVE),
                   BASELINE_FACTOR if baseline else CANDIDATE_FACTOR)

    def need(self, telemetry_bytes: int) -> int:
        """Estimated working memory of an asset holding ``telemetry_bytes`` of telemetry."""
        return int(telemetry_bytes * self.factor)

    def full(self, used: int, need: int) -> bool:
        """Whether a group already using ``used`` must be fitted before an asset needing
        ``need`` joins it. That asset's telemetry is read already, and the next one's will be
        while the group is fitted: room for it is kept (assets of a class are alike)."""
        return used > 0 and used + 2 * need > self.available
