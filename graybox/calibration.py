"""Calibration of the drift threshold epsilon per tier and channel (the paper has no method).

Method (held-out healthy pieces, scaled chi-square, predictive F quantile):

1. The baseline period consists of K >= 3 healthy windows of the nightly length. Each window
   k is left out in turn: the tiers are refitted on the other K - 1 windows (theta_-k, frozen
   structure), and window k, cut into q pieces, is fitted piece by piece exactly as nightly
   candidates of theta_-k are. Each change d = theta_piece - theta_-k is a healthy drift
   between independent data: sampling noise plus the variation of a healthy asset. (A piece
   compared with a baseline that contains it would understate the drift.)
2. A piece is shorter than a night, so its change is rescaled to the change of a nightly
   window against the full baseline: parameter estimates are asymptotically averages,
   Var(theta_n) = V / n, so Var(d) = V (1/n_piece + 1/n_rest) while a night of N samples gives
   V (1/N + 1/N_baseline); d is multiplied by the square root of the ratio. Cutting windows
   into pieces gives K q healthy drifts instead of K, which matters for estimating a tail.
3. A healthy zeta = |d|^2 is a quadratic form of a roughly Gaussian vector, well described by
   g * chi2(h) (Satterthwaite): g h = tr(Sigma), h = tr(Sigma)^2 / tr(Sigma^2). tr(Sigma) is the
   mean of the zetas; tr(Sigma^2) is estimated without bias from the cross products
   (d_k . d_l)^2 of distinct pieces. A second estimate of h comes from the spread of the
   zetas themselves (variance 2 g^2 h); the smaller h (the heavier tail) is used.
4. With g estimated from only K q pieces, a new healthy zeta divided by their mean is
   F(h, K q h)-distributed, so epsilon = mean(zeta_k) * F.ppf(1 - alpha; h, K q h): the
   uncertainty of a small sample is part of the threshold, not ignored.
5. alpha = false_alarm_rate / (tiers x channels) (Bonferroni), so the asset-night false-alarm
   rate stays at or below the target. A candidate window shorter than the reference window
   gets epsilon scaled up by the ratio of sample counts.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from typing import Sequence

import numpy as np
from scipy import stats

from graybox.exceptions import ArtifactError, InsufficientDataError

METHOD = "held-out healthy pieces rescaled to a night, scaled chi-square, predictive F quantile"


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
        Residual samples of one healthy window (a night).
    n_windows : int
        Healthy pieces the thresholds were estimated from (K windows times q pieces).
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
        raise InsufficientDataError(f"calibration needs at least 3 healthy changes, got {k}")
    size = deltas[0].size
    zetas = np.array([d @ d for d in deltas])
    mean = float(zetas.mean())
    if mean <= 0 or size == 0:
        return 0.0, mean, float(max(size, 1))
    cross = [(deltas[i] @ deltas[j]) ** 2 for i in range(k) for j in range(k) if i != j]
    trace_sq = float(np.mean(cross))
    dof_cross = np.inf if trace_sq <= 0 else mean ** 2 / trace_sq
    # the zetas' own spread gives a second estimate (g chi2(h) has variance 2 g^2 h); it
    # guards against non-Gaussian changes, e.g. a network landing in different minima
    spread = float(zetas.var(ddof=1))
    dof_spread = np.inf if spread <= 0 else 2 * mean ** 2 / spread
    dof = float(np.clip(min(dof_cross, dof_spread, size), 1.0, size))
    epsilon = mean * float(stats.f.ppf(1.0 - alpha, dof, k * dof))
    return epsilon, mean, dof
