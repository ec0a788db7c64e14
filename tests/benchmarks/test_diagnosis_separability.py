"""Known answers of the separability analysis' Monte Carlo (benchmarks/diagnosis/separability):
two hypotheses with orthogonal signatures and no signal tie (each first half the time); a
bias far above the noise is always first; a rival with the bias' own signature up to a
sliver wins as often as the bias does, and the share follows Phi(sqrt(delta) / 2)."""
import numpy as np
import pytest
from scipy import stats

from benchmarks.diagnosis.separability import allowed_top1


def test_no_signal_is_a_coin_flip_between_orthogonal_signatures():
    slopes = {"bias": np.array([1.0, 0.0, 0.0]), "other": np.array([0.0, 1.0, 0.0])}
    assert allowed_top1(slopes, 0.0, np.random.default_rng(1)) == pytest.approx(0.5, abs=0.02)


def test_a_large_bias_with_its_own_signature_is_always_first():
    slopes = {"bias": np.array([10.0, 0.0]), "other": np.array([0.0, 10.0])}
    assert allowed_top1(slopes, 5.0, np.random.default_rng(2)) == 1.0


def test_a_near_collinear_rival_follows_the_noncentrality():
    # |s_bias| = 10, the rival tilted by angle a: delta = sin(a)^2 m^2 |s|^2
    angle, magnitude = 0.1, 2.0
    slopes = {"bias": np.array([10.0, 0.0]),
              "other": 10.0 * np.array([np.cos(angle), np.sin(angle)])}
    delta = np.sin(angle) ** 2 * magnitude ** 2 * 100.0
    expected = stats.norm.cdf(np.sqrt(delta) / 2)
    assert allowed_top1(slopes, magnitude, np.random.default_rng(3)) == pytest.approx(
        expected, abs=0.02)
