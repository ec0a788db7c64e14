"""The noise tier: the last residual described by its moments, and a whiteness test."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Sequence

import numpy as np
from scipy import special

from graybox.autocovariance import autocovariance
from graybox.exceptions import InsufficientDataError

#: inverse asymptotic variances of (mean, variance, skewness, excess kurtosis) of a Gaussian
#: sample, in units of the baseline standard deviation (times N); the noise tier's zeta
#: weights each squared moment change by these so that none of them dominates by its own
#: sampling noise (the kurtosis estimate is 24 times noisier than the mean).
MOMENT_WEIGHTS = (1.0, 1.0 / 2.0, 1.0 / 6.0, 1.0 / 24.0)


def shape_moments(values: np.ndarray) -> tuple[float, float]:
    """Sample skewness and excess kurtosis (biased, as ``scipy.stats.skew`` and
    ``scipy.stats.kurtosis`` with their defaults, computed the same way to the bit).

    Parameters
    ----------
    values : numpy.ndarray
        One-dimensional sample.

    Returns
    -------
    (float, float)
        ``m3 / m2 ** 1.5`` and ``m4 / m2 ** 2 - 3`` of the central moments ``m``; both NaN
        when the sample is constant to rounding.
    """
    # by hand because importing scipy.stats costs a nightly run's process 0.5 s
    mean = values.mean(keepdims=True)
    centred = values - mean
    square = centred ** 2
    m2 = float(np.mean(square))
    if m2 <= (np.finfo(float).eps * float(mean[0])) ** 2:
        return np.nan, np.nan
    return (float(np.mean(square * centred)) / m2 ** 1.5,
            float(np.mean(square ** 2)) / m2 ** 2 - 3.0)


@dataclass(frozen=True)
class NoiseTier:
    """Moments of the last residual and its Ljung-Box whiteness test.

    Attributes
    ----------
    mean, variance, skewness, excess_kurtosis : float
        Sample moments (variance with ``ddof=0``; kurtosis is 0 for a Gaussian).
    ljung_box_statistic, ljung_box_pvalue : float
        Portmanteau test of no autocorrelation up to ``ljung_box_lags``; a small p-value
        says structure is left in the noise.
    ljung_box_lags : int
    n_obs : int
    """

    mean: float
    variance: float
    skewness: float
    excess_kurtosis: float
    ljung_box_statistic: float
    ljung_box_pvalue: float
    ljung_box_lags: int
    n_obs: int

    #: the whiteness test's diagnostics (never compared): a constant residual gives NaN
    non_finite_fields: ClassVar[frozenset[str]] = frozenset(
        {"ljung_box_statistic", "ljung_box_pvalue"})

    @property
    def moments(self) -> tuple[float, float, float, float]:
        """``(mean, variance, skewness, excess_kurtosis)``."""
        return (self.mean, self.variance, self.skewness, self.excess_kurtosis)

    @property
    def is_white(self) -> bool:
        """Whether the Ljung-Box test accepts whiteness at 1 %."""
        return self.ljung_box_pvalue >= 0.01


def describe_noise(segments: Sequence[np.ndarray] | np.ndarray, lags: int = 20) -> NoiseTier:
    """Moments and Ljung-Box test of the final residual (pooled over segments).

    Parameters
    ----------
    segments : ndarray or sequence of ndarray
    lags : int, default 20
        Ljung-Box lags (autocorrelations never cross segment borders).
    """
    if isinstance(segments, np.ndarray):
        segments = [segments]
    segments = [np.asarray(s, dtype=float) for s in segments if len(s)]
    values = np.concatenate(segments) if segments else np.zeros(0)
    n = len(values)
    if n < max(10, lags + 2):
        raise InsufficientDataError(f"{n} samples are too few to describe the noise")
    mean = float(values.mean())
    variance = float(np.mean((values - mean) ** 2))
    if variance <= 0:
        raise InsufficientDataError("the residual is constant")
    skewness, kurtosis = shape_moments(values)
    rho = autocovariance(segments, lags, mean=mean)[1:] / variance
    statistic = float(n * (n + 2) * np.sum(rho ** 2 / (n - np.arange(1, lags + 1))))
    pvalue = float(special.chdtrc(lags, statistic))     # scipy.stats.chi2.sf
    return NoiseTier(mean, variance, skewness, kurtosis, statistic, pvalue, lags, n)
