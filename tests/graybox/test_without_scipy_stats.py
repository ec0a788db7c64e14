"""graybox computes its quantiles and moments without importing scipy.stats (0.5 s of a
process's start-up), and gets exactly scipy.stats' numbers: compared to the bit here."""
import numpy as np
import pytest
from scipy import stats

from fresh_imports import loaded_after
from graybox.calibration import threshold_from_deltas
from graybox.noise_tier import describe_noise, shape_moments
from graybox.parameter_estimate import ParameterEstimate
from graybox.summary import coefficient_rows, format_pvalue


def _samples():
    rng = np.random.default_rng(7)
    yield rng.normal(size=10)
    yield rng.standard_t(3, size=4999) * 1e3 + 5
    yield rng.exponential(size=2000) + 1e6                 # large mean, small spread
    yield rng.normal(size=86_400) * 1e-9
    yield rng.uniform(-1, 1, size=777)


@pytest.mark.parametrize("index", range(5))
def test_shape_moments_are_scipys_to_the_bit(index):
    values = list(_samples())[index]
    skewness, kurtosis = shape_moments(values)
    assert skewness == float(stats.skew(values))
    assert kurtosis == float(stats.kurtosis(values))


def test_constant_to_rounding_is_nan_like_scipy():
    values = np.full(40, 1e6) + np.r_[np.zeros(39), 1e-12]
    with np.errstate(all="ignore"), pytest.warns(RuntimeWarning):
        expected = (float(stats.skew(values)), float(stats.kurtosis(values)))
    assert np.isnan(expected).all()
    assert np.isnan(shape_moments(values)).all()


def test_ljung_box_pvalue_is_scipys_chi2_sf():
    rng = np.random.default_rng(3)
    for lags in (1, 7, 20, 48):
        noise = describe_noise(np.cumsum(rng.normal(size=3000)) * 0.01 + rng.normal(size=3000),
                               lags=lags)
        assert noise.ljung_box_pvalue == float(stats.chi2.sf(noise.ljung_box_statistic, lags))


def test_epsilon_is_scipys_f_quantile():
    rng = np.random.default_rng(5)
    deltas = [rng.normal(size=12) for _ in range(6)]
    days = [float(rng.chisquare(12)) for _ in range(4)]
    for alpha in (0.01, 0.001 / 5, 0.05):
        epsilon, mean, dof = threshold_from_deltas(deltas, alpha)
        assert epsilon == mean * float(stats.f.ppf(1.0 - alpha, dof, 6 * dof))
        with_days, mean, dof = threshold_from_deltas(deltas, alpha, day_zetas=days)
        expected = max(mean * float(stats.f.ppf(1.0 - alpha, dof, 6 * dof)),
                       float(np.mean(days)) * float(stats.f.ppf(1.0 - alpha, dof, 4 * dof)))
        assert with_days == expected


def test_normal_quantiles_are_scipys():
    estimate = ParameterEstimate(("a", "b"), (1.5, -2.0), (0.1, 0.3), ((1.0, 0.0), (0.0, 1.0)),
                                 (1.0, -1.0), ("y",), (0.2,), 10, 100, 50.0, True)
    for level in (0.5, 0.9, 0.95, 0.99):
        z = float(stats.norm.ppf(0.5 + level / 2))
        assert estimate.interval(level) == ((1.5 - z * 0.1, 1.5 + z * 0.1),
                                            (-2.0 - z * 0.3, -2.0 + z * 0.3))
    row = coefficient_rows(["a"], [0.25], [0.1])[0]
    assert row[4] == format_pvalue(float(2.0 * stats.norm.sf(2.5)))


def test_graybox_does_not_import_scipy_stats():
    # the diagnosis (graybox.diagnosis, loaded on first use) still does
    loaded = loaded_after("graybox, graybox.alert, graybox.calibration, graybox.drift, "
                          "graybox.residual, graybox.signature_fit", ("scipy.stats",))
    assert loaded == "[]"
    assert "diagnose" in dir(__import__("graybox"))
