"""The analysis interval: the rate at which the tiers see the residual, chosen from the data.

Telemetry sampled much faster than the plant moves (1 Hz for a shaft that settles in a
quarter of a minute) gives a one-step residual dominated by differenced sensor noise: every
step's model error is tiny next to it, the AR tier needs its whole order cap to describe a
nearly non-invertible moving average, and a fault that changes the dynamics is lost (at 1 Hz
the friction fault that 10-s telemetry shows clearly was missed). Sampling slower than the
plant moves is not this module's concern: the tiers then work at the telemetry's interval.

**Criterion.** The white box is linearised at operating points of the data (states and
inputs of up to :data:`OPERATING_POINTS` evenly spaced samples): the Jacobian ``df/dx``
by central differences, and its eigenvalues. The fastest rate ``r`` is the 90th percentile
over the points of the largest eigenvalue magnitude, and the target interval is
``fraction / r`` (half the fastest time constant by default: two analysis samples per time
constant resolve the dynamics). The analysis interval is the largest whole multiple ``q`` of
the sample interval not above the target (``q = 1`` keeps the telemetry's rate). A model
without dynamics in its states (``r = 0``) keeps the native rate.

**Enough samples.** Decimation trades samples for signal: a slow plant (a heated room whose
envelope settles in hours) would be left with a few dozen residual samples a day, too few to
estimate anything. ``q`` is therefore also capped so that every baseline window keeps the
analysis samples its tiers and their calibration need (``calibration_splits`` pieces of
``min_samples``, see :meth:`graybox.settings.GrayBoxSettings.samples_per_window`): where the
dynamics ask for more decimation than the data can pay for, the tiers see more, noisier
samples rather than too few.

**Decimation.** The residual is cut into consecutive blocks of ``q`` samples and each block
is replaced by its mean. For the one-step residual this is the residual over the analysis
interval: the sub-steps' one-step errors add up to the error over the whole interval (to
first order in the model error), so the block sum (the mean up to the factor ``q``, which
the tiers' standardisation removes) is what the plant's model missed over ``q`` samples. As
a filter the block mean is a boxcar, whose zeros lie at the new sampling rate and its
multiples: what would alias onto the slow band the tiers model is suppressed. The inverse
residual (a rate) is averaged the same way. Samples left over at the end of a window (fewer
than ``q``) are dropped.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

from graybox.integration import Integration
from graybox.models.base import WhiteBoxModel
from graybox.state_estimation import WindowStates, estimate_states, window_arrays
from graybox.residual import infer_sample_interval

OPERATING_POINTS = 64
#: the analysis interval the dynamics ask for, in fastest time constants
ANALYSIS_FRACTION = 0.5


def fastest_rate(model: WhiteBoxModel, frames: Sequence[pd.DataFrame],
                 points: int = OPERATING_POINTS, quantile: float = 0.9) -> float:
    """The fastest rate (1/s) of the white box's linearised dynamics at the data's points.

    Parameters
    ----------
    model : WhiteBoxModel
    frames : sequence of DataFrame or WindowStates
        Telemetry with the model's columns, or segments whose full state is estimated.
    points : int
        Operating points taken, evenly spaced over all frames.
    quantile : float
        Quantile over the points of each point's largest eigenvalue magnitude.

    Returns
    -------
    float
        0 when the model has no state dynamics (or they cannot be evaluated).
    """
    return largest_rate(linearised_eigenvalues(model, frames, points), quantile)


def largest_rate(eigenvalues: np.ndarray | None, quantile: float = 0.9) -> float:
    """:func:`fastest_rate` from :func:`linearised_eigenvalues`' output (0 for None)."""
    if eigenvalues is None:
        return 0.0
    return float(np.quantile(np.abs(eigenvalues).max(axis=1), quantile))


def integrates(eigenvalues: np.ndarray | None) -> bool:
    """Whether the white box has a mode that never decays: at every point of
    :func:`linearised_eigenvalues`' output, an eigenvalue with zero real part (a tank's
    volume counted from its flows, a receiver's pressure). False for None."""
    if eigenvalues is None:
        return False
    scale = np.abs(eigenvalues).max(axis=1, keepdims=True)
    return bool((np.abs(eigenvalues.real) <= 1e-9 * scale).any(axis=1).all())


