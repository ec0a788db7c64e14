"""Moving the working directory (fleet.toml + mlflow.db + mlartifacts) keeps every baseline."""
from __future__ import annotations

import shutil

import pytest

from flowtest_config import write_config
from flowtest_fleet import BASELINE_DAYS, day


@pytest.mark.slow
def test_moved_directory_runs_the_night(tmp_path, harness, fleet):
    from flows.baseline import baseline
    from flows.nightly import nightly
    from registry import Registry

    site = tmp_path / "site"
    site.mkdir()
    # relative store path: the moved fleet.toml finds the moved database
    config = write_config(site / "fleet.toml", fleet.root, "mlflow.db")
    state = baseline(start=day(0).isoformat(), end=day(BASELINE_DAYS).isoformat(),
                     config_path=str(config), assets=["T-002"], promote=True,
                     reason="healthy days 1-3", return_state=True)
    assert state.is_completed(), state.message
    assert (site / "mlartifacts").is_dir() and (site / "mlflow.db").is_file()

    moved = tmp_path / "elsewhere" / "site"
    moved.parent.mkdir()
    shutil.move(site, moved)
    assert not site.exists()

    state = nightly(config_path=str(moved / "fleet.toml"),
                    as_of=day(BASELINE_DAYS + 1).isoformat(), assets=["T-002"],
                    return_state=True)
    assert state.is_completed(), state.message
    summary = state.result()
    (asset,) = summary["assets"]
    assert asset["status"] == "ok" and asset["baseline_version"] == 1
    assert len(asset["windows"]) == 1 and asset["windows"][0]["version"] == 2
    assert summary["alerts"] and {a["asset_id"] for a in summary["alerts"]} == {"T-002"}
    registry = Registry(f"sqlite:///{moved / 'mlflow.db'}")
    assert registry.watermark("T-002") == day(BASELINE_DAYS + 1)
    assert registry.load_version("T-002", 2).version == 2
    assert registry.alerts() and (moved / "alerts.jsonl").exists()
    assert not site.exists()                           # nothing was written at the old path
