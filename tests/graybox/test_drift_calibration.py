import dataclasses
import json
import pathlib

import numpy as np
import pytest
from conftest import make_channel, make_signature
from scipy import stats

from graybox.calibration import Calibration, TierThreshold, threshold_from_deltas
from graybox.drift import Drift, TierDrift, compute_drift, tier_deltas
from graybox.exceptions import ArtifactError, InsufficientDataError, StructureMismatchError
from graybox.noise_tier import MOMENT_WEIGHTS


def test_nonlinear_zeta_is_exactly_eq28():
    w0, W0 = np.array([[0.1, 0.2, 0.3], [-0.1, 0.0, 0.5]]), np.array([0.3, -0.4])
    w1, W1 = w0 + np.array([[0.01, 0, 0], [0, -0.02, 0]]), W0 + np.array([0.05, 0.0])
    base = make_signature((make_channel(w=w0, W=W0),))
    cand = make_signature((make_channel(w=w1, W=W1, selection=False),))
    drift = compute_drift(cand, base)
    expected = np.sum((W1 - W0) ** 2) + np.sum((w1 - w0) ** 2)
    assert drift.get("omega", "nonlinear").zeta == pytest.approx(expected, rel=1e-12)
    assert drift.get("omega", "linear").zeta == 0.0
    top = drift.get("omega", "nonlinear").top_changes[0]
    assert top.name == "W1_1" and top.contribution == pytest.approx(0.05 ** 2)


def test_linear_and_noise_zeta():
    base = make_signature((make_channel(a=(0.5, -0.2), moments=(0.0, 2.0, 0.0, 0.0)),))
    cand = make_signature((make_channel(a=(0.6, -0.2), moments=(0.1, 3.0, 0.2, 1.2)),))
    drift = compute_drift(cand, base)
    assert drift.get("omega", "linear").zeta == pytest.approx(0.01)
    expected = (MOMENT_WEIGHTS[0] * (0.1 / np.sqrt(2.0)) ** 2 + MOMENT_WEIGHTS[1] * 0.5 ** 2
                + MOMENT_WEIGHTS[2] * 0.2 ** 2 + MOMENT_WEIGHTS[3] * 1.2 ** 2)
    assert drift.get("omega", "noise").zeta == pytest.approx(expected)
    names, delta = tier_deltas(cand.channels[0], base.channels[0], "noise")
    assert names[1] == "variance" and delta[1] == pytest.approx(0.5 * np.sqrt(0.5))


def test_noise_zeta_weighs_each_moment_by_its_baselines_sampling_variance():
    base = make_signature((make_channel(moments=(0.0, 2.0, 0.5, 20.0)),))
    noise = dataclasses.replace(base.channels[0].noise, moment_variances=(1.0, 9.0, 40.0, 4000.0))
    heavy = dataclasses.replace(base, channels=(dataclasses.replace(base.channels[0],
                                                                    noise=noise),))
    cand = make_signature((make_channel(moments=(0.1, 3.0, 1.0, 60.0)),))
    expected = ((0.1 / np.sqrt(2.0)) ** 2 + 0.5 ** 2 / 9.0 + 0.5 ** 2 / 40.0 + 40.0 ** 2 / 4000.0)
    assert compute_drift(cand, heavy).get("omega", "noise").zeta == pytest.approx(expected)
    # the same changes against a baseline stored without them: a Gaussian's weights
    gaussian = ((0.1 / np.sqrt(2.0)) ** 2 + 0.5 ** 2 / 2 + 0.5 ** 2 / 6 + 40.0 ** 2 / 24)
    assert compute_drift(cand, base).get("omega", "noise").zeta == pytest.approx(gaussian)


def test_alarm_only_when_zeta_exceeds_epsilon_and_epsilon_scales_with_window():
    base = make_signature((make_channel(a=(0.5,)),))
    cand = make_signature((make_channel(a=(0.6,), n_samples=500),))
    thresholds = tuple(TierThreshold("omega", tier, eps, eps / 5, 2.0, (0.1, 0.2, 0.3))
                       for tier, eps in (("linear", 0.009), ("nonlinear", 1.0), ("noise", 1.0)))
    calibration = Calibration(thresholds, 0.01, 0.01 / 3, 1000, 12)
    # the candidate has half the reference samples: epsilon doubles, 0.018 > zeta 0.01
    drift = compute_drift(cand, base, calibration)
    entry = drift.get("omega", "linear")
    assert entry.epsilon == pytest.approx(0.018) and not entry.exceeded and not drift.alarmed
    full = make_signature((make_channel(a=(0.6,), n_samples=1000),))
    drift = compute_drift(full, base, calibration)
    assert drift.get("omega", "linear").exceeded and drift.alarms[0].tier == "linear"
    assert drift.get("omega", "linear").ratio == pytest.approx(0.01 / 0.009)



