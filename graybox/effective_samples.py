"""The effective sample size of an autocorrelated series: how many independent samples its
mean is worth.

Standard errors of a least-squares fit to prediction errors assume independent errors; the
k-step errors of overlapping predictions, and a white box's slowly varying model error, are
strongly autocorrelated, so those standard errors are too small by ``sqrt(N / N_eff)``. The
estimator here is Geyer's initial positive sequence (Geyer 1992, "Practical Markov chain Monte
Carlo"): the integrated autocorrelation time ``tau = 1 + 2 sum_k rho_k`` summed over pairs
``rho_2m + rho_2m+1`` while they stay positive, which needs no lag window to be chosen.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from graybox.autocovariance import autocovariance

#: largest lag summed, as a fraction of the series (beyond it the estimates are noise)
MAX_LAG_FRACTION = 0.25


def effective_sample_size(segments: Sequence[np.ndarray] | np.ndarray) -> float:
    """``N / tau``, with ``tau`` the integrated autocorrelation time of the pooled series.

    Parameters
    ----------
    segments : ndarray or sequence of ndarray
        Contiguous pieces of one series (lag products never cross their borders), each
        centred on the pooled mean.

    Returns
    -------
    float
        Between 1 and ``N``: a negatively autocorrelated series counts as ``N`` (never more,
        so the correction only ever widens an interval).
    """
    if isinstance(segments, np.ndarray) and segments.ndim == 1:
        segments = [segments]
    segments = [np.asarray(s, dtype=float) for s in segments if len(s)]
    total = sum(len(s) for s in segments)
    if total < 4:
        return float(max(total, 1))
    max_lag = max(2, int(MAX_LAG_FRACTION * max(len(s) for s in segments)))
    acov = autocovariance(segments, max_lag, method="fft")
    if acov[0] <= 0:
        return float(total)
    return float(np.clip(total / integrated_time(acov / acov[0]), 1.0, total))


def integrated_time(rho: np.ndarray) -> float:
    """Geyer's initial positive sequence over autocorrelations ``rho_0 = 1, rho_1, ...``: ``1
    + 2 sum_k rho_k``, summed over pairs ``rho_2m + rho_2m+1`` while they stay positive; at
    least 1."""
    rho = np.append(rho, 0.0 if len(rho) % 2 else [])
    pairs = rho[0::2] + rho[1::2]
    stop = int(np.argmax(pairs <= 0)) if np.any(pairs <= 0) else len(pairs)
    return max(1.0, -1.0 + 2.0 * float(pairs[:stop].sum()))
