"""Shared fixtures of the registry tests: one baseline and one candidate fitted per session,
and a fresh SQLite store per test (copied from a template whose schema was created once)."""
from __future__ import annotations

import dataclasses
import shutil
import sqlite3
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

from graybox.drift import compute_drift
from graybox.estimator import GrayBox
from graybox.models import LangevinShaft

N_SAMPLES = 2000
DAY0 = pd.Timestamp("2026-01-01", tz="UTC")


def make_day(day: int, seed: int, gamma: float = 0.06, noise: float = 0.3, n: int = N_SAMPLES,
             dt: float = 10.0) -> pd.DataFrame:
    """A Langevin shaft driven by coloured noise: uniform grid, columns omega and fuel_rate."""
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


@pytest.fixture(scope="session")
def fits():
    """A calibrated baseline (4 days), a candidate night, its drift, and an alarmed drift."""
    model = LangevinShaft()
    days = [make_day(d, seed=d) for d in range(4)]
    baseline = GrayBox(model).fit(days)
    night = make_day(5, seed=5)
    candidate = GrayBox(model, baseline=baseline.signature_).fit(night)
    drift = compute_drift(candidate.signature_, baseline.signature_, baseline.calibration_)
    tight = dataclasses.replace(baseline.calibration_, thresholds=tuple(
        dataclasses.replace(t, epsilon=t.epsilon * 1e-6) for t in baseline.calibration_.thresholds))
    alarmed = compute_drift(candidate.signature_, baseline.signature_, tight)
    assert alarmed.alarmed
    return SimpleNamespace(model=model, days=days, night=night,
                           baseline=baseline.signature_, calibration=baseline.calibration_,
                           candidate=candidate.signature_, drift=drift, alarmed=alarmed)


@pytest.fixture(scope="session")
def template_db(tmp_path_factory):
    """An empty SQLite store with MLflow's schema (created once: it takes seconds)."""
    from registry import Registry

    directory = tmp_path_factory.mktemp("template-store")
    Registry(f"sqlite:///{directory}/mlflow.db")
    connection = sqlite3.connect(directory / "mlflow.db")
    connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    connection.close()
    return directory / "mlflow.db"


@pytest.fixture
def store_uri(tmp_path, template_db):
    """A fresh store for one test."""
    target = tmp_path / "store" / "mlflow.db"
    target.parent.mkdir()
    shutil.copy(template_db, target)
    return f"sqlite:///{target}"


@pytest.fixture
def registry(store_uri):
    from registry import Registry

    return Registry(store_uri, user="tester")


class Recorder:
    """Records the session's fits as distinct windows (each a new version)."""

    def __init__(self, registry, fits):
        self.registry, self.fits = registry, fits

    def baseline(self, asset_id: str = "T-01", shift_days: int = 0, plots: bool = False, **kwargs):
        """The session's baseline, as if fitted on a window ``shift_days`` later."""
        start = DAY0 + pd.Timedelta(days=shift_days)
        return self.registry.record_fit(
            asset_id, "turbine", self.fits.baseline, role="baseline",
            calibration=self.fits.calibration, window_start=start,
            window_end=start + pd.Timedelta(days=4), data_hash=f"baseline-data-{shift_days}",
            plots=plots, **kwargs)

    def candidate(self, asset_id: str = "T-01", night: int = 5, alarmed: bool = False,
                  plots: bool = False, **kwargs):
        """The session's candidate as the fit of night ``night``."""
        start = DAY0 + pd.Timedelta(days=night)
        return self.registry.record_fit(
            asset_id, "turbine", self.fits.candidate, role="candidate",
            drift=self.fits.alarmed if alarmed else self.fits.drift, window_start=start,
            window_end=start + pd.Timedelta(days=1), data_hash=f"night-{night}", plots=plots,
            **kwargs)


@pytest.fixture
def rec(registry, fits):
    return Recorder(registry, fits)