def test_a_tier_without_parameters_reads_as_no_change():
    # an AR order of 0 has no parameters: zeta and epsilon are both 0, which is no change
    # (ratio 0), not an infinite ratio; a change against a zero epsilon still is infinite
    assert TierDrift("omega", "linear", 0.0, 0.0, ()).ratio == 0.0
    assert not TierDrift("omega", "linear", 0.0, 0.0, ()).exceeded
    moved = TierDrift("omega", "linear", 0.5, 0.0, ())
    assert moved.ratio == float("inf") and moved.exceeded
    assert TierDrift("omega", "linear", 0.5, None, ()).ratio is None


def test_drift_json_round_trip_is_exact():
    base = make_signature((make_channel(a=(0.5,)),))
    cand = make_signature((make_channel(a=(0.6,), moments=(0.1, 3.0, 0.2, 1.2)),))
    thresholds = tuple(TierThreshold("omega", tier, 0.003, 0.001, 2.0, (0.1, 0.2, 0.3))
                       for tier in ("linear", "nonlinear", "noise"))
    for calibration in (None, Calibration(thresholds, 0.01, 0.01 / 3, 1000, 12)):
        drift = compute_drift(cand, base, calibration)
        assert Drift.from_dict(json.loads(json.dumps(drift.to_dict()))) == drift

def test_structure_mismatch_is_refused():
    base = make_signature((make_channel(a=(0.5, -0.2)),))
    other = make_signature((make_channel(a=(0.5,)),))
    with pytest.raises(StructureMismatchError, match="frozen structure"):
        compute_drift(other, base)
    with pytest.raises(StructureMismatchError):
        compute_drift(make_signature(residual_method="inverse"), base)


def test_threshold_meets_its_false_alarm_rate_for_gaussian_changes():
    """Known answer: changes d ~ N(0, Sigma) make zeta a weighted chi-square; epsilon from
    a small healthy sample must be exceeded by new healthy zetas at most about alpha."""
    rng = np.random.default_rng(0)
    scales = np.array([3.0, 1.0, 1.0, 0.5, 0.2, 0.1])
    alpha, exceed, trials = 0.01, 0, 300
    for _ in range(trials):
        healthy = [rng.normal(size=6) * scales for _ in range(16)]
        epsilon, mean, dof = threshold_from_deltas(healthy, alpha)
        fresh = rng.normal(size=(200, 6)) * scales
        exceed += np.mean((fresh ** 2).sum(axis=1) > epsilon)
    rate = exceed / trials
    assert rate < alpha * 1.5
    assert rate > alpha / 10       # and not absurdly conservative


def test_the_zetas_spread_gives_h_without_its_small_sample_bias():
    """Known answer: five orthogonal changes (no cross products, so the spread alone
    bounds h) with zetas 1..5: mean 3, sample variance 2.5, 2 mean^2 / s^2 = 7.2, and
    without the bias of an inverse sample variance on four degrees of freedom
    ((k - 3) / (k - 1) = 1/2) h = 3.6."""
    deltas = [np.sqrt(z) * np.eye(8)[i] for i, z in enumerate((1.0, 2.0, 3.0, 4.0, 5.0))]
    epsilon, mean, dof = threshold_from_deltas(deltas, 0.01)
    assert mean == pytest.approx(3.0)
    assert dof == pytest.approx(3.6)
    assert epsilon == pytest.approx(3.0 * stats.f.ppf(0.99, 3.6, 5 * 3.6))


