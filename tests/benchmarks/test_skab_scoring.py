"""The SKAB benchmark's window labels, scores and comparison detectors on known answers (no
SKAB data needed)."""
from __future__ import annotations

import pathlib

import numpy as np
import pandas as pd
import pytest

from benchmarks.skab.detectors import CHANNELS, PcaModel, WindowDetector
from benchmarks.skab.protocol import (Experiment, baseline_plan, window_labels,
                                      with_foreign_labels)
from benchmarks.skab.run import conditioned, fleet_config
from flows.config import load_config
from benchmarks.skab.scoring import (ExperimentScore, PointCounts, point_counts,
                                     score_experiment, summarise)

WINDOW = pd.Timedelta("5min")


def _rows(start: str, seconds: int, onset: int | None = None, stop: int | None = None,
          rng=None) -> pd.DataFrame:
    """1-s rows from ``start``; anomaly labelled in ``[onset, stop)`` seconds."""
    rng = rng or np.random.default_rng(0)
    times = pd.date_range(start, periods=seconds, freq="1s", tz="UTC")
    anomaly = np.zeros(seconds)
    if onset is not None:
        anomaly[onset:stop] = 1
    frame = pd.DataFrame({"timestamp": times})
    for channel in CHANNELS:
        frame[channel] = 10 + rng.normal(0, 1, seconds)
    frame["anomaly"], frame["changepoint"] = anomaly, 0.0
    return frame


def _experiment(name, rows, session="valve1") -> Experiment:
    return Experiment(name, pathlib.Path(f"{name}.csv"), session, rows)


def test_windows_are_fault_healthy_or_after_by_their_rows():
    # 12:02:30 to 12:22:30, anomaly from 12:12:30 to 12:18:00
    rows = _rows("2020-03-09 12:02:30", 1200, onset=600, stop=930)
    labels = window_labels(_experiment("valve1/1", rows), WINDOW)
    assert labels.index[0] == pd.Timestamp("2020-03-09 12:00", tz="UTC")
    assert list(labels) == ["healthy", "healthy", "fault", "fault", "after"]


def test_rows_another_file_labels_anomalous_are_neither_healthy_nor_the_experiments_fault():
    # the first file's fault (12:05 to 12:15) overlaps the second file's first 10 minutes,
    # which that file labels normal (SKAB's other/12 and other/13)
    earlier = _experiment("other/12", _rows("2020-02-08 11:55:00", 1200, onset=600))
    later = _experiment("other/13", _rows("2020-02-08 12:05:00", 1200, onset=900))
    earlier, later = with_foreign_labels([earlier, later])
    assert later.foreign().sum() == 600 and not earlier.foreign().any()
    labels = window_labels(later, WINDOW)
    assert list(labels) == ["overlap", "overlap", "healthy", "fault"]
    # its prefix stops before the other file's fault: no baseline gets those rows
    assert len(later.prefix()) == 0 and len(earlier.prefix()) == 600


def test_a_session_baseline_takes_only_earlier_whole_healthy_windows():
    first = _experiment("valve1/0", _rows("2020-03-09 07:00:00", 1200, onset=900))
    second = _experiment("valve1/1", _rows("2020-03-09 07:20:00", 1200, onset=900))
    third = _experiment("valve1/2", _rows("2020-03-09 07:40:00", 1200, onset=900))
    later = _experiment("valve1/3", _rows("2020-03-09 08:00:00", 1200, onset=900))
    every = [first, second, third, later]
    plan = baseline_plan(later, every, None, WINDOW, pd.Timedelta("4min"))
    # each earlier prefix is 15 minutes: three whole windows each, nothing of ``later``
    assert plan.sources == ("valve1/0 prefix", "valve1/1 prefix", "valve1/2 prefix")
    assert plan.start == pd.Timestamp("2020-03-09 07:00", tz="UTC")
    assert plan.end == pd.Timestamp("2020-03-09 07:55", tz="UTC")
    assert not plan_rows_after(plan, later.start)
    assert not baseline_plan(first, every, None, WINDOW, pd.Timedelta("4min")).usable


def test_a_recent_baseline_takes_the_latest_whole_healthy_windows_only():
    every = [_experiment(f"valve1/{k}", _rows(f"2020-03-09 07:{20 * k:02d}:00", 1200, onset=900))
             for k in range(3)] + [_experiment("valve1/3", _rows("2020-03-09 08:00:00", 1200,
                                                                 onset=900))]
    later = every[-1]
    plan = baseline_plan(later, every, None, WINDOW, pd.Timedelta("4min"), recent=4)
    # the latest four of the nine earlier whole windows: valve1/2's three (07:40 to 07:55)
    # and valve1/1's last (07:30); valve1/0 is left out
    assert plan.sources == ("valve1/1 prefix", "valve1/2 prefix")
    assert plan.start == pd.Timestamp("2020-03-09 07:30", tz="UTC")
    assert plan.end == pd.Timestamp("2020-03-09 07:55", tz="UTC")
    starts = {t for part in plan.parts for t in part["timestamp"].dt.floor(WINDOW)}
    assert sorted(starts) == [pd.Timestamp(f"2020-03-09 07:{m}", tz="UTC")
                              for m in ("30", "40", "45", "50")]
    # fewer windows than asked: every one is kept
    assert baseline_plan(later, every, None, WINDOW, pd.Timedelta("4min"),
                         recent=50).start == pd.Timestamp("2020-03-09 07:00", tz="UTC")


