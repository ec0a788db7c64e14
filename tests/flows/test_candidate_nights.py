"""``[nightly] candidate_nights``: each night's candidate fitted on the trailing N nights.

A small fleet of its own (6 vehicles, seed 11, 30-s samples, 5 days; baselines of days
1-3, nights 4-5; only T-001 .. T-003 are fitted): T-003's sensor noise grows by x2.5
(noise 1.5) from day 4. Chosen by a probe of several fault sizes through the nightly batch
with ``candidate_nights`` 1 and 2 (this test repeats it): one-night windows give T-003 the worst ratios 0.87 and 0.84
(no alarm on either night); the two-night window of days 4-5 gives 1.36 (an alarm); the
healthy assets' two-night windows stay below 0.4.
"""
from __future__ import annotations

import json
import shutil
import sqlite3
from types import SimpleNamespace

import pandas as pd
import pytest

from flowtest_config import write_config
from flowtest_fleet import day
from flows.results import run_summary

FITTED = ["T-001", "T-002", "T-003"]
FAULTY = "T-003"
BASELINE_DAYS, DAYS = 3, 5


@pytest.fixture(scope="module")
def small(tmp_path_factory, harness):
    """The fleet's telemetry and a store with promoted baselines of T-001 .. T-003."""
    from flows.baseline import baseline
    from flows.demo import simulated_fleet, write_simulation
    from graybox.simulation import Fault

    directory = tmp_path_factory.mktemp("candidate-nights")
    root = directory / "telemetry"
    # the probed fleet exactly (its other faults keep the vehicles' draws as probed)
    faults = [("T-003", Fault("noise", 3.0, 1.5)), ("T-004", Fault("noise", 3.0, 2.5)),
              ("T-005", Fault("nonlinear", 3.0, 0.08)), ("T-006", Fault("noise", 3.0, 1.75))]
    write_simulation(simulated_fleet(6, DAYS, seed=11, sample_interval=30.0, faults=faults),
                     root)
    db = directory / "mlflow.db"
    config = write_config(directory / "fleet.toml", root, db)
    state = baseline(start=day(0).isoformat(), end=day(BASELINE_DAYS).isoformat(),
                     config_path=str(config), assets=FITTED, promote=True,
                     reason="healthy days 1-3", return_state=True)
    assert state.is_completed(), state.message
    connection = sqlite3.connect(db)
    connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    connection.close()
    return SimpleNamespace(root=root, db=db)


def _store(tmp_path, small, name: str, nights: int):
    """A fresh copy of the baselined store and a fleet.toml with ``candidate_nights``."""
    directory = tmp_path / name
    directory.mkdir()
    shutil.copy(small.db, directory / "mlflow.db")
    config = write_config(directory / "fleet.toml", small.root, directory / "mlflow.db",
                          candidate_nights=nights)
    from registry import Registry

    return SimpleNamespace(config=config, alerts=directory / "alerts.jsonl",
                           registry=Registry(f"sqlite:///{directory / 'mlflow.db'}"))


def _nightly(store, as_of):
    from flows.nightly import nightly

    state = nightly(config_path=str(store.config), as_of=as_of.isoformat(), assets=FITTED,
                    return_state=True)
    summary = run_summary(state)
    assert state.is_completed(), state.message
    return {a["asset_id"]: a for a in summary["assets"]}, summary


def _windows(asset):
    return [(pd.Timestamp(w["window_start"]), pd.Timestamp(w["window_end"]), w["alarm"])
            for w in asset["windows"]]


def _lines(path):
    return path.read_text().splitlines() if path.exists() else []


