"""A moved embedded store (mlflow.db + mlartifacts) keeps loading and recording."""
from __future__ import annotations

import pathlib
import shutil

import pandas as pd

from registry.store.tracking_store import resolve_store

DAY0 = pd.Timestamp("2026-01-01", tz="UTC")


def test_artifact_uris_are_rebased_only_when_their_root_is_gone(tmp_path):
    store = resolve_store(f"sqlite:///{tmp_path}/new/mlflow.db")
    own = (tmp_path / "new" / "mlartifacts").as_uri()
    gone = (tmp_path / "old" / "mlartifacts").as_uri() + "/fleet-health_turbine-1a2b3c4d/r1/artifacts"
    assert store.local_artifact_uri(gone) == own + "/fleet-health_turbine-1a2b3c4d/r1/artifacts"
    (tmp_path / "old" / "mlartifacts").mkdir(parents=True)     # the original still exists
    assert store.local_artifact_uri(gone) == gone
    for other in (own + "/x", "s3://bucket/mlartifacts/x", "file:///elsewhere/runs/x",
                  "models:/m-123"):
        assert store.local_artifact_uri(other) == other


def test_moved_store_loads_baselines_reads_alerts_and_records(tmp_path, fits):
    from registry import Registry

    old = tmp_path / "site" / "store"
    registry = Registry(f"sqlite:///{old}/mlflow.db", user="tester")
    first = registry.record_fit("T-01", "turbine", fits.baseline, role="baseline",
                                calibration=fits.calibration, window_start=DAY0,
                                window_end=DAY0 + pd.Timedelta(days=4), data_hash="b", plots=False)
    registry.promote("T-01", first.version, reason="healthy")
    night = DAY0 + pd.Timedelta(days=5)
    registry.record_fit("T-01", "turbine", fits.candidate, role="candidate", drift=fits.alarmed,
                        window_start=night, window_end=night + pd.Timedelta(days=1),
                        data_hash="n1", plots=False)
    alerts_before = registry.alerts()
    assert alerts_before
    del registry

    shutil.move(tmp_path / "site", tmp_path / "moved")
    new = tmp_path / "moved" / "store"
    assert not old.exists()

    moved = Registry(f"sqlite:///{new}/mlflow.db", user="tester")
    loaded = moved.baseline("T-01")
    assert loaded.version == first.version and loaded.signature == fits.baseline
    assert moved.alerts() == alerts_before
    later = night + pd.Timedelta(days=1)
    record = moved.record_fit("T-01", "turbine", fits.candidate, role="candidate",
                              drift=fits.alarmed, window_start=later,
                              window_end=later + pd.Timedelta(days=1), data_hash="n2", plots=False)
    assert record.created and record.version == 3
    assert moved.load_version("T-01", 3).signature == fits.candidate
    assert len(moved.alerts()) == 2 * len(alerts_before)
    assert not old.exists() and not pathlib.Path(tmp_path / "site").exists()   # nothing written there
