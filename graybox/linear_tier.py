"""The linear tier: an autoregressive model AR(n) (Eq. 17) fitted by Yule-Walker.

The Yule-Walker equations are Toeplitz; they are solved by Levinson-Durbin recursion
(:func:`scipy.linalg.solve_toeplitz`). The order is chosen by an information criterion.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np
from scipy.linalg import solve_toeplitz, toeplitz

from graybox.autocovariance import autocovariance
from graybox.exceptions import ConstantSeriesError, InsufficientDataError


@dataclass(frozen=True)
class LinearTier:
    """A fitted AR(n): ``x(t) = sum_i a_i x(t - i) + z(t)``.

    Attributes
    ----------
    coefficients : tuple of float
        ``a_1 .. a_n``.
    innovation_variance : float
        Variance of ``z(t)`` implied by the Yule-Walker solution.
    standard_errors : tuple of float
        Asymptotic standard errors of the coefficients, ``sqrt(diag(sigma^2 Gamma_n^-1 / N))``.
    n_obs : int
        Samples the autocovariances were computed from.
    """

    coefficients: tuple[float, ...]
    innovation_variance: float
    standard_errors: tuple[float, ...]
    n_obs: int

    @property
    def order(self) -> int:
        """The AR order ``n``."""
        return len(self.coefficients)

    @property
    def roots(self) -> np.ndarray:
        """Roots ``G_i`` of the characteristic equation ``G^n - a_1 G^(n-1) - ... - a_n = 0``."""
        if not self.coefficients:
            return np.zeros(0, dtype=complex)
        return np.roots(np.concatenate(([1.0], -np.asarray(self.coefficients))))

    @property
    def is_stationary(self) -> bool:
        """True when every characteristic root lies inside the unit circle (``|G_i| < 1``, Eq. 18)."""
        return bool(np.all(np.abs(self.roots) < 1.0))

    def innovations(self, x: np.ndarray) -> np.ndarray:
        """``w(t) = x(t) - sum_i a_i x(t - i)`` for ``t >= n`` (length ``len(x) - n``)."""
        x = np.asarray(x, dtype=float)
        n = self.order
        w = x[n:].copy()
        if not len(w):
            return w
        term = np.empty_like(w)             # each lag's term, written in place
        for i, a in enumerate(self.coefficients, start=1):
            np.multiply(a, x[n - i: len(x) - i], out=term)
            w -= term
        return w


def autocovariances(segments: Sequence[np.ndarray], max_lag: int) -> tuple[np.ndarray, int]:
    """Pooled biased autocovariances ``gamma_0..gamma_max_lag`` and the sample count.

    Only segments longer than ``max_lag`` count; each is centred on their pooled mean and lag
    products never cross segment borders (:func:`graybox.autocovariance.autocovariance`).
    """
    segments = [np.asarray(s, dtype=float) for s in segments if len(s) > max_lag]
    if not segments:
        raise InsufficientDataError(f"no segment is longer than {max_lag} samples")
    return autocovariance(segments, max_lag), sum(len(s) for s in segments)


def _yule_walker(acov: np.ndarray, order: int) -> tuple[np.ndarray, float]:
    """The AR(``order``) coefficients and innovation variance of the Yule-Walker equations."""
    if order == 0:
        return np.zeros(0), float(acov[0])
    coefficients = solve_toeplitz(acov[:order], acov[1: order + 1])
    return coefficients, float(acov[0] - coefficients @ acov[1: order + 1])


def _solve(acov: np.ndarray, order: int, n_obs: int) -> LinearTier:
    if order == 0:
        return LinearTier((), float(acov[0]), (), n_obs)
    coefficients, sigma2 = _yule_walker(acov, order)
    covariance = sigma2 * np.linalg.inv(toeplitz(acov[:order])) / n_obs
    errors = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    return LinearTier(tuple(map(float, coefficients)), sigma2, tuple(map(float, errors)), n_obs)


def fit_ar(segments: Sequence[np.ndarray] | np.ndarray, order: int | None = None,
           max_order: int = 20, criterion: Literal["aic", "bic"] = "bic") -> LinearTier:
    """Fit AR(n) by Yule-Walker, choosing ``n`` by AIC or BIC when it is not given.

    Parameters
    ----------
    segments : ndarray or sequence of ndarray
        The stationary series, or contiguous pieces of it (autocovariances are pooled).
    order : int, optional
        Fixed order (a frozen structure); chosen from the data when omitted.
    max_order : int, default 20
        Largest order tried.
    criterion : {"aic", "bic"}, default "bic"
        ``N log sigma_n^2 + penalty * n`` with penalty 2 (AIC) or ``log N`` (BIC).

    Returns
    -------
    LinearTier
    """
    if isinstance(segments, np.ndarray) and segments.ndim == 1:
        segments = [segments]
    top = max_order if order is None else order
    acov, n_obs = autocovariances(segments, top)
    if acov[0] <= 0:
        raise ConstantSeriesError("the series is constant; an AR model cannot be fitted")
    if order is not None:
        return _solve(acov, order, n_obs)
    penalty = 2.0 if criterion == "aic" else np.log(n_obs)
    best, best_score = None, np.inf
    for n in range(max_order + 1):
        # the criterion needs the innovation variance alone: the standard errors (an inverse
        # of the order's Toeplitz matrix) are computed for the chosen order only
        score = n_obs * np.log(_yule_walker(acov, n)[1]) + penalty * n
        if score < best_score:
            best, best_score = n, score
    return _solve(acov, best, n_obs)
