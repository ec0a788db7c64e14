"""Calibration of the drift threshold epsilon per tier and channel (the paper has no method).

Method (leave one window out, scaled chi-square, predictive F quantile):

1. The baseline period is split into K healthy windows of the nightly length. For each k, the
   tiers are refitted on the other K-1 windows (theta_-k, frozen structure, network started
   from the baseline's weights) and on window k alone (theta_k, started from theta_-k's
   weights, exactly as a nightly candidate starts from its baseline). The change
   d_k = theta_k - theta_-k is a healthy drift: it contains the sampling noise of one window
   and the day-to-day variation of a healthy asset, and window k's data never sits on both
   sides (comparing a window with a baseline that contains it would underestimate zeta).
2. A healthy zeta = |d|^2 is a quadratic form of a roughly Gaussian vector, well described by
   g * chi2(h) (Satterthwaite): g h = tr(Sigma), h = tr(Sigma)^2 / tr(Sigma^2). tr(Sigma) is the
   mean of the K zetas; tr(Sigma^2) is estimated without bias from the cross products
   (d_k . d_l)^2 of distinct windows.
3. With g estimated from only K windows, a new healthy zeta divided by the mean of the K is
   F(h, K h)-distributed, so epsilon = mean(zeta_k) * F.ppf(1 - alpha; h, K h). This accounts
   for the uncertainty of a small K instead of trusting a plug-in quantile.
4. alpha = false_alarm_rate / (tiers x channels) (Bonferroni), so the asset-night false-alarm
   rate stays at or below the target. A candidate window shorter than the calibration windows
   gets epsilon scaled up by the ratio of sample counts (parameter variance ~ 1/N).
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from typing import Sequence

import numpy as np
from scipy import stats

from graybox.exceptions import ArtifactError, InsufficientDataError

METHOD = "leave-one-window-out zeta, scaled chi-square, predictive F quantile"


@dataclass(frozen=True)
class TierThreshold:
    """Epsilon of one tier and channel, and what it was computed from."""

    channel: str
    tier: str
    epsilon: float
    mean_zeta: float        #: mean healthy zeta of the K windows
    dof: float              #: effective degrees of freedom h
    healthy_zetas: tuple[float, ...]


@dataclass(frozen=True)
class Calibration:
    """Thresholds for every tier and channel of a baseline, stored with it.

    Attributes
    ----------
    thresholds : tuple of TierThreshold
    false_alarm_rate : float
        Target false-alarm rate per asset and window.
    test_alpha : float
        Per-threshold rate after the Bonferroni split.
    reference_samples : int
        Residual samples of one calibration window.
    n_windows : int
        K, the healthy windows used.
    method : str
    """

    thresholds: tuple[TierThreshold, ...]
    false_alarm_rate: float
    test_alpha: float
    reference_samples: int
    n_windows: int
    method: str = METHOD

    def threshold(self, channel: str, tier: str) -> TierThreshold:
        for entry in self.thresholds:
            if entry.channel == channel and entry.tier == tier:
                return entry
        raise KeyError(f"no calibrated threshold for channel {channel!r}, tier {tier!r}")

    def epsilon(self, channel: str, tier: str, n_samples: int | None = None) -> float:
        """Epsilon for a candidate of ``n_samples`` residual samples (scaled up if shorter)."""
        value = self.threshold(channel, tier).epsilon
        if n_samples:
            value *= max(1.0, self.reference_samples / n_samples)
        return value

    def to_dict(self) -> dict:
        return asdict(self)

    def to_json(self, indent: int | None = None) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_dict(cls, data) -> "Calibration":
        try:
            entries = tuple(TierThreshold(str(t["channel"]), str(t["tier"]), float(t["epsilon"]),
                                          float(t["mean_zeta"]), float(t["dof"]),
                                          tuple(float(z) for z in t["healthy_zetas"]))
                            for t in data["thresholds"])
            known = {"thresholds", "false_alarm_rate", "test_alpha", "reference_samples",
                     "n_windows", "method"}
            if set(data) - known:
                raise ArtifactError(f"calibration has unknown field(s) {sorted(set(data) - known)}")
            return cls(entries, float(data["false_alarm_rate"]), float(data["test_alpha"]),
                       int(data["reference_samples"]), int(data["n_windows"]),
                       str(data.get("method", METHOD)))
        except ArtifactError:
            raise
        except (TypeError, ValueError, KeyError) as error:
            raise ArtifactError(f"malformed calibration: {error!r}") from None

    @classmethod
    def from_json(cls, text: str | bytes) -> "Calibration":
        try:
            return cls.from_dict(json.loads(text))
        except json.JSONDecodeError as error:
            raise ArtifactError(f"calibration is not valid JSON: {error}") from None


def threshold_from_deltas(deltas: Sequence[np.ndarray], alpha: float) -> tuple[float, float, float]:
    """Epsilon from K healthy parameter changes (steps 2-3 of the module's method).

    Parameters
    ----------
    deltas : sequence of ndarray
        The K vectors ``d_k`` whose squared norms are healthy zetas.
    alpha : float
        Probability that a healthy zeta exceeds epsilon.

    Returns
    -------
    epsilon, mean_zeta, dof : float
    """
    deltas = [np.asarray(d, dtype=float) for d in deltas]
    k = len(deltas)
    if k < 3:
        raise InsufficientDataError(f"calibration needs at least 3 healthy windows, got {k}")
    size = deltas[0].size
    zetas = np.array([d @ d for d in deltas])
    mean = float(zetas.mean())
    if mean <= 0 or size == 0:
        return 0.0, mean, float(max(size, 1))
    cross = [(deltas[i] @ deltas[j]) ** 2 for i in range(k) for j in range(k) if i != j]
    trace_sq = float(np.mean(cross))
    dof = size if trace_sq <= 0 else float(np.clip(mean ** 2 / trace_sq, 1.0, size))
    epsilon = mean * float(stats.f.ppf(1.0 - alpha, dof, k * dof))
    return epsilon, mean, dof
