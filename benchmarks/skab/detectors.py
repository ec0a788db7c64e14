"""The comparison detectors of SKAB's leaderboard, run on the gray box's windows.

Both see the rows the gray box sees (the conditioned export: the five measured channels and the
two 60-s averaged electrical inputs, 1 s apart) and learn from the same healthy rows as the
experiment's baseline:

``pca_t2q``   PCA on the standardized channels, the components that explain 90 % of the
              variance kept; per row Hotelling's T2 (the kept scores over their variances) and
              Q (the squared reconstruction error). A window alarms when its mean T2 or its
              mean Q exceeds its threshold.
``iforest``   scikit-learn's ``IsolationForest`` (100 trees, seeded); per row the negated
              ``score_samples`` (larger is more anomalous); a window alarms when its mean
              exceeds the threshold.

Threshold (the same for every statistic): the largest window mean over the baseline's windows,
each scored *out of sample*: the baseline's windows split into two alternating halves, each
half scored by a model fitted on the other, as the gray box's epsilon is calibrated on
left-out baseline windows. With K baseline windows a new healthy window exceeds it about once
in K + 1.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from sklearn.ensemble import IsolationForest

CHANNELS = ("motor_temp", "fluid_temp", "flow", "vibration_1", "vibration_2", "current",
            "voltage")
DETECTORS = ("pca_t2q", "iforest")
EXPLAINED = 0.9
SEED = 0


@dataclass(frozen=True)
class PcaModel:
    """Standardization and the kept principal axes."""

    mean: np.ndarray
    scale: np.ndarray
    axes: np.ndarray          # (k, channels)
    variances: np.ndarray     # (k,)

    @classmethod
    def fit(cls, x: np.ndarray) -> "PcaModel":
        mean, scale = x.mean(axis=0), x.std(axis=0)
        scale = np.where(scale > 0, scale, 1.0)
        z = (x - mean) / scale
        _, singular, vt = np.linalg.svd(z, full_matrices=False)
        variances = singular ** 2 / (len(z) - 1)
        kept = int(np.searchsorted(np.cumsum(variances) / variances.sum(), EXPLAINED) + 1)
        return cls(mean, scale, vt[:kept], variances[:kept])

    def scores(self, x: np.ndarray) -> np.ndarray:
        """Per row ``(T2, Q)``."""
        z = (x - self.mean) / self.scale
        projected = z @ self.axes.T
        t2 = (projected ** 2 / self.variances).sum(axis=1)
        q = ((z - projected @ self.axes) ** 2).sum(axis=1)
        return np.stack([t2, q], axis=1)


@dataclass(frozen=True)
class ForestModel:
    forest: IsolationForest

    @classmethod
    def fit(cls, x: np.ndarray) -> "ForestModel":
        return cls(IsolationForest(n_estimators=100, random_state=SEED).fit(x))

    def scores(self, x: np.ndarray) -> np.ndarray:
        return -self.forest.score_samples(x)[:, None]


MODELS = {"pca_t2q": PcaModel, "iforest": ForestModel}


def _window_means(scores: np.ndarray, starts: np.ndarray) -> pd.DataFrame:
    return pd.DataFrame(scores).groupby(starts).mean()


@dataclass(frozen=True)
class WindowDetector:
    """A detector fitted on the baseline rows with its per-statistic thresholds."""

    name: str
    model: object
    thresholds: np.ndarray

    @classmethod
    def fit(cls, name: str, healthy: pd.DataFrame, window: pd.Timedelta) -> "WindowDetector":
        """Fit on the rows of ``healthy`` (timestamp and :data:`CHANNELS`)."""
        kind = MODELS[name]
        x = healthy[list(CHANNELS)].to_numpy(float)
        starts = healthy["timestamp"].dt.floor(window).to_numpy()
        order = {s: i for i, s in enumerate(np.unique(starts))}
        half = np.array([order[s] % 2 for s in starts])
        held_out = []
        for part in (0, 1):
            model = kind.fit(x[half != part])
            held_out.append(_window_means(model.scores(x[half == part]), starts[half == part]))
        thresholds = pd.concat(held_out).max(axis=0).to_numpy()
        return cls(name, kind.fit(x), thresholds)

    def windows(self, rows: pd.DataFrame, window: pd.Timedelta) -> pd.DataFrame:
        """Per window start: each statistic's mean and ``alarm``."""
        starts = rows["timestamp"].dt.floor(window).to_numpy()
        means = _window_means(self.model.scores(rows[list(CHANNELS)].to_numpy(float)), starts)
        means["alarm"] = (means.to_numpy() > self.thresholds).any(axis=1)
        return means
