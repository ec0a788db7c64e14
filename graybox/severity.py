"""SeverityScale: how far past its threshold an alert is, in words.

The last small step after the drift, as Merlion's ``post_process`` keeps its threshold: the
calibration (:class:`graybox.calibration.Calibration`) sets each tier's epsilon, a drift
whose zeta exceeds it alarms (:mod:`graybox.alert`), and this scale grades the alarm's
ratio zeta/epsilon as ``minor``, ``major`` or ``critical``. A frozen record with one
``to_dict``/``from_dict``, the ``[alerts]`` table's ``major_ratio`` and ``critical_ratio``.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Mapping

SEVERITIES = ("minor", "major", "critical")


@dataclass(frozen=True)
class SeverityScale:
    """The ratios zeta/epsilon from which an alert is ``major`` and ``critical``.

    Parameters
    ----------
    major_ratio : float, default 2.0
        From this ratio an alert is ``major`` (from 1, where it alarms, ``minor``).
    critical_ratio : float, default 5.0
        From this ratio it is ``critical``.

    Raises
    ------
    ValueError
        Unless ``1 <= major_ratio <= critical_ratio``.
    """

    major_ratio: float = 2.0
    critical_ratio: float = 5.0

    def __post_init__(self) -> None:
        if not 1 <= self.major_ratio <= self.critical_ratio:
            raise ValueError(f"need 1 <= major_ratio <= critical_ratio, got "
                             f"major_ratio={self.major_ratio!r}, "
                             f"critical_ratio={self.critical_ratio!r}")

    def grade(self, ratio: float | None) -> str:
        """``minor`` below ``major_ratio`` (or without a ratio), ``major`` below
        ``critical_ratio``, else ``critical``."""
        if ratio is None or ratio < self.major_ratio:
            return "minor"
        return "major" if ratio < self.critical_ratio else "critical"

    def to_dict(self) -> dict[str, float]:
        """The two ratios as plain floats."""
        return {k: float(v) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "SeverityScale":
        """The scale of :meth:`to_dict` (a missing ratio takes its default)."""
        return cls(**{k: float(data[k]) for k in ("major_ratio", "critical_ratio") if k in data})
