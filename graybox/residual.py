"""Residual generation: the physics model used as a filter (the white box), Eqs. 1-3 and 13.

Both forms work on a whole uniform-grid window at once and on any number of state channels.
The residual is deliberately kept simple (not made robust): its structure is what the three
tiers model.
"""
from __future__ import annotations

from typing import Literal

import numpy as np
import pandas as pd
from scipy.signal import savgol_filter

from graybox.exceptions import InsufficientDataError
from graybox.models.base import WhiteBoxModel
from graybox.rk4 import rk4_step

ResidualMethod = Literal["one_step", "inverse"]
RESIDUAL_METHODS = ("one_step", "inverse")


def one_step_residual(model: WhiteBoxModel, x: np.ndarray, u: np.ndarray, dt: float,
                      substeps: int = 2) -> np.ndarray:
    """Residual ``r(t) = x*(t) - x^*(t)`` of Eqs. 2-3.

    ``x^*(t)`` integrates ``dx/dt = f(x, u)`` with classical RK4 over one sample, starting from
    the observed state ``x*(t - dt)``; inputs are interpolated linearly inside the sample.
    Every step starts from observed data, so all steps are computed at once.

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
        RK4 steps per sample.

    Returns
    -------
    ndarray of shape (T - 1, n_states)
        The residual at samples 1..T-1.
    """
    x = np.asarray(x, dtype=float)
    u = np.asarray(u, dtype=float).reshape(len(x), -1)
    if len(x) < 2:
        raise InsufficientDataError("the one-step residual needs at least 2 samples")
    state = x[:-1].copy()
    u0, u1 = u[:-1], u[1:]
    h = dt / substeps
    for step in range(substeps):
        begin = step / substeps
        ua = u0 + (u1 - u0) * begin
        um = u0 + (u1 - u0) * (begin + 0.5 / substeps)
        ub = u0 + (u1 - u0) * (begin + 1.0 / substeps)
        state = rk4_step(model.derivatives, state, ua, um, ub, h)
    return x[1:] - state


def inverse_residual(model: WhiteBoxModel, x: np.ndarray, u: np.ndarray, dt: float,
                     window: int = 7, polyorder: int = 3) -> np.ndarray:
    """Residual ``Gamma(t) = dx*/dt - f(x*, u)`` of Eq. 13 (the inverse form).

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
    x = np.asarray(x, dtype=float)
    u = np.asarray(u, dtype=float).reshape(len(x), -1)
    if len(x) < window:
        raise InsufficientDataError(f"the inverse residual needs at least {window} samples")
    derivative = savgol_filter(x, window, polyorder, deriv=1, delta=dt, axis=0, mode="interp")
    return derivative - model.derivatives(x, u)


def residual_frame(model: WhiteBoxModel, frame: pd.DataFrame, method: ResidualMethod = "one_step",
                   sample_interval: float | None = None, derivative_window: int = 7
                   ) -> pd.DataFrame:
    """Residual of a uniform-grid telemetry frame, one column per model state.

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

    Returns
    -------
    DataFrame
        Indexed by timestamp (the first sample is dropped by ``"one_step"``), columns named
        after the model's states.
    """
    if method not in RESIDUAL_METHODS:
        raise ValueError(f"residual method must be one of {RESIDUAL_METHODS}, got {method!r}")
    model.check_columns(frame.columns)
    if sample_interval is None:
        sample_interval = infer_sample_interval(frame.index)
    x = frame.loc[:, list(model.state_columns)].to_numpy(dtype=float)
    u = frame.loc[:, list(model.input_columns)].to_numpy(dtype=float).reshape(len(frame), -1)
    if method == "one_step":
        values, index = one_step_residual(model, x, u, sample_interval), frame.index[1:]
    else:
        values = inverse_residual(model, x, u, sample_interval, window=derivative_window)
        index = frame.index
    return pd.DataFrame(values, index=index, columns=list(model.states))


def infer_sample_interval(index: pd.DatetimeIndex) -> float:
    """Seconds between consecutive samples of a uniform-grid index."""
    if len(index) < 2:
        raise InsufficientDataError("cannot infer a sample interval from fewer than 2 samples")
    steps = np.diff(index.as_unit("ns").asi8) / 1e9   # pandas may store us or s ticks
    return float(np.median(steps))
