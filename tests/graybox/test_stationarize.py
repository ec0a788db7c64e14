import itertools
import warnings

import numpy as np
import pytest
from scipy.signal import lfilter

from graybox.exceptions import InsufficientDataError
from graybox.stationarize import (Differencing, acf_area, adf_statistic, autocorrelation,
                                  choose_differencing, find_period)


@pytest.mark.parametrize("period, seasonal_order, order",
                         [(0, 0, 0), (0, 0, 1), (0, 0, 3)]
                         + list(itertools.product([2, 7, 24], [1, 2], [0, 1, 2])))
def test_differencing_round_trips_exactly(period, seasonal_order, order):
    rng = np.random.default_rng(period * 100 + seasonal_order * 10 + order)
    x = rng.integers(-1000, 1000, 300).astype(float)  # integers: float sums are exact
    op = Differencing(period, seasonal_order, order)
    y = op.apply(x)
    assert len(y) == len(x) - op.lost
    np.testing.assert_array_equal(op.invert(y, x[: op.lost]), x)


def test_differencing_round_trips_real_valued_series_to_rounding():
    x = np.random.default_rng(3).normal(size=500).cumsum()
    op = Differencing(12, 1, 1)
    np.testing.assert_allclose(op.invert(op.apply(x), x[: op.lost]), x, rtol=0, atol=1e-11)


def test_differencing_matches_the_operator_definitions():
    x = np.arange(20.0) ** 2
    np.testing.assert_array_equal(Differencing(0, 0, 1).apply(x), x[1:] - x[:-1])         # Eq. 19
    np.testing.assert_array_equal(Differencing(5, 1, 0).apply(x), x[5:] - x[:-5])         # Eq. 21
    with pytest.raises(ValueError):
        Differencing(1, 1, 0)
    with pytest.raises(InsufficientDataError):
        Differencing(0, 0, 2).apply(np.ones(2))


@pytest.mark.parametrize("period", [12, 24, 50, 144])
def test_period_of_a_known_seasonal_series_is_found(period):
    rng = np.random.default_rng(period)
    t = np.arange(40 * period)
    x = 3 * np.sin(2 * np.pi * t / period) + np.sign(np.sin(2 * np.pi * t / period + 1)) \
        + rng.normal(size=len(t)) + 0.001 * t
    assert find_period(x) == period


def test_no_period_in_noise_or_a_random_walk():
    rng = np.random.default_rng(5)
    assert find_period(rng.normal(size=4000)) == 0
    assert find_period(lfilter([1], [1, -0.5], rng.normal(size=4000))) == 0


def test_choose_differencing_by_smallest_acf_area():
    rng = np.random.default_rng(7)
    n = 6000
    walk = rng.normal(size=n).cumsum()
    assert choose_differencing([walk]).differencing == Differencing(0, 0, 1)
    white = rng.normal(size=n)
    assert choose_differencing([white]).differencing == Differencing(0, 0, 0)
    t = np.arange(n)
    seasonal = 5 * np.sin(2 * np.pi * t / 24) + rng.normal(size=n)
    choice = choose_differencing([seasonal])
    assert choice.differencing == Differencing(24, 1, 0)
    assert choice.acf_area < choice.raw_acf_area / 2
    both = seasonal + rng.normal(size=n).cumsum()
    assert choose_differencing([both]).differencing == Differencing(24, 1, 1)
    resonant = lfilter([1], [1, -1.27, 0.81], rng.normal(size=n))   # stationary, oscillating
    assert choose_differencing([resonant]).differencing == Differencing(0, 0, 0)


def test_acf_area_pools_segments_and_autocorrelation_is_normalized():
    rng = np.random.default_rng(8)
    x = lfilter([1], [1, -0.8], rng.normal(size=4000))
    rho = autocorrelation(x, 5)
    assert rho[0] == 1.0 and rho[1] == pytest.approx(0.8, abs=0.05)
    assert acf_area([x[:2000], x[2000:]], 10) == pytest.approx(acf_area([x], 10), rel=0.05)


def test_adf_statistic_matches_statsmodels():
    from statsmodels.tsa.stattools import adfuller   # the test extra: a missing one fails
    rng = np.random.default_rng(9)
    for x in (lfilter([1], [1, -0.9], rng.normal(size=1500)), rng.normal(size=1500).cumsum()):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reference = adfuller(x, maxlag=6, autolag=None, regression="c")[0]
        assert adf_statistic(x, lags=6) == pytest.approx(reference, rel=1e-9)


@pytest.mark.parametrize("period, cycles", [(12, 9.6), (50, 37.3), (144, 37.3), (720, 12.0)])
def test_period_found_when_the_series_holds_a_fractional_number_of_cycles(period, cycles):
    rng = np.random.default_rng(period)
    t = np.arange(int(cycles * period))
    x = 3 * np.sin(2 * np.pi * t / period) + rng.normal(size=len(t))
    assert abs(find_period(x) - period) <= max(0, 0.01 * period)


@pytest.mark.parametrize("n, window", [(100, 7), (100, 8), (1000, 2), (3000, 1998)])
def test_box_sum_equals_the_direct_convolution(n, window):
    from graybox.stationarize import _box_sum
    x = np.random.default_rng(n).normal(size=n)
    np.testing.assert_allclose(_box_sum(x, window), np.convolve(x, np.ones(window), "same"),
                               atol=1e-9)


def test_adf_design_written_in_one_copy_gives_the_column_stacked_statistic_to_the_bit():
    # the lag columns are copied from a reversed sliding window of the differences: the same
    # design, so the same statistic as the design stacked a column at a time
    def stacked(x, lags):
        dx = np.diff(x)
        rows = len(dx) - lags
        level = x[lags:-1] - x[lags:-1].mean()
        design = np.column_stack([np.ones(rows), level] +
                                 [dx[lags - i: len(dx) - i] for i in range(1, lags + 1)])
        design /= np.sqrt(np.einsum("ij,ij->j", design, design))
        target = dx[lags:]
        inverse = np.linalg.inv(design.T @ design)
        coef = inverse @ (design.T @ target)
        resid = target - design @ coef
        sigma2 = resid @ resid / (rows - design.shape[1])
        return float(coef[1] / np.sqrt(sigma2 * inverse[1, 1]))

    rng = np.random.default_rng(8)
    for n, lags in ((300, 0), (300, 1), (2000, 7), (20000, None)):
        x = np.cumsum(rng.normal(size=n)) * 0.1 + rng.normal(size=n)
        used = int(12 * (n / 100) ** 0.25) if lags is None else lags
        assert adf_statistic(x, lags) == stacked(x, used)