def test_five_healthy_days_that_agree_by_chance_keep_the_false_alarm_rate():
    """Known answer: a slow export gives one piece a day, so five zetas set both the scale
    and the tail. Changes of h = 2 or 5 equal components (zeta = chi2(h)) among 32
    parameters: averaged over 1,600 calibrations, a new healthy zeta exceeds epsilon at
    about alpha (0.5-0.9 alpha here); with h taken as 2 mean^2 / s^2 of the five zetas, where
    days that happened to agree read as a light tail, it was 1.4-2.0 alpha."""
    rng = np.random.default_rng(0)
    alpha, rates = 0.001, []
    for h in (2, 5):
        for _ in range(800):
            deltas = list(np.pad(rng.normal(size=(5, h)), ((0, 0), (0, 32 - h))))
            epsilon, _, _ = threshold_from_deltas(deltas, alpha, [float(d @ d) for d in deltas])
            rates.append(stats.chi2.sf(epsilon, h))
    assert alpha / 4 < np.mean(rates) < 1.2 * alpha


def test_three_healthy_days_of_a_slow_export_keep_a_threshold_that_can_alarm():
    """Known answer: a 3-day baseline of a slow export (one piece a day) calibrates on three
    zetas, where an inverse sample variance has no finite mean and (k - 3) / (k - 1) is 0:
    h fell to 1 and epsilon to 24-80 times the true quantile, a baseline that never alarms
    (a new healthy zeta crossed it at 0.01 alpha). Changes of h = 2 or 5 equal components
    among 32 parameters: averaged over 1,600 calibrations the rate stays near alpha (0.4-1.4
    alpha in simulation), and the median epsilon within 20 times the true quantile."""
    rng = np.random.default_rng(0)
    alpha, rates = 0.001, []
    for h in (2, 5):
        epsilons = []
        for _ in range(800):
            deltas = list(np.pad(rng.normal(size=(3, h)), ((0, 0), (0, 32 - h))))
            epsilon, _, _ = threshold_from_deltas(deltas, alpha, [float(d @ d) for d in deltas])
            epsilons.append(epsilon)
            rates.append(stats.chi2.sf(epsilon, h))
        assert np.median(epsilons) < 20 * stats.chi2.isf(alpha, h)
    assert alpha / 4 < np.mean(rates) < 1.5 * alpha


def test_threshold_known_answer_for_isotropic_changes():
    rng = np.random.default_rng(1)
    deltas = [rng.normal(size=4) for _ in range(2000)]
    epsilon, mean, dof = threshold_from_deltas(deltas, 0.05)
    assert mean == pytest.approx(4.0, rel=0.05)
    assert dof == pytest.approx(4.0, rel=0.15)
    assert epsilon == pytest.approx(stats.chi2.ppf(0.95, 4), rel=0.05)
    with pytest.raises(InsufficientDataError):
        threshold_from_deltas(deltas[:2], 0.05)


def test_calibration_json_round_trip_and_refusal():
    calibration = Calibration((TierThreshold("omega", "linear", 0.1, 0.02, 3.0, (0.01, 0.03)),),
                              0.01, 0.0033, 8000, 16)
    assert Calibration.from_json(calibration.to_json()) == calibration
    assert calibration.epsilon("omega", "linear") == 0.1
    with pytest.raises(KeyError):
        calibration.epsilon("omega", "noise")
    with pytest.raises(ArtifactError):
        Calibration.from_json('{"thresholds": [{"channel": "omega"}]}')


def test_a_calibration_written_by_the_hand_written_reader_code_loads_equal():
    text = (pathlib.Path(__file__).parent / "data" / "calibration_v1.json").read_text().strip()
    loaded = Calibration.from_json(text)
    threshold = TierThreshold("omega", "linear", 1.5, 0.5, 3.2, (0.1, 0.7, 1 / 3))
    assert loaded == Calibration((threshold,), 0.01, 0.01 / 6, 1000, 24)
    assert loaded.to_json() == text
    with pytest.raises(ArtifactError, match=r"TierThreshold: missing field\(s\) \['dof'"):
        Calibration.from_json(text.replace('"dof": 3.2, ', ""))
    with pytest.raises(ArtifactError, match="Calibration.n_windows must be an integer"):
        Calibration.from_json(text.replace('"n_windows": 24', '"n_windows": "24"'))



def _asset_changes(rng, days, per_day, day_sd, size=1):
    """Night-scale changes of one asset: ``per_day`` pieces a day, and each whole day, which
    adds a day effect of ``day_sd`` (pieces of one day share it, so it cancels in their
    spread around the asset's refit only when it is zero)."""
    pieces = [rng.normal(size=size) for _ in range(days * per_day)]
    wholes = [rng.normal(size=size) * day_sd + rng.normal(size=size) for _ in range(days)]
    return pieces, wholes