def linearised_eigenvalues(model: WhiteBoxModel, frames: Sequence[pd.DataFrame],
                           points: int = OPERATING_POINTS) -> np.ndarray | None:
    """Eigenvalues of ``df/dx`` (central differences) at up to ``points`` operating points
    of the data, evenly spaced over all frames: shape (points, states). None when no sample
    is finite or the Jacobian is not."""
    windows = [_full_states(model, f) for f in frames]
    x = np.concatenate([w.states for w in windows])
    u = np.concatenate([w.u for w in windows])
    finite = np.isfinite(x).all(axis=1) & np.isfinite(u).all(axis=1)
    x, u = x[finite], u[finite]
    if len(x) == 0:
        return None
    take = np.unique(np.linspace(0, len(x) - 1, min(points, len(x))).round().astype(int))
    x, u = x[take], u[take]
    n = x.shape[1]
    jacobian = np.empty((len(x), n, n))
    for j in range(n):
        step = 1e-6 * np.maximum(1.0, np.abs(x[:, j]))
        up, down = x.copy(), x.copy()
        up[:, j] += step
        down[:, j] -= step
        jacobian[:, :, j] = (model.derivatives(up, u) - model.derivatives(down, u)) / (2 * step)[:, None]
    if not np.isfinite(jacobian).all():
        return None
    return np.linalg.eigvals(jacobian)


def _full_states(model: WhiteBoxModel, frame) -> WindowStates:
    if isinstance(frame, WindowStates):
        return frame
    y, u = window_arrays(model, frame)
    interval = infer_sample_interval(frame.index) if model.hidden_states else 1.0
    return estimate_states(model, y, u, interval, Integration())


def choose_analysis_interval(model: WhiteBoxModel, frames: Sequence[pd.DataFrame],
                             sample_interval: float, fraction: float = ANALYSIS_FRACTION,
                             shortest_window: int | None = None, samples_needed: int = 0) -> float:
    """The analysis interval in seconds: a whole multiple of ``sample_interval``.

    Parameters
    ----------
    model : WhiteBoxModel
    frames : sequence of DataFrame or WindowStates
        The baseline's telemetry windows (or their segments' full states).
    sample_interval : float
        Seconds between telemetry samples.
    fraction : float, default 0.5
        Target interval as a fraction of the fastest time constant.
    shortest_window : int, optional
        Telemetry samples (operating samples) of the baseline's shortest window.
    samples_needed : int, default 0
        Analysis samples every window must keep for the tiers and their calibration
        (:meth:`graybox.settings.GrayBoxSettings.samples_per_window`): the decimation never
        goes further than ``shortest_window // samples_needed``, so a slow plant is not
        starved of samples by its own time constants.

    Returns
    -------
    float
    """
    rate = fastest_rate(model, frames)
    if not rate > 0:
        return float(sample_interval)
    factor = max(1, int(np.floor(fraction / rate / sample_interval + 1e-9)))
    if shortest_window is not None and samples_needed > 0:
        factor = min(factor, max(1, shortest_window // samples_needed))
    return float(factor * sample_interval)


def decimation_factor(analysis_interval: float, sample_interval: float) -> int:
    """``q``: telemetry samples per analysis sample."""
    factor = int(round(analysis_interval / sample_interval))
    if factor < 1 or abs(factor * sample_interval - analysis_interval) > 1e-6 * analysis_interval:
        raise ValueError(f"analysis interval {analysis_interval} s is not a whole multiple of "
                         f"the sample interval {sample_interval} s")
    return factor


def decimate(residual: np.ndarray, factor: int) -> np.ndarray:
    """Block means of ``factor`` consecutive samples (along the first axis); the tail that
    does not fill a block is dropped."""
    residual = np.asarray(residual, dtype=float)
    if factor == 1:
        return residual
    blocks = len(residual) // factor
    return residual[: blocks * factor].reshape(blocks, factor, *residual.shape[1:]).mean(axis=1)
