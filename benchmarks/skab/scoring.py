"""SKAB scored two ways on the same windows.

(a) **Per experiment**: detected when a *fault* window (one holding a labelled anomaly row)
alarmed; a false alarm when a *healthy* window (all its rows before the first anomaly) alarmed;
the delay is from the first anomaly row to the end of the first alarmed fault window (when the
alarm could be raised).

(b) **Point-wise, as SKAB's leaderboard**: every row of an alarmed window is predicted
anomalous, every other row normal; F1, FAR (false alarms over normal rows) and MAR (missed
rows over anomalous rows) over the rows of all scored experiments together. Rows of windows a
detector did not analyse count as predicted normal.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd


@dataclass(frozen=True)
class ExperimentScore:
    """One detector on one experiment."""

    experiment: str
    detected: bool
    false_alarm: bool
    delay_s: float | None
    healthy_windows: int
    fault_windows: int
    alarmed_fault_windows: int


def score_experiment(name: str, labels: pd.Series, alarms: pd.Series, onset) -> ExperimentScore:
    """``labels`` (fault / healthy / after) and ``alarms`` (bool) per window start; windows
    missing from ``alarms`` were not analysed."""
    window_alarm = alarms.reindex(labels.index)
    analysed = window_alarm.notna()
    fault = (labels == "fault") & analysed
    healthy = (labels == "healthy") & analysed
    fired = window_alarm.fillna(False).astype(bool)
    hit = fault & fired
    delay = None
    if hit.any() and onset is not None:
        step = labels.index[1] - labels.index[0] if len(labels) > 1 else pd.Timedelta(0)
        delay = max(0.0, ((labels.index[hit.to_numpy()][0] + step) - onset).total_seconds())
    return ExperimentScore(name, bool(hit.any()), bool((healthy & fired).any()), delay,
                           int(healthy.sum()), int(fault.sum()), int(hit.sum()))


@dataclass(frozen=True)
class PointCounts:
    tp: int = 0
    fp: int = 0
    tn: int = 0
    fn: int = 0

    def __add__(self, other: "PointCounts") -> "PointCounts":
        return PointCounts(self.tp + other.tp, self.fp + other.fp, self.tn + other.tn,
                           self.fn + other.fn)

    @property
    def f1(self) -> float:
        return 2 * self.tp / (2 * self.tp + self.fp + self.fn) if self.tp else 0.0

    @property
    def far(self) -> float:
        return self.fp / (self.fp + self.tn) if self.fp + self.tn else 0.0

    @property
    def mar(self) -> float:
        return self.fn / (self.fn + self.tp) if self.fn + self.tp else 0.0


def point_counts(timestamps: pd.Series, truth: np.ndarray, alarms: pd.Series,
                 window: pd.Timedelta) -> PointCounts:
    """Every row of an alarmed window predicted anomalous (rows of windows not analysed:
    normal), against SKAB's ``anomaly`` labels ``truth``."""
    starts = timestamps.dt.floor(window)
    predicted = starts.map(alarms.astype(bool)).fillna(False).to_numpy(bool)
    truth = np.asarray(truth, bool)
    return PointCounts(int((predicted & truth).sum()), int((predicted & ~truth).sum()),
                       int((~predicted & ~truth).sum()), int((~predicted & truth).sum()))


@dataclass(frozen=True)
class Summary:
    """One detector over the scored experiments."""

    detector: str
    experiments: int
    detected: int
    false_alarms: int
    healthy_windows: int
    median_delay_s: float | None
    points: PointCounts

    def row(self) -> list[str]:
        delay = "-" if self.median_delay_s is None else f"{self.median_delay_s:.0f}"
        return [self.detector, f"{self.detected}/{self.experiments}",
                f"{self.false_alarms}/{self.experiments}", delay, f"{self.points.f1:.2f}",
                f"{100 * self.points.far:.1f}", f"{100 * self.points.mar:.1f}"]


def summarise(detector: str, scores: list[ExperimentScore], points: PointCounts) -> Summary:
    """The detector over the experiments it analysed (a window of them, at least)."""
    scores = [s for s in scores if s.fault_windows + s.healthy_windows > 0]
    delays = [s.delay_s for s in scores if s.delay_s is not None]
    return Summary(detector, len(scores), sum(s.detected for s in scores),
                   sum(s.false_alarm for s in scores), sum(s.healthy_windows for s in scores),
                   float(np.median(delays)) if delays else None, points)


HEADER = ["detector", "faulty experiments alarmed", "experiments with a false alarm",
          "median delay (s)", "F1 (points)", "FAR %", "MAR %"]
