"""White-box parameter estimation: chosen parameters of a model fitted to telemetry by least
squares on its k-step prediction error, with standard errors honest for autocorrelated errors.

The error is the level tier's (:mod:`graybox.level_tier`): every sample (one every
:func:`~graybox.level_tier.start_stride` samples) predicted by the white box from the full
state ``k`` samples earlier, with the observed inputs,

.. math:: e_c(t) = y_c(t) - \\hat y_c(t \\mid x(t - k), u).

A one-step error would carry a parameter's effect only over one sample, where the sensor
noise dominates it; ``k`` samples let the prediction drift from the data by the parameters'
whole effect on the dynamics (``k`` covers several of the model's time constants, 120 s at
most 12 analysis steps) while the start's sensor noise decays. Hidden states are estimated
again for every trial model (:func:`graybox.state_estimation.estimate_states`). Every
operating period is a segment; a prediction never crosses two.

The fit (``scipy.optimize.least_squares``, trust region reflective) runs twice: first with
each channel's errors scaled by their spread under the initial parameters, then weighted by
the first fit's error variance and effective sample size per channel, so that each channel
counts by its own noise and its own information.

**Standard errors.** The Gauss-Newton covariance ``(J^T W J)^-1``, with ``J`` the Jacobian of
the errors by the parameters and ``W`` per channel ``(N_eff / N) / sigma^2``: the usual
``sigma^2 (J^T J)^-1`` inflated by ``N / N_eff``, the effective-sample-size factor of the
fitted errors' autocorrelation (:func:`graybox.effective_samples.effective_sample_size`,
Geyer's initial positive sequence). Overlapping k-step predictions and a white box's slowly
varying model error make the errors strongly autocorrelated; ignoring it would make the
intervals several times too narrow. The inflation is exact for the mean of an AR-like error
and approximate for a regression slope (it treats the Jacobian's own autocorrelation as the
mean's); intervals are normal, ``value +- z sd``, or for a parameter the model declares
positive (:func:`positive_parameters`) normal in its log, ``value * exp(+- z sd / value)``
(:meth:`ParameterEstimate.interval`).
"""
from __future__ import annotations

from numbers import Real
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from graybox.effective_samples import effective_sample_size
from graybox.exceptions import GrayBoxError, InsufficientDataError, ModelSpecError
from graybox.integration import Integration
from graybox.level_tier import horizon_samples, level_data, start_stride
from graybox.models.base import WhiteBoxModel
from graybox.models.table import Table
from graybox.parameter_estimate import ParameterEstimate
from graybox.residual import infer_sample_interval
from graybox.state_estimation import estimate_states, window_arrays
from graybox.telemetry.window import window_periods

#: relative finite-difference step of the Jacobian (errors are smooth in the parameters, but
#: hidden states come from an inner fit whose tolerance sets a floor)
DIFF_STEP = 1e-6
#: a trial model that is invalid or diverges scores this, per error sample, in units of its
#: channel's scale: far worse than any valid model, so the trust region steps back
INVALID_ERROR = 1e3


def with_parameters(model: WhiteBoxModel, changes: Mapping[str, float]) -> WhiteBoxModel:
    """A model of the same class and column map with ``changes`` over its parameters.

    Raises
    ------
    ModelSpecError
        If a name is unknown or the values are physically invalid (``check_parameters``).
    """
    return type(model)(parameters={**model.parameters, **changes}, columns=model.columns)


def float_parameters(model: WhiteBoxModel) -> tuple[str, ...]:
    """The model's parameters that are numbers (not :class:`~graybox.models.table.Table`)."""
    return tuple(name for name, value in model.parameters.items() if not isinstance(value, Table))


def positive_parameters(model: WhiteBoxModel) -> tuple[str, ...]:
    """The model's number parameters that are positive by nature: its class attribute
    ``positive``, default every number parameter whose ``default_parameters`` value is > 0.

    Raises
    ------
    ModelSpecError
        If ``positive`` names something that is not a number parameter.
    """
    numbers = float_parameters(model)
    declared = getattr(model, "positive", None)
    if declared is None:
        defaults = type(model).default_parameters
        return tuple(n for n in numbers if isinstance(defaults.get(n), Real)
                     and not isinstance(defaults.get(n), bool) and defaults[n] > 0)
    wrong = [n for n in declared if n not in numbers]
    if wrong:
        raise ModelSpecError(f"{model.spec()}.positive names {wrong}, which are not number "
                             f"parameters: {', '.join(numbers)}")
    return tuple(declared)


