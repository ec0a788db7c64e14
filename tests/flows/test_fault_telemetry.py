"""Issue 13, the fault matrix: bad telemetry of every kind, at the flow level.

Each scenario breaks one Parquet file of one asset (T-002, its second night) and runs the
nightly command over two nights. The bad asset fails, named with error kind, file and row
(in the JSON and on stderr); its watermark stops before the bad night, whose first night is
committed; every other asset is committed exactly as in a clean run. A stuck or impossible
reading is a sensor's fault: the bad night also gets a ``sensor`` alert of its channel, in
the result and the alerts file. Restoring the file and rerunning gives exactly the state of
one uninterrupted clean run: no window is lost or recorded twice, and the alerts file holds
each alert once (and the sensor alert of the broken night, which stays as history).
"""
from __future__ import annotations

import json
import shutil
import types

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from flowtest_config import write_config
from flowtest_store import committed_state, count_records
from flowtest_fleet import ASSETS, BASELINE_DAYS, day

BAD_ASSET = "T-002"
BAD_DAY = BASELINE_DAYS + 1           # the second night: the first is committed before it
AS_OF = day(BASELINE_DAYS + 2).isoformat()
NIGHTS = 2




def _alert_lines(path) -> list[tuple]:
    lines = [json.loads(x) for x in path.read_text().splitlines() if x.strip()]
    return sorted((a["asset_id"], a["window_start"], a["channel"], a["tier"]) for a in lines)


def _run(capsys, config) -> tuple[int, dict, str]:
    from flows.cli import main

    status = main(["--config", str(config), "run", "--as-of", AS_OF, "--json"])
    captured = capsys.readouterr()
    return status, json.loads(captured.out), captured.err


@pytest.fixture(scope="module")
def clean(tmp_path_factory, harness, baselined, fleet, count):
    """The reference: the same two nights run once, uninterrupted, on clean telemetry."""
    from flows.nightly import nightly
    from registry import Registry

    directory = tmp_path_factory.mktemp("clean")
    shutil.copy(baselined.db, directory / "mlflow.db")
    config = write_config(directory / "fleet.toml", fleet.root, directory / "mlflow.db")
    state = nightly(config_path=str(config), as_of=AS_OF, return_state=True)
    assert state.is_completed(), state.message
    registry = Registry(f"sqlite:///{directory / 'mlflow.db'}")
    alerts = _alert_lines(directory / "alerts.jsonl")
    assert {a[0] for a in alerts} == {"T-002", "T-004"}     # the reference has alerts to lose
    return types.SimpleNamespace(state=committed_state(registry), counts=count(registry),
                                 alerts=alerts)


@pytest.fixture(scope="module")
def count():
    """``count(registry)``: active runs, model versions and registry alerts of a store."""
    return count_records


# -- the breakages: each rewrites one file and returns (kind, row or None) -----------------

def _rewrite(path, change):
    frame = pq.read_table(path).to_pandas()
    frame = change(frame)
    pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), path)


def _set(row, column, value):
    def change(frame):
        frame.loc[row, column] = value
        return frame
    return change


def _nan(path):
    _rewrite(path, _set(100, "shaft_speed", float("nan")))


def _plus_inf(path):
    _rewrite(path, _set(101, "shaft_speed", float("inf")))
    return "non_finite", 101


def _minus_inf(path):
    _rewrite(path, _set(102, "fuel_rate", float("-inf")))
    return "non_finite", 102


def _null(path):
    def change(frame):
        frame["shaft_speed"] = frame["shaft_speed"].astype(object)
        frame.loc[103, "shaft_speed"] = None
        return frame
    _rewrite(path, change)


def _backward(path):
    def change(frame):
        frame.loc[200, "timestamp"] = frame.loc[199, "timestamp"] - pd.Timedelta(seconds=5)
        return frame
    _rewrite(path, change)
    return "backward_timestamp", 200


def _duplicate(path):
    def change(frame):
        frame.loc[200, "timestamp"] = frame.loc[199, "timestamp"]
        return frame
    _rewrite(path, change)
    return "duplicate_timestamp", 200


def _stuck(path):
    # the speed holds one value for 40 samples (20 min), stuck_after is 10 min
    def change(frame):
        frame.loc[300:339, "shaft_speed"] = frame.loc[300, "shaft_speed"]
        return frame
    _rewrite(path, change)
    return "stuck_channel", 300


def _dead_sensor(path):
    # the speed sensor gives no reading all night, the other channels do
    _rewrite(path, _set(slice(None), "shaft_speed", float("nan")))
    return "silent_channel", 0


def _missing_column(path):
    _rewrite(path, lambda frame: frame.drop(columns=["fuel_rate"]))
    return "schema", None


