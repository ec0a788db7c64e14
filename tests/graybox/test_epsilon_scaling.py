"""Epsilon scaled with the candidate window's sample count, in both directions."""
import pytest
from conftest import make_channel, make_signature

from graybox.calibration import Calibration, TierThreshold
from graybox.drift import compute_drift
from graybox.epsilon_scaling import epsilon_scale


def test_known_answers():
    # one night: the calibrated epsilon
    assert epsilon_scale(1000, 1000, 4000) == 1.0
    # two nights against a four-night baseline: (1/2 + 1/4) / (1 + 1/4) = 0.6
    assert epsilon_scale(2000, 1000, 4000) == pytest.approx(0.6, rel=1e-12)
    # three nights: (1/3 + 1/4) / (5/4) = 7/15
    assert epsilon_scale(3000, 1000, 4000) == pytest.approx(7 / 15, rel=1e-12)
    # half a night: scaled up by the ratio of counts, as before (baseline or not)
    assert epsilon_scale(500, 1000, 4000) == 2.0
    assert epsilon_scale(500, 1000) == 2.0
    # longer without the baseline's count: never lowered
    assert epsilon_scale(2000, 1000) == 1.0


def test_longer_windows_lower_epsilon_less_than_the_sample_ratio_and_monotonically():
    factors = [epsilon_scale(n, 1000, 4000) for n in (1000, 1500, 2000, 4000, 10 ** 9)]
    assert factors == sorted(factors, reverse=True)
    assert all(f > 1000 / n for f, n in zip(factors[1:], (1500, 2000, 4000, 10 ** 9)))
    # an infinitely long candidate keeps the baseline's own noise: 1/4 / (5/4) = 0.2
    assert factors[-1] == pytest.approx(0.2, rel=1e-5)


def test_bad_counts_are_refused():
    with pytest.raises(ValueError, match="n_samples=0"):
        epsilon_scale(0, 1000, 4000)
    with pytest.raises(ValueError, match="baseline_samples"):
        epsilon_scale(2000, 1000, 0)


def _calibration(epsilon):
    thresholds = tuple(TierThreshold("omega", tier, eps, eps / 5, 2.0, (0.1, 0.2, 0.3))
                       for tier, eps in (("linear", epsilon), ("nonlinear", 1.0),
                                         ("noise", 1.0)))
    return Calibration(thresholds, 0.01, 0.01 / 3, 1000, 12)


def test_drift_of_a_two_night_candidate_uses_the_lowered_epsilon():
    """zeta 0.01 (a: 0.5 -> 0.6) against epsilon 0.012: one night does not alarm; a
    two-night candidate (2000 samples, baseline 4000) has epsilon 0.0072 and does."""
    base = make_signature((make_channel(a=(0.5,), n_samples=4000),))
    calibration = _calibration(0.012)
    one = compute_drift(make_signature((make_channel(a=(0.6,), n_samples=1000),)), base,
                        calibration)
    assert one.get("omega", "linear").epsilon == pytest.approx(0.012)
    assert not one.alarmed
    two = compute_drift(make_signature((make_channel(a=(0.6,), n_samples=2000),)), base,
                        calibration)
    assert two.get("omega", "linear").epsilon == pytest.approx(0.012 * 0.6)
    assert two.get("omega", "linear").exceeded and two.alarms[0].tier == "linear"
    # the calibration alone (no baseline count) never lowers epsilon
    assert calibration.epsilon("omega", "linear", n_samples=2000) == pytest.approx(0.012)
    assert calibration.epsilon("omega", "linear", n_samples=2000,
                               baseline_samples=4000) == pytest.approx(0.0072)