def operating_segments(windows: Sequence) -> tuple[list[pd.DataFrame], float]:
    """Every operating period of ``windows`` (TelemetryWindow, DataFrame or a sequence of
    DataFrames each, as :class:`~graybox.signature_fit.FitRequest` takes them) and the sample
    interval in seconds."""
    frames = [frame for window in windows for frame in window_periods(window)]
    if not frames:
        raise InsufficientDataError("no operating period to estimate from")
    first = windows[0]
    interval = getattr(first, "sample_interval", None) or infer_sample_interval(frames[0].index)
    return frames, float(interval)


@dataclass(frozen=True)
class ErrorSetup:
    """How the k-step errors are computed: telemetry rate, decimation, horizon, stride.

    Attributes
    ----------
    sample_interval : float
        Seconds between telemetry samples.
    factor : int
        Every ``factor``-th sample is analysed (states are estimated at the telemetry rate).
    horizon : int
        ``k``, in analysis samples.
    stride : int
        Analysis samples between two predictions' starts.
    integration : Integration
    """

    sample_interval: float
    factor: int
    horizon: int
    stride: int
    integration: Integration

    @property
    def analysis_interval(self) -> float:
        return self.sample_interval * self.factor

    @classmethod
    def default(cls, sample_interval: float, analysis_interval: float | None = None,
                horizon: int | None = None, stride: int | None = None,
                integration: Integration | None = None) -> "ErrorSetup":
        """The level tier's choices at ``analysis_interval`` (default: the sample interval)."""
        factor = 1 if analysis_interval is None else max(1, round(analysis_interval
                                                                  / sample_interval))
        step = factor * sample_interval
        horizon = horizon or horizon_samples(step)
        return cls(sample_interval, factor, horizon, stride or start_stride(step, horizon),
                   integration or Integration())


