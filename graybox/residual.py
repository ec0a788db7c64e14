"""Residual generation: the physics model used as a filter (the white box), Eqs. 1-3 and 13.

Both forms work on a whole uniform-grid window at once and on any number of output channels;
hidden states come from :mod:`graybox.state_estimation`.
The residual is deliberately kept simple (not made robust): its structure is what the three
tiers model.
"""
from __future__ import annotations

from typing import Literal

import numpy as np
import pandas as pd

from graybox.exceptions import InsufficientDataError
from graybox.models.base import WhiteBoxModel
from graybox.integration import Integration, advance, check_finite_outputs
from graybox.state_estimation import (WindowStates, check_prediction, estimate_states,
                                      predict_one_step, window_arrays)

ResidualMethod = Literal["one_step", "inverse"]
RESIDUAL_METHODS = ("one_step", "inverse")


def one_step_residual(model: WhiteBoxModel, x: np.ndarray, u: np.ndarray, dt: float,
                      substeps: int = 2, integration: Integration | None = None) -> np.ndarray:
    """Residual ``r(t) = x*(t) - x^*(t)`` of Eqs. 2-3, for a model whose states are all
    measured.

    ``x^*(t)`` integrates ``dx/dt = f(x, u)`` over one sample (:func:`graybox.integration.advance`),
    starting from the observed state ``x*(t - dt)``; inputs are interpolated linearly inside
    the sample. Every step starts from observed data, so all steps are computed at once.

    Parameters
    ----------
    model : WhiteBoxModel
    x : ndarray of shape (T, n_states)
        Observed states on a uniform grid.
    u : ndarray of shape (T, n_inputs)
        Observed inputs on the same grid.
    dt : float
        Sample interval in seconds.
    substeps : int, default 2
        RK4 steps per sample (when ``integration`` is not given).
    integration : Integration, optional
        Method and sub-steps; default RK4 with ``substeps``.

    Returns
    -------
    ndarray of shape (T - 1, n_states)
        The residual at samples 1..T-1.
    """
    x = np.asarray(x, dtype=float)
    u = np.asarray(u, dtype=float).reshape(len(x), -1)
    if len(x) < 2:
        raise InsufficientDataError("the one-step residual needs at least 2 samples")
    integration = integration or Integration("rk4", substeps)
    return x[1:] - advance(model.derivatives, x[:-1], u[:-1], u[1:], dt, integration)


def output_residual(model: WhiteBoxModel, window: WindowStates, dt: float,
                    integration: Integration = Integration()) -> np.ndarray:
    """The one-step residual of every output, hidden states and feed-through included.

    A model whose outputs are all states gets Eqs. 2-3 as they stand. A model with computed
    outputs ``y = g(x, u)`` gets the measured change of each output minus its predicted
    change,

    .. math:: r(t) = y^*(t) - y^*(t-1) - [g(\\hat x(t \\mid t-1), u(t)) - g(\\hat x(t-1), u(t-1))],

    with ``\\hat x(t-1)`` the estimated full state (:mod:`graybox.state_estimation`). For a
    measured state it reduces to Eq. 3; for a computed output it is the prediction of the
    output's change over one sample, which an error of the hidden states' level enters only
    through the slope of ``g`` (the ohmic step ``R0 * delta i`` of a battery's voltage is
    predicted, the open-circuit voltage's slow drift is not differenced away twice).

    Returns
    -------
    ndarray of shape (T - 1, n_outputs)
    """
    predicted = predict_one_step(model, window.states, window.u, dt, integration)
    if all(name in model.states for name in model.outputs):
        predicted_y = model.output(predicted, window.u[1:])
        check_prediction(model, window.y[1:], predicted_y, "one-step prediction")
        return window.y[1:] - predicted_y
    before = model.output(window.states[:-1], window.u[:-1])
    after = model.output(predicted, window.u[1:])
    check_finite_outputs(model, window.states[:-1], window.u[:-1], before)
    check_finite_outputs(model, predicted, window.u[1:], after)
    check_prediction(model, window.y[1:], window.y[:-1] + after - before, "one-step prediction")
    return (window.y[1:] - window.y[:-1]) - (after - before)