@pytest.mark.slow
def test_two_night_windows_catch_what_one_night_misses_and_reruns_add_nothing(
        tmp_path, small, count):
    # one night per candidate (today's behaviour): T-003's fault is missed on both nights
    one = _store(tmp_path, small, "one", 1)
    assets, summary = _nightly(one, day(DAYS))
    for asset in FITTED:
        assert _windows(assets[asset]) == [(day(3), day(4), False), (day(4), day(5), False)]
    assert not summary["alerts"]
    t003 = [w["max_ratio"] for w in assets[FAULTY]["windows"]]
    assert all(0.6 < r < 1 for r in t003), t003           # close, but below epsilon

    # two nights: the first candidate after the baseline has only its night (never reaches
    # into the baseline's window); the watermark advances one night per night
    two = _store(tmp_path, small, "two", 2)
    assets, _ = _nightly(two, day(DAYS - 1))
    for asset in FITTED:
        assert _windows(assets[asset]) == [(day(3), day(4), False)]
        assert two.registry.watermark(asset) == day(4)
    assets, summary = _nightly(two, day(DAYS))
    for asset in ("T-001", "T-002"):                        # healthy two-night windows
        assert _windows(assets[asset]) == [(day(3), day(5), False)]
        assert assets[asset]["windows"][0]["max_ratio"] < 0.6
    assert _windows(assets[FAULTY]) == [(day(3), day(5), True)]
    assert assets[FAULTY]["windows"][0]["max_ratio"] > 1.15
    for asset in FITTED:
        assert two.registry.watermark(asset) == day(5)
    # the alerts are keyed by the whole span, in the summary, the registry and the file
    alerts = summary["alerts"]
    assert alerts and {(a["asset_id"], a["window_start"], a["window_end"]) for a in alerts} \
        == {(FAULTY, day(3).isoformat(), day(5).isoformat())}
    assert {(r.asset_id, r.window_start, r.window_end) for r in two.registry.alerts()} == \
        {(FAULTY, day(3).isoformat(), day(5).isoformat())}
    lines = _lines(two.alerts)
    assert len(lines) == len(alerts)
    assert {json.loads(line)["window_start"] for line in lines} == {day(3).isoformat()}
    # the candidate's epsilon is the calibrated one lowered for twice the samples
    history = two.registry.zeta_history(FAULTY)
    spans = {(pd.Timestamp(s), pd.Timestamp(e)) for s, e in zip(history["window_start"],
                                                                history["window_end"])}
    assert spans == {(day(3), day(4)), (day(3), day(5))}
    # the fleet heat map draws a span on its last night
    from flows.fleet_view import collect_view

    view = collect_view(two.registry, f"{day(4):%Y-%m-%d}", 2)
    assert view.nights == (f"{day(3):%Y-%m-%d}", f"{day(4):%Y-%m-%d}")
    row = {r.asset_id: r for r in view.rows}[FAULTY]
    assert row.ratios[0] < 1 < row.ratios[1]

    # a rerun, and a rerun from an earlier as-of: nothing new anywhere
    before = count(two.registry)
    for as_of in (day(DAYS), day(DAYS) + pd.Timedelta(hours=6)):
        assets, summary = _nightly(two, as_of)
        assert {a["status"] for a in assets.values()} == {"up to date"}
        assert count(two.registry) == before
        assert _lines(two.alerts) == lines


@pytest.mark.slow
def test_reanalysis_takes_the_same_option_and_is_idempotent(tmp_path, small, count, capsys):
    from flows.cli import main

    store = _store(tmp_path, small, "re", 1)
    argv = ["--config", str(store.config), "reanalyze", "--asset", "T-001", "--asset",
            FAULTY, "--start", day(4).isoformat(), "--end", day(5).isoformat(),
            "--candidate-nights", "2", "--json"]
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["extra"]["candidate_nights"] == 2
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    assert _windows(by_asset["T-001"]) == [(day(3), day(5), False)]
    assert _windows(by_asset[FAULTY]) == [(day(3), day(5), True)]
    before = count(store.registry)
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert all(not w["created"] for a in again["assets"] for w in a["windows"])
    assert count(store.registry) == before
    # the configured default (1) without the option: the night alone, no alarm
    assert main(argv[:-3] + ["--json"]) == 0
    alone = {a["asset_id"]: a for a in json.loads(capsys.readouterr().out)["assets"]}
    assert _windows(alone[FAULTY]) == [(day(4), day(5), False)]


def test_bad_candidate_nights_are_refused_naming_the_key_or_option(tmp_path, capsys):
    from flows.cli import main
    from flows.config import ConfigError, load_config

    minimal = ('[classes.turbine]\nmodel = "graybox.models:GasTurbineShaft"\n'
               'assets = ["T-*"]\ncolumns = { omega = "shaft_speed" }\n')
    path = tmp_path / "fleet.toml"
    path.write_text(minimal)
    assert load_config(path).nightly.candidate_nights == 2
    path.write_text("[nightly]\ncandidate_nights = 3\n" + minimal)
    assert load_config(path).nightly.candidate_nights == 3
    for bad in ("0", "-1", '"2"', "1.5", "true"):
        path.write_text(f"[nightly]\ncandidate_nights = {bad}\n" + minimal)
        with pytest.raises(ConfigError, match=r"fleet.toml: nightly.candidate_nights: must be "
                                              r"an integer >= 1"):
            load_config(path)
    path.write_text(minimal)
    assert main(["--config", str(path), "reanalyze", "--asset", "T-001", "--start",
                 "2026-01-01", "--end", "2026-01-02", "--candidate-nights", "0"]) == 2
    assert "--candidate-nights: must be an integer >= 1, got '0'" in capsys.readouterr().err


def test_trailing_nights_known_answers():
    from flows.discovery import trailing_nights

    night = pd.Timedelta(days=1)
    assert trailing_nights(day(4), day(5), 1, night) == [(day(4), day(5))]
    assert trailing_nights(day(4), day(5), 3, night) == [(day(2), day(3)), (day(3), day(4)),
                                                        (day(4), day(5))]
    # never before the reference's window end; a night before it is fitted alone
    assert trailing_nights(day(4), day(5), 3, night, earliest=day(3)) == [(day(3), day(4)),
                                                                         (day(4), day(5))]
    assert trailing_nights(day(1), day(2), 3, night, earliest=day(3)) == [(day(1), day(2))]
    # 12-hour windows: the trailing windows are 12 hours each
    half = pd.Timedelta(hours=12)
    assert trailing_nights(day(4), day(4) + half, 2, half) == [(day(3) + half, day(4)),
                                                               (day(4), day(4) + half)]
    with pytest.raises(ValueError, match="nights must be >= 1"):
        trailing_nights(day(4), day(5), 0, night)