def test_a_first_experiment_may_take_the_earliest_later_windows_when_asked():
    every = [_experiment(f"valve1/{k}", _rows(f"2020-03-09 07:{20 * k:02d}:00", 1200, onset=900))
             for k in range(3)]
    first = every[0]
    assert not baseline_plan(first, every, None, WINDOW, pd.Timedelta("4min")).usable
    plan = baseline_plan(first, every, None, WINDOW, pd.Timedelta("4min"), recent=4, later=True)
    # valve1/1's three prefix windows (07:20 to 07:35) and valve1/2's first (07:40)
    assert plan.usable and plan.later
    assert plan.sources == ("valve1/1 prefix", "valve1/2 prefix")
    assert (plan.start, plan.end) == (pd.Timestamp("2020-03-09 07:20", tz="UTC"),
                                      pd.Timestamp("2020-03-09 07:45", tz="UTC"))
    assert all((part["timestamp"] >= first.end).all() for part in plan.parts)
    # an experiment with enough earlier windows keeps them
    assert not baseline_plan(every[2], every, None, WINDOW, pd.Timedelta("4min"), recent=4,
                             later=True).later


def plan_rows_after(plan, moment) -> bool:
    return any((part["timestamp"] >= moment).any() for part in plan.parts)


def test_an_experiment_is_detected_by_a_fault_window_and_falsely_alarmed_by_a_healthy_one():
    start = pd.Timestamp("2020-03-09 12:00", tz="UTC")
    index = pd.date_range(start, periods=4, freq=WINDOW)
    labels = pd.Series(["healthy", "healthy", "fault", "fault"], index=index, dtype=object)
    onset = start + pd.Timedelta("11min")
    late = score_experiment("e", labels, pd.Series([False, True, False, True], index=index),
                            onset)
    assert late.detected and late.false_alarm
    # the first alarmed fault window ends at 12:20, 9 minutes after the onset
    assert late.delay_s == 540
    # a window not analysed counts neither way
    missing = score_experiment("e", labels, pd.Series([False], index=index[:1]), onset)
    assert not missing.detected and not missing.false_alarm and missing.fault_windows == 0


def test_point_scores_mark_every_row_of_an_alarmed_window():
    rows = _rows("2020-03-09 12:00:00", 600, onset=450)
    alarms = pd.Series({pd.Timestamp("2020-03-09 12:05", tz="UTC"): True,
                        pd.Timestamp("2020-03-09 12:00", tz="UTC"): False})
    counts = point_counts(rows["timestamp"], rows["anomaly"].to_numpy(), alarms, WINDOW)
    # 300 rows predicted anomalous, 150 of them labelled so; 300 normal, all labelled so
    assert counts == PointCounts(tp=150, fp=150, tn=300, fn=0)
    assert counts.f1 == pytest.approx(2 * 150 / (300 + 150))
    assert counts.far == pytest.approx(150 / 450) and counts.mar == 0


def test_pca_keeps_the_axes_of_the_variance_and_its_t2_averages_their_number():
    rng = np.random.default_rng(5)
    n = 5000
    hidden = rng.normal(0, 1, (n, 2))
    x = hidden @ rng.normal(0, 1, (2, len(CHANNELS))) + rng.normal(0, 1e-3, (n, len(CHANNELS)))
    model = PcaModel.fit(x)
    assert model.axes.shape == (2, len(CHANNELS))
    t2, q = model.scores(x).T
    # in sample, the mean T2 is exactly k (n - 1) / n; Q is the 1e-3 noise left over
    assert t2.mean() == pytest.approx(2 * (n - 1) / n, rel=1e-9)
    assert q.mean() < 1e-3


@pytest.mark.parametrize("name", ["pca_t2q", "iforest"])
def test_detectors_alarm_on_a_window_whose_flow_leaves_its_relation(name):
    rng = np.random.default_rng(3)

    def plant(start, seconds):
        rows = _rows(start, seconds, rng=rng)
        rows["flow"] = 10 + 0.8 * rows["current"] + rng.normal(0, 0.3, seconds)
        return rows

    detector = WindowDetector.fit(name, plant("2020-02-08 10:00", 3600), WINDOW)
    test = plant("2020-02-08 12:00", 900)
    test.loc[600:, "flow"] += 4          # the last window's flow leaves its relation
    assert detector.windows(test, WINDOW)["alarm"].iloc[-1]


def test_inputs_are_averaged_causally_over_a_minute():
    rows = _rows("2020-02-08 10:00", 180)
    rows["current"] = np.r_[np.zeros(60), np.ones(120)]
    averaged = conditioned(rows)
    assert averaged["current"].iloc[59] == 0
    assert averaged["current"].iloc[89] == pytest.approx(30 / 60)
    assert averaged["current"].iloc[119] == 1


def test_the_benchmark_fleet_is_a_configuration_the_product_accepts(tmp_path):
    path = tmp_path / "fleet.toml"
    path.write_text(fleet_config(["other-5", "valve1-4"]))
    config = load_config(path)
    assert config.nightly.window_delta == pd.Timedelta("5min")
    skab = config.classes["skab_pump"]
    assert skab.grid.min_duration == 240
    assert "vibration_1_level" in skab.estimate


def test_a_detector_is_summarised_over_the_experiments_it_analysed():
    analysed = ExperimentScore("a", True, False, 60.0, 1, 2, 1)
    unanalysed = ExperimentScore("b", False, False, None, 0, 0, 0)
    summary = summarise("d", [analysed, unanalysed], PointCounts())
    assert (summary.experiments, summary.detected, summary.median_delay_s) == (1, 1, 60.0)