def inverse_residual(model: WhiteBoxModel, x: np.ndarray, u: np.ndarray, dt: float,
                     window: int = 7, polyorder: int = 3) -> np.ndarray:
    """Residual ``Gamma(t) = dx*/dt - f(x*, u)`` of Eq. 13 (the inverse form), for a model
    whose states are all measured.

    The derivative is a Savitzky-Golay derivative (a local polynomial fit), which is robust to
    sensor noise where a plain difference would amplify it.

    Parameters
    ----------
    model : WhiteBoxModel
    x, u : ndarray
        Observed states (T, n_states) and inputs (T, n_inputs) on a uniform grid.
    dt : float
        Sample interval in seconds.
    window : int, default 7
        Savitzky-Golay window in samples (odd).
    polyorder : int, default 3
        Order of the local polynomial.

    Returns
    -------
    ndarray of shape (T, n_states)
    """
    # scipy.signal imports scipy.stats (0.5 s together): only the inverse form needs it
    from scipy.signal import savgol_filter

    x = np.asarray(x, dtype=float)
    u = np.asarray(u, dtype=float).reshape(len(x), -1)
    if len(x) < window:
        raise InsufficientDataError(f"the inverse residual needs at least {window} samples")
    derivative = savgol_filter(x, window, polyorder, deriv=1, delta=dt, axis=0, mode="interp")
    return derivative - model.derivatives(x, u)


def inverse_output_residual(model: WhiteBoxModel, window: WindowStates, dt: float,
                            derivative_window: int = 7, polyorder: int = 3) -> np.ndarray:
    """Eq. 13 for outputs: ``dy*/dt - dg/dt``, with ``dg/dt = (dg/dx) f(x, u) + (dg/du) du/dt``
    at the estimated full state (a directional difference); Eq. 13 itself where the outputs
    are all states.

    Returns
    -------
    ndarray of shape (T, n_outputs)
    """
    if all(name in model.states for name in model.outputs):
        measured = [model.states.index(name) for name in model.outputs]
        full = inverse_residual(model, window.states, window.u, dt, derivative_window, polyorder)
        return full[:, measured]
    from scipy.signal import savgol_filter

    if len(window.y) < derivative_window:
        raise InsufficientDataError(f"the inverse residual needs at least {derivative_window} "
                                    f"samples")
    derivative = savgol_filter(window.y, derivative_window, polyorder, deriv=1, delta=dt,
                               axis=0, mode="interp")
    rate_u = (savgol_filter(window.u, derivative_window, polyorder, deriv=1, delta=dt, axis=0,
                            mode="interp") if window.u.shape[1] else window.u)
    epsilon = 1e-6 * dt
    x, u = window.states, window.u
    moved = model.output(x + epsilon * model.derivatives(x, u), u + epsilon * rate_u)
    return derivative - (moved - model.output(x, u)) / epsilon


def residual_frame(model: WhiteBoxModel, frame: pd.DataFrame, method: ResidualMethod = "one_step",
                   sample_interval: float | None = None, derivative_window: int = 7,
                   integration: Integration = Integration(),
                   window: WindowStates | None = None) -> pd.DataFrame:
    """Residual of a uniform-grid telemetry frame, one column per model output.

    Parameters
    ----------
    model : WhiteBoxModel
    frame : DataFrame
        Indexed by UTC timestamps on a uniform grid, with the model's columns.
    method : {"one_step", "inverse"}
        Eqs. 2-3 or Eq. 13.
    sample_interval : float, optional
        Seconds between samples; inferred from the index when omitted.
    derivative_window : int, default 7
        Savitzky-Golay window in samples of ``"inverse"`` (odd).
    integration : Integration, optional
        How the white box is integrated over a sample (default RK4, 2 sub-steps).
    window : WindowStates, optional
        The frame's full state, when already estimated (:func:`estimate_states`).

    Returns
    -------
    DataFrame
        Indexed by timestamp (the first sample is dropped by ``"one_step"``), columns named
        after the model's outputs.
    """
    if method not in RESIDUAL_METHODS:
        raise ValueError(f"residual method must be one of {RESIDUAL_METHODS}, got {method!r}")
    if sample_interval is None:
        sample_interval = infer_sample_interval(frame.index)
    if window is None:   # window_arrays checks the frame's columns
        window = estimate_states(model, *window_arrays(model, frame), sample_interval, integration)
    if method == "one_step":
        values = output_residual(model, window, sample_interval, integration)
        index = frame.index[1:]
    else:
        values = inverse_output_residual(model, window, sample_interval, derivative_window)
        index = frame.index
    return pd.DataFrame(values, index=index, columns=list(model.outputs))


def infer_sample_interval(index: pd.DatetimeIndex) -> float:
    """Seconds between consecutive samples of a uniform-grid index."""
    if len(index) < 2:
        raise InsufficientDataError("cannot infer a sample interval from fewer than 2 samples")
    steps = np.diff(index.as_unit("ns").asi8) / 1e9   # pandas may store us or s ticks
    return float(np.median(steps))