def _strings(path):
    def change(frame):
        frame["shaft_speed"] = frame["shaft_speed"].map(lambda v: f"{v:.3f}")
        return frame
    _rewrite(path, change)
    return "schema", None


def _out_of_range(path):
    _rewrite(path, _set(500, "shaft_speed", 1e10))
    return "out_of_range", 500


def _truncated(path):
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])
    return "unreadable", None


def _zero_bytes(path):
    path.write_bytes(b"")
    return "unreadable", None


def _not_parquet(path):
    path.write_text("timestamp,shaft_speed,fuel_rate\n2026-01-05T00:00:00Z,1000,1\n")
    return "unreadable", None


BREAKAGES = {"plus_inf": _plus_inf, "minus_inf": _minus_inf,
             "backward_timestamp": _backward, "duplicate_timestamp": _duplicate,
             "stuck_sensor": _stuck, "dead_sensor": _dead_sensor, "missing_column": _missing_column,
             "strings_in_numeric_column": _strings, "out_of_range": _out_of_range,
             "truncated_file": _truncated, "zero_byte_file": _zero_bytes,
             "not_parquet": _not_parquet}


def test_a_logger_outage_is_read_in_two_parts_and_said(workspace, fleet, clean, capsys):
    """Rows missing for longer than max_gap (20 samples of 30 s, 10 minutes; max_gap is 4):
    not bad telemetry, a logger's outage. The night is analysed in its two parts, committed
    as in a clean run, and the asset's result says that it was read in parts; a sensor that
    goes silent for the night's last 40 minutes leaves those rows out, also said."""
    root = workspace.path / "telemetry"
    shutil.copytree(fleet.root, root)

    def change(frame):
        frame.loc[2800:, "shaft_speed"] = float("nan")
        return frame.drop(index=range(300, 320)).reset_index(drop=True)
    _rewrite(root / f"asset_id={BAD_ASSET}/date={day(BAD_DAY):%Y-%m-%d}/part-0.parquet", change)
    workspace.configure(telemetry=root)
    status, summary, err = _run(capsys, workspace.config)
    assert status == 0, err
    assert summary["coverage"]["complete"]
    bad = {a["asset_id"]: a for a in summary["assets"]}[BAD_ASSET]
    assert bad["status"] == "ok"
    assert [w["window_start"] for w in bad["windows"]] == [
        day(BAD_DAY - 1).isoformat(), day(BAD_DAY).isoformat()]
    assert (f"read 1 window(s) in parts, split where rows were missing for longer than the "
            f"grid's max_gap: {day(BAD_DAY).isoformat()} (1 gap)") in bad["note"]
    assert (f"left out rows where a channel had no reading (longer than the grid's max_gap, "
            f"or a running channel's): {day(BAD_DAY).isoformat()} 'shaft_speed' 40min"
            ) in bad["note"]
    state = committed_state(workspace.registry())
    assert state["watermarks"] == clean.state["watermarks"]
    assert state["baselines"] == clean.state["baselines"]


def test_rows_sent_twice_are_left_out_and_said(workspace, fleet, clean, count, capsys):
    """A gateway that reconnects sends its last 50 rows again (times go back, the readings
    are the same): nothing new, and not bad telemetry. The night is the clean run's (its
    records, alerts and watermark), and the asset's result says how many rows were left
    out."""
    root = workspace.path / "telemetry"
    shutil.copytree(fleet.root, root)

    def change(frame):
        return pd.concat([frame.iloc[:1050], frame.iloc[1000:1050], frame.iloc[1050:]],
                         ignore_index=True)
    _rewrite(root / f"asset_id={BAD_ASSET}/date={day(BAD_DAY):%Y-%m-%d}/part-0.parquet", change)
    workspace.configure(telemetry=root)
    status, summary, err = _run(capsys, workspace.config)
    assert status == 0, err
    bad = {a["asset_id"]: a for a in summary["assets"]}[BAD_ASSET]
    assert bad["status"] == "ok"
    assert (f"left out rows sent twice (the timestamp and readings of a row before them): "
            f"{day(BAD_DAY).isoformat()} (50 rows)") in bad["note"]
    registry = workspace.registry()
    state = committed_state(registry)
    assert state["watermarks"] == clean.state["watermarks"]
    assert state["baselines"] == clean.state["baselines"]
    assert count(registry) == clean.counts
    assert _alert_lines(workspace.alerts) == clean.alerts


