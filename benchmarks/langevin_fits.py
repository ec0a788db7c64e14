"""The Langevin-shaft days and fits the registry's benchmark and tests record.

:func:`make_day` simulates one day of a :class:`graybox.models.LangevinShaft` driven by
coloured noise; :func:`fit_langevin` fits a calibrated baseline on days 0-3 and a candidate
on day 5 against it, with its drift (seconds of work: fit once, record many times).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

if TYPE_CHECKING:   # graybox (torch) loads only when fitting
    from graybox.calibration import Calibration
    from graybox.drift import Drift
    from graybox.models import LangevinShaft
    from graybox.signature import Signature

DAY0 = pd.Timestamp("2026-01-01", tz="UTC")
N_SAMPLES = 2000


def make_day(day: int, seed: int, gamma: float = 0.06, noise: float = 0.3, n: int = N_SAMPLES,
             dt: float = 10.0) -> pd.DataFrame:
    """A Langevin shaft driven by coloured noise: uniform grid, columns omega and fuel_rate."""
    from scipy.signal import lfilter

    rng = np.random.default_rng(seed)
    force = lfilter([1], [1, -1.2728, 0.81], rng.normal(size=n)) * 0.2 / 3.4
    omega = np.zeros(n)
    phi = np.exp(-gamma * dt)
    gain = (1 - phi) / gamma
    for t in range(1, n):
        omega[t] = phi * omega[t - 1] + gain * force[t]
    # nanosecond index: graybox.residual.infer_sample_interval reads asi8 as nanoseconds
    index = pd.date_range(DAY0 + pd.Timedelta(days=day), periods=n, freq="10s",
                          name="timestamp").as_unit("ns")
    return pd.DataFrame({"omega": omega + 1000 + noise * rng.normal(size=n),
                         "fuel_rate": np.ones(n)}, index=index)


@dataclass(frozen=True)
class LangevinFits:
    """A calibrated baseline of days 0-3, and the candidate of day 5 with its drift.

    Attributes
    ----------
    model : graybox.models.LangevinShaft
    days : list of DataFrame
        Days 0-3 (:func:`make_day` with seeds 0-3).
    night : DataFrame
        Day 5 (seed 5).
    baseline : graybox.signature.Signature
    calibration : graybox.calibration.Calibration
    candidate : graybox.signature.Signature
        The night's fit with the baseline's frozen structure.
    drift : graybox.drift.Drift
        The candidate against the baseline.
    """

    model: LangevinShaft
    days: list[pd.DataFrame]
    night: pd.DataFrame
    baseline: Signature
    calibration: Calibration
    candidate: Signature
    drift: Drift


def fit_langevin() -> LangevinFits:
    """Fit the baseline, the candidate and its drift (see :class:`LangevinFits`)."""
    from graybox.drift import compute_drift
    from graybox.estimator import GrayBox
    from graybox.models import LangevinShaft

    model = LangevinShaft()
    days = [make_day(d, seed=d) for d in range(4)]
    baseline = GrayBox(model).fit(days)
    night = make_day(5, seed=5)
    candidate = GrayBox(model, baseline=baseline.signature_).fit(night)
    drift = compute_drift(candidate.signature_, baseline.signature_, baseline.calibration_)
    return LangevinFits(model, days, night, baseline.signature_, baseline.calibration_,
                        candidate.signature_, drift)
