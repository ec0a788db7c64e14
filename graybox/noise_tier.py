"""The noise tier: the last residual described by its moments, and a whiteness test."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Sequence

import numpy as np
from scipy import special

from graybox.autocovariance import autocovariance
from graybox.exceptions import ConstantSeriesError, InsufficientDataError

#: inverse asymptotic variances of (mean, variance, skewness, excess kurtosis) of a Gaussian
#: sample, in units of the baseline standard deviation (times N); the noise tier's zeta
#: weights each squared moment change by the inverse of its sampling variance so that none of
#: them dominates by its own sampling noise (the kurtosis estimate is 24 times noisier than
#: the mean): these for a record stored before it held its own (``moment_variances``)
MOMENT_WEIGHTS = (1.0, 1.0 / 2.0, 1.0 / 6.0, 1.0 / 24.0)
#: a moment's sampling variance is taken as at least this share of a Gaussian sample's: a
#: light-tailed residual (a sine's, a two-level one: kurtosis variance near 0) must not
#: weigh its shape's changes without bound
VARIANCE_FLOOR = 0.25


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


def moment_variances(values: np.ndarray, skewness: float,
                     kurtosis: float) -> tuple[float, float, float, float]:
    """Asymptotic sampling variances (times N) of the mean (in standard deviations), the
    relative variance, the skewness and the excess kurtosis of ``values``' own distribution.

    Each is the mean square of the statistic's influence function over the sample (the delta
    method with the sample's own moments, up to the eighth): with ``z`` the standardised
    values, ``g`` the skewness and ``b`` the kurtosis (not excess), ``z``, ``z^2 - 1``,
    ``z^3 - 3 z - g - 1.5 g (z^2 - 1)`` and ``z^4 - b - 4 g z - 2 b (z^2 - 1)``. A Gaussian
    sample gives 1, 2, 6 and 24 (the inverse :data:`MOMENT_WEIGHTS`); a residual with rare
    transients gives its kurtosis a variance many times 24, which is how much its kurtosis
    moves from night to night with no fault.

    Parameters
    ----------
    values : numpy.ndarray
        One-dimensional sample (not constant).
    skewness, kurtosis : float
        Its skewness and excess kurtosis (:func:`shape_moments`).

    Returns
    -------
    tuple of 4 float
    """
    z = (values - values.mean()) / values.std()
    square = z * z
    b = kurtosis + 3.0
    skew_influence = z * (square - 3.0) - skewness - 1.5 * skewness * (square - 1.0)
    kurtosis_influence = square * square - b - 4.0 * skewness * z - 2.0 * b * (square - 1.0)
    return (1.0, float(np.mean((square - 1.0) ** 2)), float(np.mean(skew_influence ** 2)),
            float(np.mean(kurtosis_influence ** 2)))


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
    moment_variances : tuple of 4 float, optional
        The sampling variances (times N) of the four moments under the residual's own
        distribution (:func:`moment_variances`); a baseline's weigh the tier's zeta. None in
        a record stored before them, whose zeta weighs by :data:`MOMENT_WEIGHTS`.
    """

    mean: float
    variance: float
    skewness: float
    excess_kurtosis: float
    ljung_box_statistic: float
    ljung_box_pvalue: float
    ljung_box_lags: int
    n_obs: int
    moment_variances: tuple[float, float, float, float] | None = None

    omitted_when_none: ClassVar[frozenset[str]] = frozenset({"moment_variances"})
    #: the whiteness test's diagnostics (never compared): a constant residual gives NaN
    non_finite_fields: ClassVar[frozenset[str]] = frozenset(
        {"ljung_box_statistic", "ljung_box_pvalue"})

    @property
    def moments(self) -> tuple[float, float, float, float]:
        """``(mean, variance, skewness, excess_kurtosis)``."""
        return (self.mean, self.variance, self.skewness, self.excess_kurtosis)

    @property
    def moment_weights(self) -> tuple[float, float, float, float]:
        """What the tier's zeta weighs each squared moment change by, when this record is the
        baseline: the inverse :attr:`moment_variances` (:data:`MOMENT_WEIGHTS` without)."""
        if self.moment_variances is None:
            return MOMENT_WEIGHTS
        return tuple(1.0 / max(v, VARIANCE_FLOOR / w)
                     for v, w in zip(self.moment_variances, MOMENT_WEIGHTS))

    @property
    def is_white(self) -> bool:
        """Whether the Ljung-Box test accepts whiteness at 1 %."""
        return self.ljung_box_pvalue >= 0.01


def sampling_zeta_quantile(baseline: NoiseTier, n_candidate: int, alpha: float) -> float:
    """The noise tier's zeta that sampling noise alone exceeds with probability ``alpha``.

    A candidate's moment ``j`` and the baseline's differ by sampling noise of variance
    ``v_j (1 / n + 1 / N)`` (``v``: the baseline's :attr:`NoiseTier.moment_variances`, a
    Gaussian's without; ``n``, ``N``: the candidate's and the baseline's samples); zeta weighs
    its square by :attr:`NoiseTier.moment_weights` ``w_j``, so zeta is a sum of
    ``lambda_j chi2(1)`` with ``lambda_j = v_j w_j (1 / n + 1 / N)`` (1 where no floor binds),
    read as ``g chi2(h)`` (Satterthwaite: ``g h = sum lambda``, ``h = (sum lambda)^2 / sum
    lambda^2``; the moments taken as uncorrelated).

    Parameters
    ----------
    baseline : NoiseTier
    n_candidate : int
        The candidate's residual samples (> 0).
    alpha : float
        In (0, 1).

    Returns
    -------
    float
    """
    if not 0 < alpha < 1 or n_candidate <= 0:
        raise ValueError(f"need 0 < alpha < 1 and n_candidate > 0, got {alpha}, {n_candidate}")
    variances = baseline.moment_variances or tuple(1.0 / w for w in MOMENT_WEIGHTS)
    scale = 1.0 / n_candidate + 1.0 / baseline.n_obs
    weights = np.array([v * w for v, w in zip(variances, baseline.moment_weights)]) * scale
    g = float(np.sum(weights ** 2) / np.sum(weights))
    h = float(np.sum(weights) / g)
    return g * float(special.chdtri(h, alpha))     # scipy.stats.chi2.isf(alpha, h)


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
    skewness, kurtosis = shape_moments(values)
    if variance <= 0 or np.isnan(skewness):
        # constant to rounding: a stretch where the machine stood still (no moments to
        # describe; a machine that stops is declared by its class's grid ``running``)
        raise ConstantSeriesError("the residual is constant")
    rho = autocovariance(segments, lags, mean=mean)[1:] / variance
    statistic = float(n * (n + 2) * np.sum(rho ** 2 / (n - np.arange(1, lags + 1))))
    pvalue = float(special.chdtrc(lags, statistic))     # scipy.stats.chi2.sf
    variances = moment_variances(values, skewness, kurtosis) if np.isfinite(kurtosis) else None
    return NoiseTier(mean, variance, skewness, kurtosis, statistic, pvalue, lags, n, variances)