@pytest.mark.parametrize("miss", [_nan, _null])
def test_a_missed_reading_is_interpolated_and_the_night_analysed(miss, workspace, fleet, clean,
                                                                 count, capsys):
    """A NaN or a null (a missed reading) is not bad telemetry: it is interpolated in time
    like a missing row, and the night is analysed and committed as in a clean run."""
    root = workspace.path / "telemetry"
    shutil.copytree(fleet.root, root)
    miss(root / f"asset_id={BAD_ASSET}/date={day(BAD_DAY):%Y-%m-%d}/part-0.parquet")
    workspace.configure(telemetry=root)
    status, summary, err = _run(capsys, workspace.config)
    assert status == 0, err
    assert summary["coverage"]["complete"]
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    assert [w["window_start"] for w in by_asset[BAD_ASSET]["windows"]] == [
        day(BAD_DAY - 1).isoformat(), day(BAD_DAY).isoformat()]
    registry = workspace.registry()
    state = committed_state(registry)
    assert state["watermarks"] == clean.state["watermarks"]
    assert state["baselines"] == clean.state["baselines"]
    assert count(registry)["runs"] == clean.counts["runs"]


@pytest.mark.parametrize("how", list(BREAKAGES))
def test_fault_bad_telemetry(how, workspace, fleet, clean, count, capsys):
    root = workspace.path / "telemetry"
    shutil.copytree(fleet.root, root)
    relative = (f"asset_id={BAD_ASSET}/date={day(BAD_DAY):%Y-%m-%d}/part-0.parquet")
    bad_file = root / relative
    kind, row = BREAKAGES[how](bad_file)
    workspace.configure(telemetry=root)

    status, summary, err = _run(capsys, workspace.config)
    assert status == 1, err
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    bad = by_asset[BAD_ASSET]
    assert bad["status"] == "failed"
    error = bad["error"]
    assert (error["kind"], error["file"], error["row"]) == (kind, str(bad_file), row), error
    assert error["window_start"] == day(BAD_DAY).isoformat()
    assert [w["window_start"] for w in bad["windows"]] == [day(BAD_DAY - 1).isoformat()]
    assert f"fleet-health: {BAD_ASSET} failed: asset '{BAD_ASSET}', file {bad_file}" in err
    assert f"[{kind}]" in err
    if row is not None:
        assert f"row {row}:" in err
    assert summary["coverage"]["missed"] == [BAD_ASSET]
    assert summary["coverage"]["failed"] == 1 and summary["exit_status"] == 1
    sensor = ([(BAD_ASSET, day(BAD_DAY).isoformat(), "shaft_speed", kind)]
              if kind in ("stuck_channel", "out_of_range", "silent_channel") else [])
    assert [(a["asset_id"], a["window_start"], a["channel"], a["tier"])
            for a in bad["alerts"] if a["kind"] == "sensor"] == sensor
    assert all(a["kind"] != "sensor" for r in summary["assets"] for a in r["alerts"]
               if r["asset_id"] != BAD_ASSET)

    registry = workspace.registry()
    state = committed_state(registry)
    expected = clean.state
    # the bad asset stops before the bad night; its first night is committed
    assert state["watermarks"] == {**expected["watermarks"], BAD_ASSET: day(BAD_DAY)}
    assert state["baselines"] == expected["baselines"]
    kept = [a for a in expected["alerts"]
            if a[0] != BAD_ASSET or a[1] < day(BAD_DAY).isoformat()]
    assert state["alerts"] == kept
    assert count(registry) == {"runs": clean.counts["runs"] - 1,
                               "versions": clean.counts["versions"] - 1,
                               "alerts": len(kept)}
    exported = _alert_lines(workspace.alerts)
    assert exported == sorted([(a, w, c, t) for a, w, c, t in clean.alerts
                               if a != BAD_ASSET or w < day(BAD_DAY).isoformat()] + sensor)
    status, summary, err = _run(capsys, workspace.config)   # still broken: said once
    assert status == 1 and _alert_lines(workspace.alerts) == exported

    shutil.copy(fleet.root / relative, bad_file)          # the file is fixed
    status, summary, err = _run(capsys, workspace.config)
    assert status == 0, err
    assert summary["coverage"]["complete"]
    windows = {a["asset_id"]: [w["window_start"] for w in a["windows"]]
               for a in summary["assets"]}
    assert windows == {**{a: [] for a in ASSETS}, BAD_ASSET: [day(BAD_DAY).isoformat()]}
    registry = workspace.registry()
    assert committed_state(registry) == expected
    assert count(registry) == clean.counts
    assert _alert_lines(workspace.alerts) == sorted(clean.alerts + sensor)


