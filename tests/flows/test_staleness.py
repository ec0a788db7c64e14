"""Issue 13, item 2: an asset whose telemetry stopped arriving is reported stale, with an
alert, instead of "up to date" forever; and a future --as-of is refused."""
from __future__ import annotations

import json
import shutil

import pandas as pd
import pyarrow.parquet as pq
import pytest

from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, day
from flows.results import run_summary


def _jsonl(path):
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _newest(root, asset, day_index):
    table = pq.read_table(root / f"asset_id={asset}" / f"date={day(day_index):%Y-%m-%d}")
    return pd.Timestamp(table.column("timestamp").to_pandas().max()).tz_convert("UTC")


def _set_alerts_key(config, line: str):
    text = config.read_text().replace("[alerts]\n", f"[alerts]\n{line}\n", 1)
    config.write_text(text)


def test_fault_stale_asset_gets_status_and_one_alert(workspace, fleet, tmp_path, capsys):
    """T-005's last two days never arrived: as of the end of day 6 its newest sample is more
    than 2 days old. It is 'stale' (exit 1) with one stale alert naming its last data time
    and age, its one night is committed; the others are untouched."""
    from flows.cli import main

    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)
    for i in (DAYS - 2, DAYS - 1):
        shutil.rmtree(root / "asset_id=T-005" / f"date={day(i):%Y-%m-%d}")
    workspace.configure(telemetry=root)
    last = _newest(root, "T-005", DAYS - 3)

    status = main(["--config", str(workspace.config), "run", "--as-of", day(DAYS).isoformat(),
                   "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert status == 1 and summary["exit_status"] == 1
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    stale = by_asset["T-005"]
    assert stale["status"] == "stale"
    assert len(stale["windows"]) == 1                      # its one night is committed
    assert workspace.registry().watermark("T-005") == day(BASELINE_DAYS + 1)
    stale_alerts = [a for a in summary["alerts"] if a["kind"] == "stale"]
    assert len(stale_alerts) == 1
    alert = stale_alerts[0]
    assert alert["asset_id"] == "T-005" and alert["tier"] == "stale"
    assert pd.Timestamp(alert["window_start"]) == last == pd.Timestamp(alert["window_end"])
    assert alert["zeta"] == pytest.approx((day(DAYS) - last) / pd.Timedelta(days=1))
    assert alert["epsilon"] == 2.0 and alert["ratio"] > 1
    assert summary["counts"]["stale"] == 1
    for asset in set(ASSETS) - {"T-005"}:
        assert by_asset[asset]["status"] == "ok"
        assert len(by_asset[asset]["windows"]) == DAYS - BASELINE_DAYS
        assert workspace.registry().watermark(asset) == day(DAYS)
        assert not [a for a in by_asset[asset]["alerts"] if a["kind"] == "stale"]
    lines = _jsonl(workspace.alerts)
    assert [x["asset_id"] for x in lines if x.get("kind") == "stale"] == ["T-005"]

    # an hour later, still nothing new: stale again, and no second alert line
    status = main(["--config", str(workspace.config), "run", "--as-of",
                   (day(DAYS) + pd.Timedelta(hours=1)).isoformat(), "--json"])
    again = json.loads(capsys.readouterr().out)
    assert status == 1
    by_asset = {a["asset_id"]: a for a in again["assets"]}
    assert by_asset["T-005"]["status"] == "stale"
    assert "stale: no telemetry since" in by_asset["T-005"]["note"]
    assert {by_asset[a]["status"] for a in set(ASSETS) - {"T-005"}} == {"up to date"}
    assert len(_jsonl(workspace.alerts)) == len(lines)


def test_fault_run_months_after_the_last_data_is_not_up_to_date(workspace):
    """Ten months after the fleet's last data: every asset stale, none 'up to date'; with
    stale_after = "off" (explicitly) the old behaviour is back."""
    from flows.nightly import nightly

    as_of = day(DAYS) + pd.Timedelta(days=300)
    state = nightly(config_path=str(workspace.config), as_of=as_of.isoformat(),
                    return_state=True)
    summary = run_summary(state)
    assert summary["exit_status"] == 1
    assert {a["status"] for a in summary["assets"]} == {"stale"}
    assert sorted(a["asset_id"] for a in summary["alerts"] if a["kind"] == "stale") == \
        sorted(ASSETS)

    _set_alerts_key(workspace.config, 'stale_after = "off"')
    state = nightly(config_path=str(workspace.config), as_of=as_of.isoformat(),
                    return_state=True)
    summary = run_summary(state)
    assert summary["exit_status"] == 0
    assert {a["status"] for a in summary["assets"]} == {"up to date"}
    assert not summary["alerts"]


def test_fault_a_deployment_run_that_leaves_assets_unmonitored_fails_with_their_summary(
        workspace):
    """The way Prefect's engine runs a deployment (``fleet-health serve``, a worker): it
    demands the flow's result, and a Failed state's data is raised. It is the run's own error,
    named after what happened and carrying the summary; it was a TypeError of Prefect's
    ("Unexpected result for failed state") while the data was the summary dict."""
    import pickle

    from prefect.flow_engine import run_flow

    from flows.errors import AssetsNotMonitored
    from flows.nightly import nightly

    as_of = day(DAYS) + pd.Timedelta(days=300)
    with pytest.raises(AssetsNotMonitored, match="not monitored") as raised:
        run_flow(nightly, parameters={"config_path": str(workspace.config),
                                      "as_of": as_of.isoformat()})
    summary = raised.value.summary
    assert summary["exit_status"] == 1
    assert {a["status"] for a in summary["assets"]} == {"stale"}
    # a result store may persist it: it pickles with its summary
    again = pickle.loads(pickle.dumps(raised.value))
    assert str(again) == str(raised.value) and again.summary == summary


@pytest.mark.parametrize("value, message", [
    ('"2"', "not a duration"), ('"soon"', "not a duration"), ('"0D"', "positive duration"),
    ('"-1D"', "positive duration")])
def test_fault_bad_stale_after_is_a_config_error(tmp_path, value, message):
    from flows.config import ConfigError, load_config
    from flowtest_config import write_config

    config = write_config(tmp_path / "fleet.toml", tmp_path, tmp_path / "m.db")
    _set_alerts_key(config, f"stale_after = {value}")
    with pytest.raises(ConfigError, match=f"alerts.stale_after.*{message}"):
        load_config(config)


def test_stale_after_defaults_and_off(tmp_path):
    from flows.config import load_config
    from flowtest_config import write_config

    config = write_config(tmp_path / "fleet.toml", tmp_path, tmp_path / "m.db")
    assert load_config(config).alerts.stale_after_delta == pd.Timedelta(days=2)
    _set_alerts_key(config, 'stale_after = "off"')
    assert load_config(config).alerts.stale_after_delta is None


@pytest.mark.parametrize("argv", [
    ["run", "--as-of", "2030-01-01"],
    ["reanalyze", "--asset", "T-001", "--start", "2030-01-01", "--end", "2030-01-02"]])
def test_fault_future_as_of_is_a_usage_error(tmp_path, capsys, argv):
    from flows.cli import main
    from flowtest_config import write_config

    (tmp_path / "telemetry").mkdir()
    config = write_config(tmp_path / "fleet.toml", tmp_path / "telemetry", tmp_path / "m.db")
    assert main(["--config", str(config), *argv]) == 2
    err = capsys.readouterr().err
    assert "2030-01-01" in err and "in the future" in err
    assert not (tmp_path / "m.db").exists()           # refused before anything ran


def test_as_of_within_clock_skew_is_accepted():
    from flows.discovery import not_in_future
    from flows.errors import UsageError

    now = pd.Timestamp("2026-03-01T12:00", tz="UTC")
    assert not_in_future(now + pd.Timedelta(minutes=4), "--as-of", now=now) == \
        now + pd.Timedelta(minutes=4)
    with pytest.raises(UsageError, match="in the future"):
        not_in_future(now + pd.Timedelta(minutes=6), "--as-of", now=now)


def test_fault_reanalysis_of_a_range_without_data_says_so(workspace, capsys):
    """A range with no telemetry: 0 windows, and a note saying so, not a bare 'ok'."""
    from flows.cli import main

    status = main(["--config", str(workspace.config), "reanalyze", "--asset", "T-001",
                   "--start", "2025-06-01", "--end", "2025-06-03", "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert status == 0
    (asset,) = summary["assets"]
    assert asset["windows"] == []
    assert asset["note"] == "0 windows: no telemetry in [2025-06-01 00:00, 2025-06-03 00:00) UTC"
