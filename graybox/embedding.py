"""Takens embedding parameters from data: the delay ``tau`` and the dimension ``m`` (Eq. 15).

``tau`` is the first minimum of the average mutual information (Fraser and Swinney, 1986);
``m`` is the smallest dimension without false nearest neighbours (Kennel, Brown and
Abarbanel, 1992).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from graybox.autocovariance import autocovariance


def delay_vectors(x: np.ndarray, dim: int, tau: int) -> np.ndarray:
    """Rows ``[x(t), x(t - tau), ..., x(t - (dim - 1) tau)]`` for every ``t`` with a full history."""
    x = np.asarray(x, dtype=float)
    span = (dim - 1) * tau
    n = len(x) - span
    return np.column_stack([x[span - k * tau: span - k * tau + n] for k in range(dim)])


def mutual_information(x: np.ndarray, lag: int, bins: int = 32) -> float:
    """Average mutual information (nats) between ``x(t)`` and ``x(t + lag)``, equal-width bins."""
    x = np.asarray(x, dtype=float)
    low, high = x.min(), x.max()
    if high <= low:
        return 0.0
    codes = np.minimum(((x - low) / (high - low) * bins).astype(np.int64), bins - 1)
    a, b = codes[:-lag], codes[lag:]
    joint = np.bincount(a * bins + b, minlength=bins * bins).reshape(bins, bins) / len(a)
    pa, pb = joint.sum(axis=1), joint.sum(axis=0)
    nonzero = joint > 0
    return float(np.sum(joint[nonzero] * np.log(joint[nonzero] / np.outer(pa, pb)[nonzero])))


def choose_delay(x: np.ndarray, max_delay: int = 50, bins: int = 32,
                 smooth_correlation: float = 0.5) -> int:
    """The delay ``tau``: the first minimum of the average mutual information.

    The mutual-information minimum (Fraser and Swinney) is a rule for a sampled flow, a smooth
    series whose consecutive samples are strongly correlated. A series that is not smooth at
    the sampling step (lag-1 autocorrelation below ``smooth_correlation`` in magnitude), such
    as white noise, a map, or the residual of an AR model, gets ``tau = 1``: its delay
    coordinates are already as independent as they will be. When the information of a smooth
    series decays without a minimum, ``tau`` is the first lag where it falls below ``1/e`` of
    its lag-1 value.

    Parameters
    ----------
    x : ndarray
    max_delay : int, default 50
    bins : int, default 32
    smooth_correlation : float, default 0.5
    """
    x = np.asarray(x, dtype=float)
    gamma = autocovariance([x], 1)
    if gamma[0] == 0 or abs(gamma[1] / gamma[0]) < smooth_correlation:
        return 1
    information = np.array([mutual_information(x, lag, bins) for lag in range(1, max_delay + 2)])
    for lag in range(1, max_delay):
        if information[lag] < information[lag - 1] and information[lag] <= information[lag + 1]:
            return lag + 1
    below = np.flatnonzero(information < information[0] / np.e)
    return int(below[0]) + 1 if below.size else max_delay


def false_nearest_fraction(x: np.ndarray, dim: int, tau: int, ratio: float = 10.0,
                           size_tolerance: float = 2.0, max_points: int = 4000) -> float:
    """Fraction of false nearest neighbours going from ``dim`` to ``dim + 1`` dimensions.

    A neighbour is false when adding the next delay coordinate stretches its distance by more
    than ``ratio`` times (Kennel's first test) or beyond ``size_tolerance`` times the series'
    standard deviation (the second test, which keeps noise from looking low-dimensional).
    """
    x = np.asarray(x, dtype=float)
    embedded = delay_vectors(x, dim + 1, tau)
    if len(embedded) > max_points:
        embedded = embedded[np.linspace(0, len(embedded) - 1, max_points).astype(int)]
    base, extra = embedded[:, :dim], embedded[:, dim]
    distance, index = cKDTree(base).query(base, k=2)
    distance, index = distance[:, 1], index[:, 1]
    stretch = np.abs(extra - extra[index])
    valid = distance > 0
    first = stretch[valid] / distance[valid] > ratio
    second = np.sqrt(distance[valid] ** 2 + stretch[valid] ** 2) / (x.std() + 1e-300) > size_tolerance
    return float(np.mean(first | second)) if valid.any() else 0.0


def choose_dimension(x: np.ndarray, tau: int, max_dim: int = 8, threshold: float = 0.05,
                     min_drop: float = 0.02) -> int:
    """The embedding dimension ``m``: the smallest with few false nearest neighbours.

    Returns the first ``m`` whose false-neighbour fraction is below ``threshold``, or, when the
    fraction levels off above it (noise), the first ``m`` after which it falls by less than
    ``min_drop``; at most ``max_dim``.
    """
    previous = None
    for dim in range(1, max_dim + 1):
        fraction = false_nearest_fraction(x, dim, tau)
        if fraction < threshold:
            return dim
        if previous is not None and previous - fraction < min_drop:
            return dim - 1
        previous = fraction
    return max_dim
