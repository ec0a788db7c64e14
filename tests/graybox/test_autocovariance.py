import numpy as np
import pytest

from graybox.autocovariance import autocorrelation, autocovariance


def test_direct_and_fft_agree_and_lag_products_stay_within_segments():
    rng = np.random.default_rng(0)
    x = rng.normal(size=600)
    segments = [x[:2], x[2:300], x[300:]]
    direct = autocovariance(segments, 8)
    np.testing.assert_allclose(autocovariance(segments, 8, method="fft"), direct, atol=1e-14)
    mean = x.mean()
    c = [s - mean for s in segments]
    lag3 = sum(np.dot(s[3:], s[:-3]) for s in c if len(s) > 3) / len(x)
    assert direct[3] == pytest.approx(lag3, rel=1e-13)
    assert direct[0] == pytest.approx(np.var(x), rel=1e-13)


def test_explicit_mean_and_constant_series():
    x = np.arange(10.0)
    assert autocovariance([x], 0, mean=0.0)[0] == pytest.approx(np.mean(x ** 2))
    np.testing.assert_array_equal(autocorrelation(np.ones(20), 3), np.zeros(4))
    with pytest.raises(ValueError):
        autocovariance([x], 2, method="slow")
