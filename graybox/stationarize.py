"""Stationarization: seasonal then regular differencing (Eqs. 19 and 21) and its exact inverse.

The orders and the period are chosen from the data with the paper's criterion, the smallest
area under the autocorrelation curve, with a parsimony rule and an augmented Dickey-Fuller
cross-check (see :func:`choose_differencing`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from graybox.autocovariance import autocorrelation
from graybox.exceptions import InsufficientDataError

#: asymptotic 5 % critical value of the Dickey-Fuller t statistic with a constant (MacKinnon)
ADF_CRITICAL_5PCT = -2.86


@dataclass(frozen=True)
class Differencing:
    """The operator ``(1 - B)^order (1 - B^period)^seasonal_order`` (seasonal applied first).

    Attributes
    ----------
    period : int
        Seasonal period ``s`` in samples (0 when there is no seasonal differencing).
    seasonal_order : int
        ``m2``, how many times ``(1 - B^s)`` is applied.
    order : int
        ``m1``, how many times ``(1 - B)`` is applied.
    """

    period: int = 0
    seasonal_order: int = 0
    order: int = 0

    def __post_init__(self):
        if self.order < 0 or self.seasonal_order < 0 or self.period < 0:
            raise ValueError(f"differencing orders and period must be >= 0: {self}")
        if self.seasonal_order > 0 and self.period < 2:
            raise ValueError(f"seasonal differencing needs a period >= 2: {self}")

    @property
    def lost(self) -> int:
        """Samples consumed at the start of a series: ``seasonal_order * period + order``."""
        return self.seasonal_order * self.period + self.order

    def apply(self, x: np.ndarray) -> np.ndarray:
        """Difference ``x``; the result is ``lost`` samples shorter."""
        y = np.asarray(x, dtype=float)
        if len(y) <= self.lost:
            raise InsufficientDataError(
                f"{len(y)} samples cannot be differenced by {self} (needs more than {self.lost})")
        for _ in range(self.seasonal_order):
            y = y[self.period:] - y[:-self.period]
        for _ in range(self.order):
            y = np.diff(y)
        return y

    def invert(self, y: np.ndarray, head: np.ndarray) -> np.ndarray:
        """Undo :meth:`apply`: rebuild ``x`` from its differences and its first ``lost`` samples.

        Parameters
        ----------
        y : ndarray
            The differenced series, ``apply(x)``.
        head : ndarray
            ``x[:lost]``, the initial values the operator discarded.

        Returns
        -------
        ndarray
            ``x``, of length ``len(y) + lost``.
        """
        head = np.asarray(head, dtype=float)
        if len(head) != self.lost:
            raise ValueError(f"invert needs the first {self.lost} samples, got {len(head)}")
        s = self.period
        # initial values of every intermediate series, recomputed from the head of x
        seasonal_heads = [head]
        for _ in range(self.seasonal_order):
            seasonal_heads.append(seasonal_heads[-1][s:] - seasonal_heads[-1][:-s])
        regular_heads = [seasonal_heads[-1]]
        for _ in range(self.order):
            regular_heads.append(np.diff(regular_heads[-1]))
        z = np.asarray(y, dtype=float)
        for i in range(self.order, 0, -1):
            first = regular_heads[i - 1][0]
            z = np.concatenate(([first], first + np.cumsum(z)))
        for j in range(self.seasonal_order, 0, -1):
            start = seasonal_heads[j - 1][:s]
            out = np.empty(len(z) + s)
            out[:s] = start
            for phase in range(s):
                out[s + phase::s] = start[phase] + np.cumsum(z[phase::s])
            z = out
        return z


def acf_area(segments: Sequence[np.ndarray], lags: int) -> float:
    """Area under the absolute autocorrelation curve, ``sum_{k=1..lags} |rho_k|``.

    With several segments the autocorrelations are averaged, weighted by segment length.
    """
    weights, curves = [], []
    for segment in segments:
        if len(segment) > lags + 1:
            curves.append(autocorrelation(segment, lags)[1:])
            weights.append(len(segment))
    if not curves:
        raise InsufficientDataError(f"no segment is longer than {lags + 1} samples")
    return float(np.abs(np.average(curves, axis=0, weights=weights)).sum())


def find_period(x: np.ndarray, max_period: int | None = None, min_cycles: int = 3,
                min_correlation: float = 0.2) -> int:
    """Dominant seasonal period of a series in samples, or 0 if there is none.

    The candidate comes from the periodogram's highest peak (after removing a linear trend),
    located between frequency bins by parabolic interpolation, rounded to whole samples, and
    accepted only if the autocorrelation at one, two, ... ``min_cycles`` periods all exceed
    ``min_correlation``: a season repeats, a stochastic resonance decays.

    Parameters
    ----------
    x : ndarray
    max_period : int, optional
        Longest period considered; at most ``len(x) // min_cycles``.
    min_cycles : int, default 3
        The series must hold at least this many periods.
    min_correlation : float, default 0.2
        Autocorrelation at each multiple of the period needed to call it seasonal.
    """
    x = np.asarray(x, dtype=float)
    n = len(x)
    limit = n // min_cycles if max_period is None else min(max_period, n // min_cycles)
    if limit < 2:
        return 0
    t = np.arange(n)
    detrended = x - np.polyval(np.polyfit(t, x, 1), t)
    power = np.abs(np.fft.rfft(detrended)) ** 2
    frequencies = np.arange(len(power))
    with np.errstate(divide="ignore"):
        periods = np.where(frequencies > 0, n / np.maximum(frequencies, 1), np.inf)
    allowed = (periods >= 2) & (periods <= limit)
    if not allowed.any():
        return 0
    k = int(np.argmax(np.where(allowed, power, -1.0)))
    # the peak frequency between bins, by a parabola through the log power around it
    offset = 0.0
    if 0 < k < len(power) - 1 and np.all(power[k - 1: k + 2] > 0):
        left, centre, right = np.log(power[k - 1: k + 2])
        curvature = left - 2 * centre + right
        if curvature < 0:
            offset = 0.5 * (left - right) / curvature
    best = int(round(n / (k + offset)))
    if not 2 <= best <= limit:
        return 0
    # A season repeats: the correlation must persist over min_cycles periods, which a
    # stochastic resonance (a damped oscillation, e.g. an AR(2) with complex roots) does not.
    # Components slower than the period are removed first (a moving average over two
    # periods, which averages the season itself out): they would correlate every lag.
    window = 2 * best
    slow = _box_sum(detrended, window) / _box_sum(np.ones(n), window)
    lags = best * np.arange(1, min_cycles + 1)
    lags = lags[lags < n]
    rho = autocorrelation(detrended - slow, int(lags[-1]))
    return best if np.min(rho[lags]) >= min_correlation else 0


def _box_sum(x: np.ndarray, window: int) -> np.ndarray:
    """``np.convolve(x, np.ones(window), "same")`` by cumulative sums: O(n), where the direct
    convolution costs n x window (at 1 Hz, days of samples times a period of hours)."""
    n = len(x)
    cumulative = np.concatenate(([0.0], np.cumsum(x)))
    i = np.arange(n)
    hi = np.minimum(n - 1, i + (window - 1) // 2)
    lo = np.maximum(0, i + (window - 1) // 2 - window + 1)
    return cumulative[hi + 1] - cumulative[lo]


def adf_statistic(x: np.ndarray, lags: int | None = None) -> float:
    """Augmented Dickey-Fuller t statistic (regression with a constant).

    ``dx_t = alpha + beta x_{t-1} + sum_i delta_i dx_{t-i} + e_t``; the statistic is the t value
    of ``beta``. Below :data:`ADF_CRITICAL_5PCT` the unit root is rejected at 5 %.

    Parameters
    ----------
    x : ndarray
    lags : int, optional
        Augmentation lags; default ``int(12 * (n / 100) ** 0.25)`` (Schwert), capped at n/10.
    """
    x = np.asarray(x, dtype=float)
    n = len(x)
    if lags is None:
        lags = int(12 * (n / 100) ** 0.25)
    lags = max(0, min(lags, n // 10))
    dx = np.diff(x)
    rows = len(dx) - lags
    if rows < lags + 10:
        raise InsufficientDataError(f"{n} samples are too few for an ADF test with {lags} lags")
    # the t value is unchanged by centring x (the constant absorbs it) and by scaling each
    # column, which keeps the normal equations well conditioned; they cost n p^2 against the
    # SVD of a day's n x p design (about 100 times more at 86,400 samples and p = 67)
    design = np.empty((rows, lags + 2))
    design[:, 0] = 1.0
    design[:, 1] = x[lags:-1] - x[lags:-1].mean()
    # column 1 + i is dx[lags - i:len(dx) - i]: row t's lags are dx's window from t, reversed
    # (written in one copy: a column at a time, the row-major design is written 8 bytes in
    # every 8 (lags + 2))
    design[:, 2:] = sliding_window_view(dx[:-1], lags)[:, ::-1]
    norms = np.sqrt(np.einsum("ij,ij->j", design, design))
    norms[norms == 0] = 1.0
    design /= norms
    target = dx[lags:]
    gram = design.T @ design
    try:
        inverse = np.linalg.inv(gram)
    except np.linalg.LinAlgError:
        inverse = np.linalg.pinv(gram)
    coef = inverse @ (design.T @ target)
    resid = target - design @ coef
    dof = rows - design.shape[1]
    sigma2 = resid @ resid / dof
    return float(coef[1] / np.sqrt(sigma2 * inverse[1, 1]))


@dataclass(frozen=True)
class DifferencingChoice:
    """The chosen operator and the evidence for it."""

    differencing: Differencing
    acf_area: float          #: ACF area of the chosen transform
    raw_acf_area: float      #: ACF area of the untransformed series
    adf_statistic: float     #: ADF t statistic of the chosen transform
    candidate_period: int    #: period found in the data (0 = none), whether used or not


def choose_differencing(segments: Sequence[np.ndarray], max_order: int = 2,
                        max_seasonal_order: int = 1, max_period: int | None = None,
                        lags: int = 40, min_improvement: float = 2.0) -> DifferencingChoice:
    """Choose ``s``, ``m2`` and ``m1`` by the smallest area under the autocorrelation curve.

    The search goes greedily from no differencing: a seasonal difference (at the period found
    by :func:`find_period`) is tried first, as the paper recommends, then regular differences.
    An operator is kept only if it shrinks the ACF area by at least ``min_improvement``
    (parsimony: over-differencing a stationary series also lowers the area a little while
    damaging its structure). The augmented Dickey-Fuller test cross-checks the regular
    differences: a second or later difference is tried only while the series still has a unit
    root (not rejected at 5 %), and one is added while the result has one.

    Parameters
    ----------
    segments : sequence of ndarray
        Contiguous pieces of the series (for example one per day); ACFs are pooled.
    max_order, max_seasonal_order : int
        Upper bounds of ``m1`` and ``m2``.
    max_period : int, optional
        Longest seasonal period; default a third of the shortest segment, so the operator can
        be applied to every window of that length.
    lags : int, default 40
        Lags in the ACF area; raised to two periods when a period is tried.
    min_improvement : float, default 2.0
        Factor by which an operator must shrink the area to be kept.
    """
    segments = [np.asarray(s, dtype=float) for s in segments]
    shortest = min(len(s) for s in segments)
    if max_period is None:
        max_period = shortest // 3
    longest = max(segments, key=len)
    period = 0
    if max_seasonal_order > 0:
        # a trend can hide the season from the periodogram: look again after one difference
        period = (find_period(longest, max_period=max_period)
                  or find_period(np.diff(longest), max_period=max_period))
    area_lags = min(max(lags, 2 * period), shortest // 4)
    if area_lags < 2:
        raise InsufficientDataError(f"segments of {shortest} samples are too short to stationarize")

    def area(op: Differencing) -> float:
        return acf_area([op.apply(s) for s in segments], area_lags)

    best = Differencing()
    best_area = raw_area = area(best)
    if period:
        for m2 in range(1, max_seasonal_order + 1):
            trial = Differencing(period, m2, 0)
            if trial.lost + area_lags + 2 >= shortest:
                break
            trial_area = area(trial)
            if trial_area * min_improvement > best_area:
                break
            best, best_area = trial, trial_area
    while best.order < max_order:
        if best.order >= 1 and adf_statistic(best.apply(longest)) < ADF_CRITICAL_5PCT:
            break  # no unit root left: a further difference would only over-difference
        trial = Differencing(best.period, best.seasonal_order, best.order + 1)
        trial_area = area(trial)
        if trial_area * min_improvement > best_area:
            break
        best, best_area = trial, trial_area
    statistic = adf_statistic(best.apply(longest))
    while statistic > ADF_CRITICAL_5PCT and best.order < max_order:
        best = Differencing(best.period, best.seasonal_order, best.order + 1)
        best_area = area(best)
        statistic = adf_statistic(best.apply(longest))
    if best.seasonal_order == 0:
        best = Differencing(0, 0, best.order)
    return DifferencingChoice(best, best_area, raw_area, statistic, period)