def prediction_errors(model: WhiteBoxModel, segments: Sequence[tuple[np.ndarray, np.ndarray]],
                      setup: ErrorSetup, drift: Mapping[str, Sequence[str]] | None = None,
                      starts: Sequence[np.ndarray] | None = None,
                      states: Sequence | None = None
                      ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per output channel, the k-step prediction errors of ``model`` over ``segments``.

    Parameters
    ----------
    model : WhiteBoxModel
    segments : sequence of (y, u)
        Outputs (T, n_outputs) and inputs (T, n_inputs) of each operating period, at the
        telemetry rate (:func:`graybox.state_estimation.window_arrays`).
    setup : ErrorSetup
    drift : mapping of str to sequence of str, optional
        Per channel, the hidden states whose change is a feature (a baseline level tier's
        ``drifting``); default found in these segments
        (:func:`graybox.level_tier.drifting_states`).
    starts : sequence of ndarray, optional
        Per segment, its initial hidden state already fitted
        (:func:`graybox.state_estimation.initial_hidden_together`); default fitted here.
    states : sequence of WindowStates, optional
        Per segment, its full states already estimated at the telemetry rate
        (:func:`graybox.state_estimation.estimate_states` of this model, segment and
        integration); default estimated here.

    Returns
    -------
    dict of str to (errors, features, segment)
        As :func:`graybox.level_tier.level_data`: errors (N,), operating features (N, p) and
        the segment of each error.
    """
    if model.hidden_states and states is not None:
        states = [window.decimated(setup.factor) for window in states]
    elif model.hidden_states:
        starts = [None] * len(segments) if starts is None else starts
        states = [estimate_states(model, y, u, setup.sample_interval, setup.integration,
                                  start=start).decimated(setup.factor)
                  for (y, u), start in zip(segments, starts)]
    else:   # the states are the measurements: decimated first, the same at a tenth the copying
        states = [estimate_states(model, y[::setup.factor], u[::setup.factor],
                                  setup.sample_interval, setup.integration) for y, u in segments]
    return level_data(model, states, setup.analysis_interval, setup.horizon, setup.stride,
                      setup.integration, drift)


def _segment_pieces(values: np.ndarray, positions: np.ndarray) -> list[np.ndarray]:
    return [values[positions == p] for p in np.unique(positions)]


def channel_weights(errors: np.ndarray, positions: np.ndarray) -> tuple[float, float]:
    """RMS of a channel's errors and its effective sample size (segments kept apart)."""
    rms = float(np.sqrt(np.mean(errors ** 2)))
    centred = errors - errors.mean()
    return rms, effective_sample_size(_segment_pieces(centred, positions))


def estimate_parameters(model: WhiteBoxModel, windows: Sequence, names: Sequence[str],
                        initial: Mapping[str, float] | None = None, *,
                        analysis_interval: float | None = None, horizon: int | None = None,
                        stride: int | None = None, integration: Integration | None = None,
                        max_nfev: int = 100) -> ParameterEstimate:
    """Fit ``names`` of ``model`` to telemetry by least squares on the k-step prediction error.

    Parameters
    ----------
    model : WhiteBoxModel
        The white box; its other parameters stay as they are.
    windows : sequence
        Telemetry windows (TelemetryWindow, DataFrame, or sequence of DataFrames: the operating
        periods of one window), on a uniform grid.
    names : sequence of str
        The parameters to estimate (numbers, not tables). Choose an identifiable set: a model
        whose equation can be scaled through (the shaft's ``J``, ``a``, ``b + c``, ``d``)
        leaves one of them to be fixed.
    initial : mapping of str to float, optional
        Where the fit starts (default: the model's values).
    analysis_interval : float, optional
        Seconds between analysed samples (a multiple of the sample interval; default the
        sample interval).
    horizon, stride : int, optional
        ``k`` and the samples between two predictions (default the level tier's at the
        analysis interval: 120 s at most 12 steps, a start every 10 s).
    integration : Integration, optional
        Default RK4 with 2 sub-steps.
    max_nfev : int, default 100
        Evaluations of each least-squares pass.

    Returns
    -------
    ParameterEstimate

    Raises
    ------
    ModelSpecError
        If a name is not a number parameter of the model, or the start is invalid.
    InsufficientDataError
        If no segment is longer than the horizon.
    """
    names = tuple(names)
    known = float_parameters(model)
    unknown = [n for n in names if n not in known]
    if unknown or not names:
        raise ModelSpecError(f"{model.spec()}: cannot estimate {unknown or '(nothing)'}; "
                             f"number parameters: {', '.join(known)}")
    start = {n: float((initial or {}).get(n, model.parameters[n])) for n in names}
    frames, interval = operating_segments(windows)
    segments = [window_arrays(model, frame) for frame in frames]
    setup = ErrorSetup.default(interval, analysis_interval, horizon, stride, integration)
    x0 = np.array([start[n] for n in names])
    scale = np.where(x0 != 0, np.abs(x0), 1.0)
    channels = model.outputs

    def errors_at(delta: np.ndarray):
        trial = with_parameters(model, dict(zip(names, x0 + scale * delta)))
        data = prediction_errors(trial, segments, setup)
        return [data[c][0] for c in channels], data[channels[0]][2]

    first, positions = errors_at(np.zeros(len(names)))
    finite = [np.isfinite(e) for e in first]
    if min(int(f.sum()) for f in finite) <= len(names) + 2:
        raise InsufficientDataError(f"too few finite k-step errors to estimate {names}")

    def residual(delta: np.ndarray, weights: np.ndarray) -> np.ndarray:
        try:
            errors, _ = errors_at(delta)
            parts = [np.nan_to_num(e[f], nan=INVALID_ERROR * s, posinf=INVALID_ERROR * s,
                                   neginf=-INVALID_ERROR * s) * w
                     for e, f, w, s in zip(errors, finite, weights, 1 / weights)]
        except (GrayBoxError, FloatingPointError):
            parts = [np.full(int(f.sum()), INVALID_ERROR) for f in finite]
        return np.concatenate(parts)

    spread = np.array([max(float(np.std(e[f])), 1e-12) for e, f in zip(first, finite)])
    delta, fit = np.zeros(len(names)), None
    weights = 1 / spread
    for _ in range(2):
        fit = least_squares(residual, delta, args=(weights,), method="trf",
                            diff_step=DIFF_STEP, max_nfev=max_nfev)
        delta = fit.x
        errors, positions = errors_at(delta)
        stats_ = [channel_weights(e[f], positions[f]) for e, f in zip(errors, finite)]
        new = np.array([np.sqrt(n_eff / f.sum()) / max(rms, 1e-300)
                        for (rms, n_eff), f in zip(stats_, finite)])
        jacobian = fit.jac * np.repeat(new / weights, [int(f.sum()) for f in finite])[:, None]
        weights = new
    covariance_delta = np.linalg.pinv(jacobian.T @ jacobian)
    covariance = covariance_delta * np.outer(scale, scale)
    values = x0 + scale * delta
    positive = positive_parameters(model)
    return ParameterEstimate(
        names, tuple(map(float, values)), tuple(float(np.sqrt(max(v, 0.0)))
                                                for v in np.diag(covariance)),
        tuple(tuple(map(float, row)) for row in covariance), tuple(map(float, x0)),
        tuple(channels), tuple(rms for rms, _ in stats_), int(setup.horizon),
        int(sum(f.sum() for f in finite)), float(sum(n for _, n in stats_)),
        bool(fit.status > 0), tuple(name in positive for name in names))
