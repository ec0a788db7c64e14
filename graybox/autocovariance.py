"""Sample autocovariance of a series given in contiguous pieces, and its autocorrelation.

Every tier, the stationarity search and the residual plots use these two functions, so that
there is one estimator: the biased one (lag-``k`` products summed, divided by the number of
samples, not by the number of products), pooled over segments, with lag products never
crossing a segment border.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np


def autocovariance(segments: Sequence[np.ndarray], max_lag: int, mean: float | None = None,
                   method: str = "direct") -> np.ndarray:
    """Pooled biased autocovariances ``gamma_0..gamma_max_lag``.

    ``gamma_k = sum over segments of sum_t c_t c_{t+k} / N`` where ``c = segment - mean`` and
    ``N`` is the total number of samples in all segments; a segment of ``k`` samples or fewer
    adds nothing to ``gamma_k``.

    Parameters
    ----------
    segments : sequence of ndarray
        Contiguous pieces of one series (lag products never cross their borders).
    max_lag : int
        Largest lag.
    mean : float, optional
        The centre subtracted from every segment. Default: the pooled mean of all segments,
        ``sum(segment.sum()) / N``.
    method : {"direct", "fft"}, default "direct"
        ``"direct"``: one dot product per lag and segment (cheap for a few lags);
        ``"fft"``: per segment through a zero-padded FFT of length the power of two
        ``>= 2 len - 1`` (cheap for many lags). The two agree to rounding.

    Returns
    -------
    ndarray of shape (max_lag + 1,)

    Raises
    ------
    ValueError
        For an unknown ``method`` or when ``segments`` holds no sample.
    """
    if method not in ("direct", "fft"):
        raise ValueError(f"method must be 'direct' or 'fft', got {method!r}")
    segments = [np.asarray(s, dtype=float) for s in segments]
    total = sum(len(s) for s in segments)
    if total == 0:
        raise ValueError("no samples to compute an autocovariance from")
    if mean is None:
        mean = sum(s.sum() for s in segments) / total
    acov = np.zeros(max_lag + 1)
    for s in segments:
        c = s - mean
        if method == "fft":
            size = 1 << int(np.ceil(np.log2(2 * len(c) - 1)))
            spectrum = np.fft.rfft(c, size)
            # the padded transform is circular: lags of len(c) and beyond are wrap-around
            products = np.fft.irfft(spectrum * np.conj(spectrum), size)[: min(max_lag + 1, len(c))]
            acov[: len(products)] += products
        else:
            for k in range(min(max_lag + 1, len(c))):
                acov[k] += np.dot(c[k:], c[: len(c) - k])
    return acov / total


def autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation ``rho_0..rho_max_lag`` of one series (biased, by FFT).

    Parameters
    ----------
    x : ndarray
        The series, centred on its own mean.
    max_lag : int

    Returns
    -------
    ndarray of shape (max_lag + 1,)
        ``gamma_k / gamma_0`` (:func:`autocovariance`, ``method="fft"``); all zeros for a
        constant series.
    """
    acov = autocovariance([x], max_lag, method="fft")
    if acov[0] <= 0:
        return np.zeros(max_lag + 1)
    return acov / acov[0]
