"""benchmarks.detection: the detectors' known answers, their calibration, the metrics, and a
reduced grid end to end (two vehicles, one seed, 30-second samples).

(Named ``test_detection_benchmark.py``: ``tests/graybox/test_detection.py`` exists and pytest's
default import mode needs distinct basenames.)
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from benchmarks.detection import classic, metrics
from benchmarks.detection.__main__ import grid_from_args, parse_args
from benchmarks.detection.grid import Grid, simulate_seed
from benchmarks.detection.report import headline, load_results, summarize, write_report
from benchmarks.detection.run import run_grid

SETTINGS = classic.ClassicSettings()


# ------------------------------------------------------------------------------------------
# detectors: known answers
# ------------------------------------------------------------------------------------------
def test_cusum_noise_free_step_alarms_at_the_expected_sample():
    # a step of 2 with k = 0.5 adds 1.5 per sample: 1.5, 3.0, 4.5 > h = 4 on the third
    x = np.concatenate([np.zeros(50), np.full(20, 2.0)])
    assert classic.cusum_first_alarm(x, k=0.5, h=4.0) == 52
    assert classic.cusum_first_alarm(-x, k=0.5, h=4.0) == 52      # two-sided
    assert classic.cusum_first_alarm(np.zeros(100), 0.5, 4.0) == -1
    assert classic.cusum_max(x, 0.5)[0] == pytest.approx(20 * 1.5)


def test_cusum_delay_for_a_one_sigma_step_matches_the_classic_table():
    """Page CUSUM with k = 0.5, h = 5 on N(0, 1) data: ARL for a 1-sigma shift is about 10.4
    samples (Montgomery, Introduction to SQC, Table 9.3), i.e. a mean delay of about 9.4 after
    the step sample; and it rarely alarms before the step (in-control ARL ~ 465 one-sided)."""
    rng = np.random.default_rng(0)
    delays, early = [], 0
    for _ in range(400):
        x = rng.standard_normal(200)
        x[100:] += 1.0
        alarm = classic.cusum_first_alarm(x, k=0.5, h=5.0)
        if 0 <= alarm < 100:
            early += 1
            continue
        delays.append(alarm - 100)
    assert 8.0 < np.mean(delays) < 11.5
    assert early / 400 < 0.5


def test_glr_of_a_known_change_point_is_half_a_chi_square_with_two_dof():
    rng = np.random.default_rng(1)
    u, v = rng.standard_normal((2, 5000, 40))
    # only the whole window is a candidate change point: (S_u^2 + S_v^2) / (2 n) ~ chi2(2) / 2
    values = classic.glr_max(u, v, min_batches=40)
    assert values.mean() == pytest.approx(1.0, rel=0.05)
    assert np.mean(values > stats.chi2.ppf(0.99, 2) / 2) == pytest.approx(0.01, abs=0.005)
    # a shift after batch 20 is found, and the maximum is taken at the change point
    shifted = u[:1].copy()
    shifted[0, 20:] += 3.0
    assert classic.glr_max(shifted, np.zeros_like(shifted), 5)[0] > 30


def _gaussian_days(rng, n, k):
    return [rng.standard_normal(n) for _ in range(k)]


def test_redline_and_cusum_calibration_meet_the_target_on_gaussian_nights():
    """Known answer: on white Gaussian residuals the per-asset thresholds from 4 baseline days
    give close to 1 % false alarms on fresh nights (the estimation error is part of them)."""
    rng = np.random.default_rng(2)
    n, dt = 2879, 30.0        # one day at 30 s (the one-step residual drops one sample)
    alarms = {d: 0 for d in classic.DETECTORS}
    nights = 0
    for asset in range(15):
        cal = classic.calibrate(_gaussian_days(rng, n, 4), dt, SETTINGS, 0.01, seed=asset)
        for _ in range(40):
            values = classic.night_statistics(rng.standard_normal(n), cal, dt, SETTINGS)
            for d in classic.DETECTORS:
                alarms[d] += values[d] > cal.thresholds[d]
            nights += 1
    rates = {d: alarms[d] / nights for d in classic.DETECTORS}
    assert 0.0015 <= rates["redline"] <= 0.025, rates
    assert rates["cusum_mean"] <= 0.025, rates
    assert max(rates.values()) <= 0.03, rates


def test_redline_threshold_is_above_the_gaussian_exceedance_fraction():
    rng = np.random.default_rng(3)
    cal = classic.calibrate(_gaussian_days(rng, 8639, 4), 10.0, SETTINGS, 0.01)
    expected = 2 * stats.norm.sf(3.0)       # 0.27 % of samples beyond 3 sigma
    assert expected < cal.thresholds["redline"] < 3 * expected
    assert set(cal.thresholds) == set(classic.DETECTORS)
    with pytest.raises(ValueError, match="at least 3"):
        classic.calibrate(_gaussian_days(rng, 100, 2), 10.0)


def test_series_model_keeps_a_real_profile_and_drops_noise():
    rng = np.random.default_rng(4)
    t = np.linspace(0, 2 * np.pi, 288)
    profile = 3 * np.sin(t)
    with_profile = np.stack([profile + rng.standard_normal(288) for _ in range(4)])
    noise_only = np.stack([rng.standard_normal(288) for _ in range(4)])
    kept = classic.fit_series_model(with_profile)
    dropped = classic.fit_series_model(noise_only)
    assert kept.shrinkage > 0.9 and dropped.shrinkage < 0.5
    assert np.corrcoef(kept.profile, profile)[0, 1] > 0.95   # a 4-day mean: noise sd 0.5
    # an AR(1) is recovered from pooled days
    ar = np.stack([np.asarray(pd.Series(rng.standard_normal(2000)).ewm(alpha=0.3).mean())
                   for _ in range(4)])
    coefficients, _ = classic.fit_ar(ar - ar.mean(), 5)
    assert coefficients[0] == pytest.approx(0.7, abs=0.05)


# ------------------------------------------------------------------------------------------
# metrics
# ------------------------------------------------------------------------------------------
def test_auc_known_answers():
    rng = np.random.default_rng(5)
    same = metrics.auc(rng.standard_normal(4000), rng.standard_normal(4000))
    assert same == pytest.approx(0.5, abs=0.02)
    assert metrics.auc(np.array([0.0, 1.0]), np.array([2.0, 3.0])) == 1.0
    assert metrics.auc(np.array([2.0, 3.0]), np.array([0.0, 1.0])) == 0.0
    assert metrics.auc(np.ones(5), np.ones(7)) == 0.5                       # ties count half
    # Mann-Whitney: AUC = U / (n1 n2)
    a, b = rng.standard_normal(50), rng.standard_normal(60) + 0.5
    u = stats.mannwhitneyu(b, a).statistic
    assert metrics.auc(a, b) == pytest.approx(u / (50 * 60))
    assert np.isnan(metrics.auc(np.array([]), np.array([1.0])))


def test_matched_level_and_clopper_pearson():
    healthy = np.arange(1, 201, dtype=float)          # 200 nights: at most 2 may exceed
    level = metrics.matched_level(healthy, 0.01)
    assert level == 198.0 and (healthy > level).sum() == 2
    low, high = metrics.clopper_pearson(0, 18)
    assert low == 0.0 and high == pytest.approx(0.1853, abs=1e-4)
    low, high = metrics.clopper_pearson(5, 500)
    assert low < 0.01 < high


# ------------------------------------------------------------------------------------------
# reduced grid end to end
# ------------------------------------------------------------------------------------------
# large faults at 30-s samples: there the random moment integrated over a sample dominates the
# one-step residual, so the sensor-noise fault is x4 (a doubled noise is below what it shows)
REDUCED = Grid(magnitudes={"friction": (0.5,), "nonlinear": (0.3,), "noise": (3.0,), "bias": (5.0,)},
               model_errors=(0.0,), seeds=(1,), vehicles=2, baseline_days=3, pre_nights=1,
               post_nights=2, sample_interval=30.0)


@pytest.fixture(scope="module")
def reduced():
    table, info = run_grid(REDUCED, workers=1, progress=None)
    run = {"command": "python -m benchmarks.detection (test)", "date": "today", "commit": "test",
           "workers": 1, "threads": 1, "cpus": 2, "load_note": "test", "versions": "",
           "timings": info["timings"], "structures": info["structures"],
           "wall_seconds": info["wall_seconds"]}
    return table, summarize(table, REDUCED, run)


def test_faulty_assets_share_their_twin_telemetry_before_onset():
    vehicles = simulate_seed(REDUCED, 1)
    assert len(vehicles) == 2
    v = vehicles[0]
    assert len(v.healthy) == REDUCED.days
    assert set(v.faulty) == set(REDUCED.scenarios())
    for frames in v.faulty.values():
        assert len(frames) == REDUCED.post_nights
        assert frames[0].index[0] == v.healthy[REDUCED.onset_day].index[0]


def test_reduced_grid_rows_and_columns(reduced):
    table, _ = reduced
    nights_per_vehicle = (REDUCED.days - REDUCED.baseline_days
                          + len(REDUCED.scenarios()) * REDUCED.post_nights)
    assert len(table) == REDUCED.vehicles * nights_per_vehicle * len(REDUCED.model_errors)
    for d in classic.DETECTORS:
        assert table[f"{d}_stat"].notna().all() and (table[f"{d}_thr"] >= 0).all()
    for tier in metrics.TIERS:
        assert table[f"gb_{tier}_zeta"].notna().all() and (table[f"gb_{tier}_eps"] > 0).all()
    healthy = table[table.kind == "healthy"]
    assert sorted(healthy.night.unique()) == list(range(REDUCED.baseline_days, REDUCED.days))
    faulty = table[table.kind != "healthy"]
    assert (faulty.night >= REDUCED.onset_day).all() and faulty.faulty.all()


def test_reduced_grid_metrics_structure_and_large_faults_detected(reduced):
    _, results = reduced
    d = results.detection
    expected = len(metrics.ALL_DETECTORS) * len(REDUCED.model_errors) * len(REDUCED.scenarios())
    assert len(d) == expected
    assert (d.assets == REDUCED.vehicles).all()
    assert d.rate.between(0, 1).all() and d.auc.dropna().between(0, 1).all()
    assert d.median_delay.dropna().between(0, REDUCED.post_nights - 1).all()
    fa = results.false_alarms
    assert len(fa) == len(metrics.ALL_DETECTORS) * len(REDUCED.model_errors)
    assert (fa.nights == REDUCED.vehicles * (REDUCED.days - REDUCED.baseline_days)).all()
    # large faults: the gray box sees (a)-(c), the mean CUSUM sees a 5 rad/s bias
    gray = d[d.detector == metrics.GRAYBOX].set_index("kind")
    assert (gray.loc[["friction", "nonlinear", "noise"], "rate"] == 1.0).all()
    assert d[(d.detector == "cusum_mean") & (d.kind == "bias")].rate.iloc[0] == 1.0
    head = headline(results)
    assert set(head.kind) == {"friction", "nonlinear", "noise"} and "met" in head


def test_report_files(reduced, tmp_path):
    _, results = reduced
    out = tmp_path / "bench.md"
    written = write_report(results, out, discussion="## Discussion\n\nhand-written text\n")
    text = out.read_text()
    for needle in ("## Headline", "## Realized false-alarm rates", "gray box (any tier)",
                   "hand-written text", "Reproduce with", "bench/detection_rate.png"):
        assert needle in text
    for path in written:
        assert path.exists() and path.stat().st_size > 0
    png = tmp_path / "bench" / "detection_rate.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    raw = pd.read_csv(tmp_path / "bench" / "detection_nights.csv")
    assert len(raw) == len(results.table) and "gb_noise_zeta" in raw
    # the saved raw results and run record re-render the same metrics
    again = load_results(tmp_path / "bench")
    pd.testing.assert_frame_equal(again.detection, results.detection, check_exact=False)
    pd.testing.assert_frame_equal(again.false_alarms, results.false_alarms, check_exact=False)
    assert again.grid == results.grid
    # a record written before the grid had candidate_nights ran the night alone
    record = tmp_path / "bench" / "detection_run.json"
    data = json.loads(record.read_text())
    del data["grid"]["candidate_nights"]
    record.write_text(json.dumps(data))
    assert load_results(tmp_path / "bench").grid.candidate_nights == 1


def test_command_line_grid():
    quick = grid_from_args(parse_args(["--quick"]))
    assert quick.seeds == (1,) and quick.vehicles == 2 and quick.model_errors == (0.0, 0.1, 0.2)
    full = grid_from_args(parse_args(["--seeds", "3", "--magnitudes", "noise=0.2,0.4"]))
    assert full.seeds == (1, 2, 3) and full.magnitudes["noise"] == (0.2, 0.4)
    assert full.magnitudes["friction"] == Grid().magnitudes["friction"]


def test_the_side_runs_read_the_grid_defaults_and_the_product_candidate_nights():
    from benchmarks.detection import rates, subset
    from flows.config.settings import NightlySettings

    defaults = Grid()
    assert defaults.candidate_nights == NightlySettings().candidate_nights
    assert grid_from_args(parse_args([])).candidate_nights == defaults.candidate_nights
    args = rates.parse_args([])
    assert (args.seeds, args.vehicles) == (len(defaults.seeds), defaults.vehicles)
    # the published sampling-interval section fitted each candidate on its night alone
    assert rates.base_grid(args).candidate_nights == rates.CANDIDATE_NIGHTS == 1
    assert rates.REFERENCE == defaults.sample_interval
    args = subset.parse_args(["--model-errors", "0,0.2,"])
    assert args.model_errors == (0.0, 0.2) and args.vehicles == defaults.vehicles
    assert subset.parse_args([]).model_errors == defaults.model_errors


# ------------------------------------------------------------------------------------------
# the sampling-interval axis
# ------------------------------------------------------------------------------------------
def test_rate_grid_at_two_intervals_and_its_section(tmp_path):
    from benchmarks.detection import rates

    base = Grid(magnitudes={"friction": (0.5,), "noise": (1.0,)}, model_errors=(0.0,), seeds=(1,),
                vehicles=2, baseline_days=3, pre_nights=1, post_nights=2)
    intervals = (10.0, 60.0)
    table, info = rates.run_rates(base, intervals, workers=1, progress=None)
    nights_per_vehicle = base.days - base.baseline_days + len(base.scenarios()) * base.post_nights
    assert len(table) == len(intervals) * base.vehicles * nights_per_vehicle
    assert sorted(table.sample_interval.unique()) == list(intervals)
    assert [p["sample_interval"] for p in info["per_interval"]] == list(intervals)
    detection, false_alarms = rates.summarize_rates(table, base)
    assert len(detection) == len(intervals) * len(metrics.ALL_DETECTORS) * len(base.scenarios())
    assert (false_alarms.nights == base.vehicles * (base.days - base.baseline_days)).all()
    goals = rates.goal(detection, false_alarms)
    assert len(goals) == len(intervals) * len(base.scenarios())
    assert (goals[goals.sample_interval == 10.0].gap == 0).all()
    noise = rates.noise_share(intervals, vehicles=1, days=1)
    assert list(noise.sample_interval) == list(intervals)
    assert noise.native_share.between(0, 1).all()
    run = {"command": "test", "date": "today", "commit": "test", "workers": 1, "threads": 1,
           "load_note": "test", "wall_seconds": 1.0, **info}
    rates.save(tmp_path / "bench", table, detection, false_alarms, noise, base, intervals, run)
    text = rates.section(tmp_path / "bench")
    assert text.startswith("## Detection per sampling interval")
    for needle in ("| 10 s |", "| 60 s |", "false alarms per healthy asset-night",
                   "(c) sensor-noise change 1", "Gray-box baselines per interval"):
        assert needle in text
    assert rates.section(tmp_path / "missing") is None