@pytest.mark.slow
def test_fault_bad_telemetry_in_baseline_days_leaves_the_baseline_untouched(
        workspace, fleet, count, capsys):
    """``baseline fit --all --promote`` over days 1-4 with T-002's second day truncated: T-002
    fails naming the file, keeps its promoted baseline and gets no new version; the other
    four get their new baseline; no watermark moves. With the file restored, the same
    command fits T-002 once and finds the others' fits already recorded."""
    from flows.cli import main

    root = workspace.path / "telemetry"
    shutil.copytree(fleet.root, root)
    relative = f"asset_id={BAD_ASSET}/date={day(1):%Y-%m-%d}/part-0.parquet"
    kind, _ = _truncated(root / relative)
    workspace.configure(telemetry=root)
    registry = workspace.registry()
    old = {a: registry.baseline(a).version for a in ASSETS}
    history = {a: len(registry.history(a)) for a in ASSETS}
    counts = count(registry)
    argv = ["--config", str(workspace.config), "baseline", "fit", "--all", "--start",
            day(0).isoformat(), "--end", day(BASELINE_DAYS + 1).isoformat(), "--promote",
            "--reason", "refit on days 1-4", "--json"]

    status = main(argv)
    captured = capsys.readouterr()
    assert status == 1, captured.err
    by_asset = {a["asset_id"]: a for a in json.loads(captured.out)["assets"]}
    assert by_asset[BAD_ASSET]["status"] == "failed"
    error = by_asset[BAD_ASSET]["error"]
    assert (error["kind"], error["file"]) == (kind, str(root / relative))
    assert f"fleet-health: {BAD_ASSET} failed: asset '{BAD_ASSET}', file {root / relative}" \
        in captured.err
    registry = workspace.registry()
    assert registry.baseline(BAD_ASSET).version == old[BAD_ASSET]
    assert len(registry.history(BAD_ASSET)) == history[BAD_ASSET]
    fitted = {}
    for asset in set(ASSETS) - {BAD_ASSET}:
        assert by_asset[asset]["status"] == "ok"
        baseline = registry.baseline(asset)
        assert baseline.version != old[asset] and baseline.calibration is not None
        assert (baseline.info.window_start, baseline.info.window_end) == (
            day(0).isoformat(), day(BASELINE_DAYS + 1).isoformat())
        assert len(registry.history(asset)) == history[asset] + 1
        fitted[asset] = baseline.version
    assert {registry.watermark(a) for a in ASSETS} == {None}
    assert count(registry)["versions"] == counts["versions"] + len(ASSETS) - 1

    shutil.copy(fleet.root / relative, root / relative)
    status = main(argv)
    captured = capsys.readouterr()
    assert status == 0, captured.err
    registry = workspace.registry()
    assert count(registry)["versions"] == counts["versions"] + len(ASSETS)
    assert {a: registry.baseline(a).version for a in fitted} == fitted
    assert registry.baseline(BAD_ASSET).version != old[BAD_ASSET]
    assert {registry.watermark(a) for a in ASSETS} == {None}


def test_fault_day_without_rows_is_said_and_analysed_once_its_rows_arrive(
        workspace, fleet, clean, count, capsys):
    """T-002's second night is a valid Parquet file without rows (an export that wrote
    nothing): the night is skipped, but the asset's note names it (never silently), its
    watermark does not pass it, and the others are committed as in a clean run. When the
    rows arrive, the rerun analyses it: the state of one uninterrupted clean run."""
    root = workspace.path / "telemetry"
    shutil.copytree(fleet.root, root)
    relative = f"asset_id={BAD_ASSET}/date={day(BAD_DAY):%Y-%m-%d}/part-0.parquet"
    _rewrite(root / relative, lambda frame: frame.iloc[0:0])
    workspace.configure(telemetry=root)

    status, summary, err = _run(capsys, workspace.config)
    assert status == 0, err
    bad = {a["asset_id"]: a for a in summary["assets"]}[BAD_ASSET]
    assert bad["status"] == "ok"
    assert [w["window_start"] for w in bad["windows"]] == [day(BAD_DAY - 1).isoformat()]
    assert (f"skipped 1 window(s) whose telemetry has no rows: {day(BAD_DAY).isoformat()}"
            in bad["note"])
    registry = workspace.registry()
    state = committed_state(registry)
    assert state["watermarks"] == {**clean.state["watermarks"], BAD_ASSET: day(BAD_DAY)}
    assert state["baselines"] == clean.state["baselines"]
    assert count(registry)["versions"] == clean.counts["versions"] - 1

    shutil.copy(fleet.root / relative, root / relative)       # the rows arrive
    status, summary, err = _run(capsys, workspace.config)
    assert status == 0, err
    registry = workspace.registry()
    assert committed_state(registry) == clean.state
    assert count(registry) == clean.counts
    assert _alert_lines(workspace.alerts) == clean.alerts