def test_whole_days_that_vary_more_than_their_pieces_raise_epsilon():
    """Known answer: whole days vary 1 + 4 = 5 times their pieces. Each asset's own 5 days
    give the threshold (a new day over their mean is about F(1, 5)-distributed), so new days
    exceed it at about alpha, where the pieces alone would alarm on more than 10 % of them."""
    rng = np.random.default_rng(5)
    exceed, plain_exceed = [], []
    for _ in range(40):
        pieces, wholes = _asset_changes(rng, 5, 8, 2.0)
        epsilon, _, _ = threshold_from_deltas(pieces, 0.01, [float(d @ d) for d in wholes])
        plain, _, _ = threshold_from_deltas(pieces, 0.01)
        fresh = rng.normal(size=4000) * 2.0 + rng.normal(size=4000)
        exceed.append(np.mean(fresh ** 2 > epsilon))
        plain_exceed.append(np.mean(fresh ** 2 > plain))
    assert 0.002 < np.mean(exceed) < 0.02
    assert np.mean(plain_exceed) > 0.1


def test_without_a_day_effect_the_rate_holds():
    rng = np.random.default_rng(6)
    exceed = []
    for _ in range(20):
        pieces, wholes = _asset_changes(rng, 5, 8, 0.0, size=3)
        epsilon, _, _ = threshold_from_deltas(pieces, 0.01, [float(d @ d) for d in wholes])
        exceed.append(np.mean((rng.normal(size=(2000, 3)) ** 2).sum(axis=1) > epsilon))
    assert np.mean(exceed) < 0.015


def test_quiet_days_leave_the_pieces_threshold_and_loud_days_set_it():
    deltas = [np.array([x]) for x in (0.5, -1.0, 1.5, -0.3)]
    plain = threshold_from_deltas(deltas, 0.01)
    assert threshold_from_deltas(deltas, 0.01, [1e-6, 2e-6]) == plain
    _, mean, dof = plain
    loud = [10.0, 30.0, 20.0]
    epsilon = threshold_from_deltas(deltas, 0.01, loud)[0]
    assert epsilon == pytest.approx(20.0 * stats.f.ppf(0.99, dof, 3 * dof))


def test_a_noise_epsilon_below_the_moments_sampling_noise_is_raised_to_it():
    # five baseline days that happened to agree calibrate a tiny epsilon; a night's moments
    # differ from the baseline's by their sampling noise at least
    from graybox.noise_tier import sampling_zeta_quantile
    base = make_signature((make_channel(moments=(0.0, 1.0, 0.0, 0.0), n_samples=400),))
    cand = make_signature((make_channel(moments=(0.05, 1.1, 0.2, 0.5), n_samples=200),))
    thresholds = tuple(TierThreshold("omega", tier, 1e-4, 1e-5, 2.0, (1e-5,) * 3)
                       for tier in ("linear", "nonlinear", "noise"))
    calibration = Calibration(thresholds, 0.01, 0.01 / 3, 200, 12)
    entry = compute_drift(cand, base, calibration).get("omega", "noise")
    floor = sampling_zeta_quantile(base.channels[0].noise, 200, 0.01 / 3)
    assert entry.epsilon == pytest.approx(floor)
    assert floor == pytest.approx((1 / 200 + 1 / 400) * stats.chi2.isf(0.01 / 3, 4))
    # zeta 0.05^2 + 0.1^2 / 2 + 0.2^2 / 6 + 0.5^2 / 24 = 0.0246, under the floor (0.12)
    assert entry.zeta == pytest.approx(0.0025 + 0.005 + 0.04 / 6 + 0.25 / 24) and not entry.exceeded
    # the linear tier has no such floor: its calibrated epsilon stands
    assert compute_drift(cand, base, calibration).get("omega", "linear").epsilon == pytest.approx(1e-4)


def test_a_drifts_largest_entry_is_its_largest_calibrated_ratio():
    entries = (TierDrift("temp", "noise", 0.38, 0.5, ()),
               TierDrift("temp", "level", 9.0, None, ()),
               TierDrift("speed", "linear", 0.2, 0.1, ()),
               TierDrift("speed", "noise", 0.0, 0.0, ()))
    largest = Drift(entries, 100).largest
    assert (largest.channel, largest.tier, largest.ratio) == ("speed", "linear", 2.0)
    # nothing calibrated: no largest ratio
    assert Drift(entries[1:2], 100).largest is None
