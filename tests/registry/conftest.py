"""Shared fixtures of the registry tests: one baseline and one candidate fitted per session,
and a fresh SQLite store per test (copied from a template whose schema was created once)."""
from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import pandas as pd
import pytest
from store_copies import checkpointed, copy_store

from benchmarks.langevin_fits import DAY0, fit_langevin
from graybox.drift import compute_drift


@pytest.fixture(scope="session")
def fits():
    """A calibrated baseline (4 days), a candidate night, its drift, and an alarmed drift."""
    shared = fit_langevin()
    tight = dataclasses.replace(shared.calibration, thresholds=tuple(
        dataclasses.replace(t, epsilon=t.epsilon * 1e-6) for t in shared.calibration.thresholds))
    alarmed = compute_drift(shared.candidate, shared.baseline, tight)
    assert alarmed.alarmed
    return SimpleNamespace(**vars(shared), alarmed=alarmed)


@pytest.fixture(scope="session")
def template_db(tmp_path_factory):
    """An empty SQLite store with MLflow's schema (created once: it takes seconds)."""
    from registry import Registry

    directory = tmp_path_factory.mktemp("template-store")
    Registry(f"sqlite:///{directory}/mlflow.db")
    return checkpointed(directory / "mlflow.db")


@pytest.fixture
def store_uri(tmp_path, template_db):
    """A fresh store for one test."""
    return copy_store(template_db, tmp_path / "store")


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
