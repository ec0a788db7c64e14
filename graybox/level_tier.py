"""The level tier: each channel's level against the white box's k-step prediction, per
operating condition.

A sensor bias ``b`` is invisible to the one-step residual ``x(t+1) - f(x(t))``: the offset
enters the prediction's starting point too, so only ``(1 - J) b`` is left (``J`` the
one-step Jacobian), and differencing removes even that. A prediction started ``k`` samples
earlier forgets its start (``J^k b`` vanishes once ``k`` spans a few of the model's time
constants), so the k-step prediction error

.. math:: e(t) = x^*(t) - \\hat x(t \\mid x^*(t - k), u)

carries the whole bias. With a wrong white box it also carries the model error, which
depends on the operating condition and so moves with each night's load. The tier therefore
regresses ``e`` on the operating condition (the prediction itself and the inputs, centred at
the baseline's means) and keeps the intercept: the channel's level at the baseline's
operating point. Candidates keep the baseline's centre and slopes and refit only the level,
the mean error after the baseline's operating-condition share is taken out. A bias step
moves it by ``b``; a night at another load does not, as long as the baseline's relation
holds there.

``k`` (:func:`level_horizon`, recorded by the baseline): 120 s, at most 12 steps (several time
constants of the shaft models); where the analysis interval is capped below what the white
box's dynamics ask for (a slow plant logged every minute), 12 of the intervals they ask for,
within the baseline's segments and calibration pieces. Cost: ``k`` RK4 integrations of a whole window at
once (vectorized over time), started every 10 s or every twelfth of the horizon, plus one
small least-squares fit per channel.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Mapping, Sequence

import numpy as np
import pandas as pd

from graybox.analysis_rate import ANALYSIS_FRACTION
from graybox.exceptions import InsufficientDataError
from graybox.models.base import WhiteBoxModel
from graybox.integration import Integration, advance, jacobian
from graybox.operating_conditions import OperatingConditions
from graybox.state_estimation import (WindowStates, check_prediction, estimate_states,
                                      window_arrays)

#: the shortest horizon, in seconds: several time constants of the shaft models
#: (1 / gamma ~ 17 s), and the whole horizon of records stored before it followed the model
LEVEL_HORIZON_SECONDS = 120.0
#: most RK4 sample steps of :func:`horizon_samples`' horizon (records stored before
#: :func:`level_horizon`)
LEVEL_MAX_STEPS = 12
#: the horizon in analysis intervals as the white box's dynamics ask for them (half its
#: fastest time constant each, :mod:`graybox.analysis_rate`): the fixed horizon's 12 steps
LEVEL_ASKED_STEPS = 12
#: most RK4 sample steps of :func:`level_horizon`'s horizon: bounds the cost
LEVEL_LONGEST_STEPS = 256
#: least seconds between two predictions' starting points: the level moves far slower than
#: a sample, and the cost is steps times starting points
LEVEL_START_SPACING = 10.0
#: starting points per horizon at most: predictions that overlap more say nothing new
LEVEL_STARTS_PER_HORIZON = 12
#: states probed for :func:`drifting_states` (spread over the windows' samples)
DRIFT_PROBES = 64


@dataclass(frozen=True)
class LevelTier:
    """The level of one channel's k-step prediction error at the baseline's operating point.

    Attributes
    ----------
    level : float
        Intercept of the error's regression on the centred operating features: the mean
        error at the baseline's operating point (in the channel's units).
    slopes : tuple of float
        Regression coefficients of the features, fitted by the baseline (the model error's
        share; a candidate keeps its baseline's).
    center : tuple of float
        Feature means of the baseline (a candidate keeps its baseline's, so levels compare).
    residual_std : float
        Standard deviation of the regression's residual; the unit of the tier's changes.
    horizon : int
        ``k``, in telemetry samples.
    n_obs : int
        Error samples the fit used.
    operating_point : tuple of float, optional
        The fit's own feature means (a candidate's: its night's operating point).
    reach : float, optional
        A baseline's largest operating-condition correction of one of its windows: the norm
        of the inputs' ``slopes * (window's feature means - center)``, in the channel's units
        (see :func:`correction` and :func:`extrapolation`). None for candidates and records
        stored before it.
    operating : tuple of int, optional
        A baseline's features that set the operating condition in :func:`correction`: the
        positions of the inputs that no controller sets and whose means differ between the
        baseline's days beyond chance (:func:`operating_features`). None (candidates, records
        stored before it): every input.
    window_points : tuple of tuple of float, optional
        A candidate's feature means per telemetry window (a candidate of several nights has
        one per night): :func:`extrapolation` takes the farthest. None for baselines and
        records stored before it (the ``operating_point`` stands for the whole fit).
    drifting : tuple of str, optional
        A baseline's hidden states whose change since the segment's start is among its
        features, after the inputs (:func:`drifting_states`); its candidates use the same.
        None for candidates and records stored before it (then none is a feature).
    extent_reach : float, optional
        A baseline with drifting states: the largest correction of one of its windows'
        *extent*, its feature means with each drifting state's change replaced by the
        window's sample farthest from the centre (:func:`extrapolation`). None otherwise.
    window_extents : tuple of tuple of float, optional
        A candidate's extent per telemetry window, where its baseline has drifting states.
    resolution : float, optional
        A baseline's: the step its channel's reading is logged in
        (:func:`graybox.resolution.reading_resolution`, 0 when not quantized). A level
        change within one step is never an alarm (:meth:`graybox.tiers.level.LevelTierKind.
        epsilon_floor`). None for candidates and records stored before it.
    """

    level: float
    slopes: tuple[float, ...]
    center: tuple[float, ...]
    residual_std: float
    horizon: int
    n_obs: int
    operating_point: tuple[float, ...] | None = None
    reach: float | None = None
    operating: tuple[int, ...] | None = None
    window_points: tuple[tuple[float, ...], ...] | None = None
    resolution: float | None = None
    drifting: tuple[str, ...] | None = None
    extent_reach: float | None = None
    window_extents: tuple[tuple[float, ...], ...] | None = None

    omitted_when_none: ClassVar[frozenset[str]] = frozenset({
        "operating_point", "reach", "operating", "window_points", "resolution", "drifting",
        "extent_reach", "window_extents"})


def horizon_samples(sample_interval: float, seconds: float = LEVEL_HORIZON_SECONDS) -> int:
    """``k`` for samples every ``sample_interval`` seconds: ``seconds`` ahead, at least 1 and
    at most :data:`LEVEL_MAX_STEPS` (the horizon before :func:`level_horizon`)."""
    return int(np.clip(np.ceil(seconds / sample_interval - 1e-9), 1, LEVEL_MAX_STEPS))


def level_horizon(time_constant: float, sample_interval: float, segment_lengths: Sequence[int],
                  piece_samples: int, integrating: bool = False) -> int:
    """A baseline's ``k``: the fixed horizon (:func:`horizon_samples`), or, where the analysis
    interval is at most half what the white box's dynamics ask for, :data:`LEVEL_ASKED_STEPS`
    of the interval they ask for.

    The fixed horizon (120 s, at most 12 steps) is several time constants of a shaft that
    settles in 17 s. A slow plant logged every minute has its analysis interval capped far
    below what its dynamics ask for (half its fastest time constant), to keep the samples a
    day needs (:func:`graybox.analysis_rate.choose_analysis_interval`), and its horizon
    shrank with it: a heated room whose air settles in an hour and a half got 2 steps and
    kept ``1 - J^k`` = 2 % of a sensor bias, and of a shift of its equilibrium (a weaker
    heater) as little. Counted in the steps its dynamics ask for, the horizon is what it was
    meant to be. A plant analysed at the interval it asks for keeps the fixed horizon
    exactly (lengthening it there was tried and moved a conveyor's thermal level: healthy
    alarms 4 -> 8 of 300). So does a plant with a mode that never decays (``integrating``:
    a start's error is never forgotten, and a longer horizon only accumulates the white
    box's rate errors; a compressor's receiver pressure lost a small leak), and one whose
    caps leave the horizon shorter than one fastest time constant (too little is forgotten
    and the rest accumulates: a pump station's 11-18 h tank over 6 h alarmed on one healthy
    station's 10 nights of 15, and where the caps left 6 h for a 12-h tank, faults were
    lost).
    At most :data:`LEVEL_LONGEST_STEPS` (cost), half of
    ``piece_samples`` (each calibration piece keeps errors of its own) and half of the
    median operating segment (a prediction never crosses a segment's border). The steps are
    a rung ``2^n`` or ``1.5 * 2^n`` (the first at or above the wanted steps, or the last
    within the caps), so that a baseline refitted on some of its days (calibration) gets
    the same horizon and reuses the segments' predictions.

    Parameters
    ----------
    time_constant : float
        Seconds: ``1 /`` :func:`graybox.analysis_rate.fastest_rate` (0 for a model without
        dynamics).
    sample_interval : float
        Seconds between the samples predicted (the analysis interval).
    segment_lengths : sequence of int
        Samples of the baseline's operating segments.
    piece_samples : int
        Samples of a calibration piece (at least ``min_samples``).
    integrating : bool, default False
        The white box has a mode that never decays
        (:func:`graybox.analysis_rate.integrates` of the baseline's eigenvalues).

    Returns
    -------
    int
    """
    floor = horizon_samples(sample_interval)
    asked = ANALYSIS_FRACTION * time_constant
    if integrating or not asked >= 2 * sample_interval:
        return floor
    wanted = LEVEL_ASKED_STEPS * asked / sample_interval
    cap = min(LEVEL_LONGEST_STEPS, piece_samples // 2,
              int(np.median(segment_lengths)) // 2 if len(segment_lengths) else 0)
    steps = min(np.ceil(wanted - 1e-9), cap)
    rungs = [r for r in _rungs(cap) if r > floor]
    if steps <= floor or not rungs or rungs[-1] * sample_interval < time_constant:
        return floor
    return next((r for r in rungs if r >= steps), rungs[-1])


def _rungs(most: int) -> list[int]:
    """``2^n`` and ``1.5 * 2^n`` up to ``most``: 1, 2, 3, 4, 6, 8, 12, 16, 24, ..."""
    rungs, power = [1], 2
    while power <= most:
        rungs += [r for r in (power, 3 * power // 2) if r <= most]
        power *= 2
    return rungs


def start_stride(sample_interval: float, horizon: int) -> int:
    """Samples between two predictions' starting points: :data:`LEVEL_START_SPACING`, or a
    :data:`LEVEL_STARTS_PER_HORIZON`-th of a longer horizon of ``horizon`` samples."""
    spacing = max(LEVEL_START_SPACING, horizon * sample_interval / LEVEL_STARTS_PER_HORIZON)
    return max(1, int(round(spacing / sample_interval)))


def k_step_prediction(model: WhiteBoxModel, x: np.ndarray, u: np.ndarray, dt: float, k: int,
                      substeps: int = 2, stride: int = 1,
                      integration: Integration | None = None) -> np.ndarray:
    """Free-run prediction of every sample from the (full) state ``k`` samples earlier.

    Parameters
    ----------
    model : WhiteBoxModel
    x : ndarray of shape (T, n_states)
        Full states: measured ones as read, hidden ones estimated.
    u : ndarray of shape (T, n_inputs)
    dt : float
        Sample interval in seconds.
    k : int
        Samples predicted ahead (``k = 1`` is the one-step prediction of Eqs. 2-3).
    substeps : int, default 2
        RK4 steps per sample (when ``integration`` is not given; inputs linear inside a
        sample).
    stride : int, default 1
        Predict only every ``stride``-th sample.
    integration : Integration, optional

    Returns
    -------
    ndarray of shape (ceil((T - k) / stride), n_states)
        The predictions of samples ``k, k + stride, ... <= T-1``.
    """
    x = np.asarray(x, dtype=float)
    u = np.asarray(u, dtype=float).reshape(len(x), -1)
    if len(x) <= k:
        raise InsufficientDataError(f"a {k}-step prediction needs more than {k} samples")
    integration = integration or Integration("rk4", substeps)
    n = len(x) - k
    state = x[:n:stride].copy()
    for j in range(k):
        state = advance(model.derivatives, state, u[j:j + n:stride], u[j + 1:j + 1 + n:stride],
                        dt, integration)
    return state


def segment_level_data(model: WhiteBoxModel, window: WindowStates, dt: float, k: int,
                       stride: int = 1, integration: Integration | None = None
                       ) -> tuple[np.ndarray, np.ndarray] | None:
    """One segment's k-step errors and predictions (see :func:`level_data`).

    Returns
    -------
    (errors, predicted) or None
        ``errors`` and ``predicted`` of shape (N, n_outputs), one row every ``stride``
        samples from sample ``k``; None when the segment is not longer than ``k``.
    """
    if len(window.y) <= k:
        return None
    predicted = k_step_prediction(model, window.states, window.u, dt, k, stride=stride,
                                  integration=integration)
    measured = window.y[k::stride]
    predicted = model.output(predicted, window.u[k::stride])
    check_prediction(model, measured, predicted, f"{k}-step prediction")
    return measured - predicted, predicted


def drifting_states(model: WhiteBoxModel, windows: Sequence[WindowStates]
                    ) -> dict[str, tuple[int, ...]]:
    """Per output channel, the hidden states whose open-loop run drifts into its k-step
    prediction: their change since the segment's start is one of the channel's level
    features (:func:`pool_level_data`).

    A hidden state is estimated once per segment, at its start, and then runs open-loop by
    the white box's dynamics (:mod:`graybox.state_estimation`); the k-step prediction starts
    from that run. A hidden state that relaxes (its rate depends on its own value: an RC
    voltage) forgets its start's error and carries only the model's recent error, which the
    other features follow. One whose rate does not depend on its own value (an integrator:
    a state of charge counted from the current, a volume from its flows) never forgets: a
    rate error of the white box (a capacity 10 % off) accumulates in it with every unit it
    moves, and the channels it enters carry that drift as a level that moves with how far
    the state has moved since its estimate, not with the operating condition of the
    moment. Such a state *drifts*: ``df_j/dx_j`` is 0 at every probed state (up to
    rounding). It drifts into a channel whose output map reads it, or, for a measured state,
    whose dynamics do (``dg_i/dx_j`` or ``df_i/dx_j`` nonzero at some probed state).

    Parameters
    ----------
    model : WhiteBoxModel
    windows : sequence of WindowStates
        The states probed: :data:`DRIFT_PROBES` samples spread over them.

    Returns
    -------
    dict of str to tuple of int
        Per output, the positions in ``model.states`` of the hidden states drifting into it
        (empty for every output of a model without hidden states).
    """
    hidden = [model.states.index(name) for name in model.hidden_states]
    empty = {name: () for name in model.outputs}
    windows = [w for w in windows if len(w.states)]
    if not hidden or not windows:
        return empty
    x = np.concatenate([w.states for w in windows])
    u = np.concatenate([w.u for w in windows]).reshape(len(x), -1)
    rows = np.unique(np.linspace(0, len(x) - 1, min(DRIFT_PROBES, len(x))).astype(int))
    x, u = x[rows], u[rows]
    rates = model.derivatives(x, u)
    dynamics = jacobian(model.derivatives, x, u, rates)            # (N, n, n)
    scale = np.maximum(np.abs(rates), 1e-300)
    # relative to the rate's own size: a forward difference of a rate that ignores the
    # state is exactly 0; one that reads it differs by far more than rounding
    drifting = [j for j in hidden
                if np.all(np.abs(dynamics[:, j, j]) * np.maximum(1.0, np.abs(x[:, j]))
                          <= 1e-6 * scale[:, j])]
    if not drifting:
        return empty
    y = model.output(x, u)
    reads = np.empty(y.shape + (len(drifting),))
    for position, j in enumerate(drifting):
        delta = 1e-6 * np.maximum(1.0, np.abs(x[:, j]))
        shifted = x.copy()
        shifted[:, j] += delta
        reads[..., position] = (model.output(shifted, u) - y) / delta[:, None]
    out = {}
    for i, name in enumerate(model.outputs):
        measured = model.states.index(name) if name in model.states else None
        out[name] = tuple(
            j for position, j in enumerate(drifting)
            if np.any(np.abs(reads[:, i, position]) > 0)
            or (measured is not None and np.any(np.abs(dynamics[:, measured, j]) > 0)))
    return out


def drifting_state_names(model: WhiteBoxModel, windows: Sequence[WindowStates]
                         ) -> dict[str, tuple[str, ...]]:
    """:func:`drifting_states` by state name, as a baseline records them
    (:attr:`LevelTier.drifting`)."""
    return {name: tuple(model.states[j] for j in found)
            for name, found in drifting_states(model, windows).items()}


def pool_level_data(model: WhiteBoxModel, windows: Sequence[WindowStates],
                    parts: Sequence[tuple[np.ndarray, np.ndarray] | None], k: int,
                    stride: int = 1, drift: Mapping[str, Sequence[str]] | None = None
                    ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """:func:`level_data` from each segment's :func:`segment_level_data`; ``drift``: per
    channel, the hidden states whose change is a feature (default :func:`drifting_states`
    of these windows; a candidate passes its baseline's)."""
    if drift is None:
        drift = drifting_state_names(model, windows)
    drift = {name: [model.states.index(state) for state in drift.get(name, ())]
             for name in model.outputs}
    errors = {name: [] for name in model.outputs}
    features = {name: [] for name in model.outputs}
    segments = []
    for position, (window, part) in enumerate(zip(windows, parts)):
        if part is None:
            continue
        error, predicted = part
        segments.append(np.full(len(error), position))
        for i, name in enumerate(model.outputs):
            errors[name].append(error[:, i])
            moved = window.states[k::stride][:, drift[name]] - window.states[0, drift[name]]
            features[name].append(np.column_stack([predicted[:, i], window.u[k::stride], moved]))
    if not segments:
        raise InsufficientDataError(f"channel {model.outputs[0]!r}: no segment is longer "
                                    f"than the level tier's horizon of {k} samples")
    positions = np.concatenate(segments)
    return {name: (np.concatenate(errors[name]), np.concatenate(features[name]), positions)
            for name in model.outputs}


def level_data(model: WhiteBoxModel, windows: Sequence[WindowStates | pd.DataFrame], dt: float,
               k: int,
               stride: int = 1, integration: Integration | None = None,
               drift: Mapping[str, Sequence[str]] | None = None
               ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per output channel, the k-step errors and their operating features, pooled over
    segments (a prediction never crosses a segment border); one prediction every
    ``stride`` samples.

    Returns
    -------
    dict of str to (errors, features, segments)
        ``errors`` of shape (N,), ``features`` of shape (N, 1 + n_inputs + n_drifting):
        the channel's prediction, then the inputs at the predicted sample, then the change
        since the segment's start of each hidden state drifting into the channel
        (``drift``, default :func:`drifting_states`; none without hidden states);
        ``segments`` (N,): the position in ``windows`` each sample comes from.
    """
    windows = [estimate_states(model, *window_arrays(model, window), dt,
                               integration or Integration())
               if isinstance(window, pd.DataFrame) else window for window in windows]
    parts = [segment_level_data(model, window, dt, k, stride, integration)
             for window in windows]
    return pool_level_data(model, windows, parts, k, stride, drift)


def fit_level(errors: np.ndarray, features: np.ndarray, horizon: int,
              baseline: LevelTier | None = None, groups: np.ndarray | None = None,
              operating: Sequence[int] | None = None, resolution: float | None = None,
              drifting: Sequence[str] | None = None) -> LevelTier:
    """Regress the k-step errors on the centred operating features; keep the intercept.

    Parameters
    ----------
    errors : ndarray of shape (N,)
    features : ndarray of shape (N, p)
    horizon : int
        ``k`` the errors were computed with (recorded).
    baseline : LevelTier, optional
        A candidate's baseline: its centre and slopes are kept and only the level is
        refitted, so both are levels at the same operating point. None fits centre (the
        features' means), slopes and level.
    groups : ndarray of shape (N,), optional
        The telemetry window of each sample: a new baseline's ``reach`` is the largest
        correction of a window's operating point, a candidate keeps each window's
        ``window_points`` (none without).
    operating : sequence of int, optional
        A new baseline's features that set the operating condition (:func:`correction`);
        None: every input.
    resolution : float, optional
        A new baseline's channel's reading step (recorded; a candidate records none).
    drifting : sequence of str, optional
        A new baseline's hidden states whose changes are the last features (recorded; a
        candidate records none).

    Returns
    -------
    LevelTier
    """
    errors = np.asarray(errors, dtype=float)
    features = np.asarray(features, dtype=float).reshape(len(errors), -1)
    finite = np.isfinite(errors) & np.isfinite(features).all(axis=1)
    errors, features = errors[finite], features[finite]
    groups = None if groups is None else np.asarray(groups)[finite]
    if len(errors) <= features.shape[1] + 2:
        raise InsufficientDataError(f"{len(errors)} finite k-step errors are too few for the "
                                    f"level tier")
    if baseline is None:
        center = features.mean(axis=0)
        # a feature without spread (a constant input) has no slope; lstsq gives it 0
        design = np.column_stack([np.ones(len(errors)), features - center])
        coefficients, *_ = np.linalg.lstsq(design, errors, rcond=None)
        level, slopes = float(coefficients[0]), coefficients[1:]
    else:
        # the baseline's relation to the operating condition, only the offset refitted: a
        # night (or a calibration piece) covering part of the load range would otherwise
        # extrapolate its own slopes to the baseline's centre
        center, slopes = np.asarray(baseline.center, float), np.asarray(baseline.slopes, float)
        level = float(np.mean(errors - (features - center) @ slopes))
    residual = errors - level - (features - center) @ slopes
    reach, points, extent_reach, extents = None, None, None, None
    operating = None if baseline is not None or operating is None else tuple(
        int(i) for i in operating)
    drifts = len(drifting or ()) if baseline is None else len(baseline.drifting or ())
    if groups is not None:
        windows = [features[groups == g] for g in np.unique(groups)]
        means = [window.mean(axis=0) for window in windows]
        spans = [extent(window, center, drifts) for window in windows] if drifts else None
        if baseline is None:
            reach = max(correction(point, center, slopes, operating) for point in means)
            if spans:
                extent_reach = max(correction(point, center, slopes, operating)
                                   for point in spans)
        else:
            points = tuple(tuple(float(c) for c in point) for point in means)
            if spans:
                extents = tuple(tuple(float(c) for c in point) for point in spans)
    return LevelTier(level, tuple(float(c) for c in slopes), tuple(float(c) for c in center),
                     float(residual.std()), int(horizon), int(len(errors)),
                     tuple(float(c) for c in features.mean(axis=0)), reach, operating, points,
                     None if baseline is not None or resolution is None else float(resolution),
                     None if baseline is not None or not drifting else tuple(drifting),
                     extent_reach, extents)


def extent(features: np.ndarray, center: Sequence[float], drifts: int) -> np.ndarray:
    """A window's extent: its feature means, with each of the last ``drifts`` features (the
    drifting states' changes) replaced by the window's value farthest from ``center``.

    A drifting state's change is a path, not a condition the window holds around its mean:
    a night that discharges a pack deep and charges it again has an ordinary mean change of
    charge, yet spent hours where the baseline's days never took it."""
    point = features.mean(axis=0)
    center = np.asarray(center, float)
    for j in range(features.shape[1] - drifts, features.shape[1]):
        point[j] = features[np.argmax(np.abs(features[:, j] - center[j])), j]
    return point


def correction(point: Sequence[float], center: Sequence[float], slopes: Sequence[float],
               operating: Sequence[int] | None = None) -> float:
    """The size of the operating-condition correction at ``point``: the norm of the
    operating features' shares ``slopes * (point - center)``, in the channel's units.

    ``operating`` lists the features that count (None: every input). The first feature, the
    channel's own prediction, never counts: a sensor fault moves it too (a bias enters the
    prediction through its start), and a fault must not read as a night outside the
    operating range. Nor does an input a controller sets (``controlled_inputs`` of the white
    box), for the same reason: a fault the loop compensates moves it."""
    positions = (np.arange(1, len(center)) if operating is None
                 else np.asarray(operating, dtype=int))
    point, center, slopes = (np.asarray(v, float)[positions] for v in (point, center, slopes))
    return float(np.sqrt(np.sum((slopes * (point - center)) ** 2)))


def operating_features(model: WhiteBoxModel,
                       conditions: OperatingConditions | None = None) -> tuple[int, ...]:
    """Positions, among a channel's level features (its prediction, then the inputs), of the
    inputs that place a night in or outside the baseline's operating range: those no
    controller sets and, given the baseline's ``conditions``, whose windows' means differ
    beyond chance (:meth:`~graybox.operating_conditions.OperatingConditions.varying_inputs`).
    A plant driven alike every day has days whose input means differ by chance alone: a
    night a little beyond the reach of such days is not beyond anything, and its level change
    is not discounted (the other tiers' conditions count the same way)."""
    varying = None if conditions is None else set(conditions.varying_inputs())
    return tuple(1 + i for i, name in enumerate(model.inputs)
                 if name not in model.controlled_inputs and (varying is None or name in varying))


def extrapolation(candidate: LevelTier, baseline: LevelTier) -> float:
    """How far outside its baseline's operating range a candidate lies: the correction
    (:func:`correction`) of its farthest window's operating point over the baseline's
    ``reach``, the largest of a baseline window's. Above 1, a night lies where the baseline's
    slopes were never checked by a day of its own; 0 where either record lacks the figures.
    A candidate of several nights is as far outside as its farthest night: the correction is
    linear in the operating point, the model error it stands for is not, so the average of a
    night far outside and one inside would understate it."""
    if candidate.operating_point is None or not baseline.reach:
        return 0.0
    points = candidate.window_points or (candidate.operating_point,)
    outside = max(correction(point, baseline.center, baseline.slopes, baseline.operating)
                  for point in points) / baseline.reach
    if baseline.extent_reach and candidate.window_extents:
        # a drifting state: as far outside as its farthest excursion, too (:func:`extent`)
        outside = max(outside, max(correction(point, baseline.center, baseline.slopes,
                                              baseline.operating)
                                   for point in candidate.window_extents)
                      / baseline.extent_reach)
    return outside
