import warnings

import numpy as np
import pytest
from scipy.signal import lfilter

from graybox.exceptions import InsufficientDataError
from graybox.linear_tier import LinearTier, autocovariances, fit_ar

TRUE = np.array([0.6, -0.3])


def simulate_ar2(n, seed):
    rng = np.random.default_rng(seed)
    return lfilter([1], [1, -TRUE[0], -TRUE[1]], rng.normal(size=n + 500))[500:]


def test_ar2_coefficients_recovered_within_standard_errors():
    fit = fit_ar(simulate_ar2(5000, 0), order=2)
    errors = np.asarray(fit.standard_errors)
    assert np.all(np.abs(np.asarray(fit.coefficients) - TRUE) < 3 * errors)
    # the asymptotic standard error of AR(2) coefficients is sqrt((1 - a2^2) / N)
    np.testing.assert_allclose(errors, np.sqrt((1 - TRUE[1] ** 2) / 5000), rtol=0.05)
    assert fit.innovation_variance == pytest.approx(1.0, rel=0.05)


def test_ar2_coverage_of_standard_errors_over_many_series():
    inside = 0
    for seed in range(200):
        fit = fit_ar(simulate_ar2(1000, seed), order=2)
        inside += np.abs(fit.coefficients[0] - TRUE[0]) < 1.96 * fit.standard_errors[0]
    assert 0.90 <= inside / 200 <= 0.99


def test_agrees_with_statsmodels_yule_walker():
    from statsmodels.regression.linear_model import yule_walker   # the test extra: must be there
    x = simulate_ar2(3000, 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rho, sigma = yule_walker(x, order=4, method="mle")
    fit = fit_ar(x, order=4)
    np.testing.assert_allclose(fit.coefficients, rho, rtol=1e-10, atol=1e-12)
    assert fit.innovation_variance == pytest.approx(sigma ** 2, rel=1e-10)


def test_order_is_chosen_from_the_data():
    x = simulate_ar2(8000, 2)
    assert fit_ar(x, criterion="bic").order == 2
    assert fit_ar(x, criterion="aic").order >= 2
    assert fit_ar(np.random.default_rng(3).normal(size=8000)).order == 0


def test_roots_and_stationarity():
    fit = LinearTier((0.6, -0.3), 1.0, (0.0, 0.0), 100)
    roots = fit.roots
    np.testing.assert_allclose(np.sort_complex(roots), np.sort_complex(np.roots([1, -0.6, 0.3])))
    assert fit.is_stationary and np.all(np.abs(roots) < 1)
    assert not LinearTier((1.0,), 1.0, (0.0,), 100).is_stationary       # unit root, |G| = 1
    assert not LinearTier((0.5, 0.6), 1.0, (0.0, 0.0), 100).is_stationary


def test_innovations_invert_the_filter():
    rng = np.random.default_rng(4)
    noise = rng.normal(size=600)
    x = lfilter([1], [1, -TRUE[0], -TRUE[1]], noise)
    fit = LinearTier(tuple(TRUE), 1.0, (0.0, 0.0), len(x))
    np.testing.assert_allclose(fit.innovations(x), noise[2:], atol=1e-12)


def test_segments_are_pooled_without_crossing_borders():
    x = simulate_ar2(4000, 5)
    acov_one, n_one = autocovariances([x], 3)
    acov_two, n_two = autocovariances([x[:2000], x[2000:]], 3)
    assert n_one == n_two == 4000
    np.testing.assert_allclose(acov_two, acov_one, rtol=0.02)
    with pytest.raises(InsufficientDataError):
        fit_ar([np.ones(50)], order=2)


def test_a_starved_window_names_the_setting_that_helps():
    from graybox.settings import GrayBoxSettings
    from graybox.tiers.linear import _what_helps
    # 1 s samples: 201 s of operation fit in a window, so a longer window (or period) helps
    fast = _what_helps(GrayBoxSettings(), 1.0, 120)
    assert "more than 201 s" in fast and "use longer windows ([nightly] window)" in fast
    # a 15-minute logger: 201 samples need 50 h, longer than the longest window (a day), so
    # the advice is the class's min_samples (a day holds 96 samples), never a longer window
    slow = _what_helps(GrayBoxSettings(), 900.0, 95)
    assert "more than 180900 s" in slow and "windows are at most a day" in slow
    assert "settings.min_samples" in slow and "a day holds 96 at 900 s" in slow
    assert "use longer windows" not in slow


def test_the_chosen_order_is_the_one_every_orders_full_fit_would_choose():
    # the criterion reads each order's innovation variance alone; the standard errors are
    # computed for the chosen order only: the same tier as fitting every order in full
    from graybox.linear_tier import _solve

    rng = np.random.default_rng(5)
    for n, criterion in ((400, "bic"), (5000, "aic"), (20000, "bic")):
        x = lfilter([1.0], [1.0, -0.5, 0.3, -0.1], rng.normal(size=n))
        segments = [x[: n // 3], x[n // 3:]]
        acov, n_obs = autocovariances(segments, 12)
        penalty = 2.0 if criterion == "aic" else np.log(n_obs)
        fits = [_solve(acov, k, n_obs) for k in range(13)]
        scores = [n_obs * np.log(f.innovation_variance) + penalty * k for k, f in enumerate(fits)]
        assert fit_ar(segments, max_order=12, criterion=criterion) == fits[int(np.argmin(scores))]
