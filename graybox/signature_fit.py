"""Batched fleet fitting: telemetry windows -> residual -> three tiers -> signature, for many
assets at once.

:func:`fit_signatures` prepares every request (residual at the telemetry's rate, decimated to
the analysis interval, stationarized, AR tier), then fits all their networks in batched
computations grouped by network shape, then describes the noise. A request's result never
depends on the other requests of the call, and one asset's bad data never stops the others:
an error in a request's own preparation or noise tier is its result, and when a batched
network computation raises, each of its requests is fitted again alone, so the error is the
result of the request that causes it and the others are unaffected.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Sequence

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from graybox.analysis_rate import choose_analysis_interval, decimate, decimation_factor
from graybox.embedding import choose_delay, choose_dimension
from graybox.exceptions import GrayBoxError, InsufficientDataError
from graybox.integration import Integration, IntegrationError, choose_integration
from graybox.level_tier import (LevelTier, fit_level, horizon_samples, operating_features,
                                pool_level_data, segment_level_data, start_stride)
from graybox.linear_tier import LinearTier, fit_ar
from graybox.models.base import WhiteBoxModel
from graybox.models.spec import ModelSpec
from graybox.noise_tier import describe_noise
from graybox.operating_conditions import OperatingConditions, operating_conditions
from graybox.parameter_estimate import ParameterEstimate
from graybox.parameter_estimation import estimate_parameters, with_parameters
from graybox.nonlinear_tier import NonlinearTier, fit_networks, initial_weights, lagged
from graybox.residual import infer_sample_interval, residual_frame
from graybox.settings import GrayBoxSettings
from graybox.signature import (ChannelSignature, ChannelStructure, HiddenStart, Selection,
                               Signature)
from graybox.stage_clock import StageClock, timed
from graybox.segment_cache import SegmentCache
from graybox.state_estimation import WindowStates, estimate_states, window_arrays
from graybox.telemetry.window import window_periods
from graybox.stationarize import choose_differencing


@dataclass(frozen=True)
class FitRequest:
    """One asset's fit in a fleet batch.

    Attributes
    ----------
    model : WhiteBoxModel
    windows : sequence of TelemetryWindow, DataFrame or sequence of DataFrame
        Uniform-grid telemetry. Each operating period of each window (a TelemetryWindow's
        :meth:`~graybox.telemetry.TelemetryWindow.periods`; a sequence of frames is the
        periods of one window) is a separate segment: its residual, differences and delays
        never cross into another. In a window of several periods, a period shorter than
        ``settings.shortest_period`` is left out; a window without any long enough is an
        error.
    baseline : Signature, optional
        Frozen structure to fit with (a candidate). None fits a new baseline structure.
    warm_start : Signature, optional
        Network weights to start from; defaults to ``baseline``.
    asset_id : str, optional
    seed : int
        Seeds the random initial weights of a new baseline.
    estimate : tuple of str
        White-box parameters a new baseline first fits to the asset's windows
        (:func:`~graybox.parameter_estimation.estimate_parameters`); the baseline is then
        fitted with the tuned white box and records the estimates (``Signature.tuning``).
        A candidate always uses its baseline's tuned values.
    """

    model: WhiteBoxModel
    windows: Sequence
    baseline: Signature | None = None
    warm_start: Signature | None = None
    asset_id: str | None = None
    seed: int = 0
    estimate: tuple[str, ...] = ()


@dataclass
class _Channel:
    name: str
    structure: ChannelStructure | None
    linear: LinearTier
    w_segments: list[np.ndarray]
    n_samples: int
    selection: Selection | None = None
    nonlinear: NonlinearTier | None = None
    level: LevelTier | None = None


@dataclass
class _Prepared:
    request: FitRequest
    sample_interval: float
    analysis_interval: float
    window_start: str | None
    window_end: str | None
    asset_id: str | None
    integration: Integration
    hidden_starts: tuple | None
    channels: list[_Channel] = field(default_factory=list)
    tuning: ParameterEstimate | None = None
    conditions: OperatingConditions | None = None


def _window_parts(window) -> tuple[list[pd.DataFrame], float, str | None]:
    periods = window_periods(window)
    if not periods:
        raise InsufficientDataError("a window without any operating period")
    interval = getattr(window, "sample_interval", None) or infer_sample_interval(periods[0].index)
    return periods, float(interval), getattr(window, "asset_id", None)


def _operating_segments(parts, settings: GrayBoxSettings, interval: float
                        ) -> tuple[list[pd.DataFrame], list[int]]:
    """Every window's periods as segments, with the window each belongs to. In a window of
    several periods, those shorter than ``settings.shortest_period`` are left out."""
    frames, owners = [], []
    for k, (periods, _, _) in enumerate(parts):
        if len(periods) > 1:
            kept = [p for p in periods if len(p) * interval >= settings.shortest_period]
            if not kept:
                longest = max(len(p) for p in periods) * interval
                raise InsufficientDataError(
                    f"window {k} starting {periods[0].index[0].isoformat()}: none of its "
                    f"{len(periods)} operating periods is long enough to fit (the longest "
                    f"lasts {longest:g} s; a period needs ar_span + delay_span + "
                    f"derivative_span = {settings.shortest_period:g} s)")
            periods = kept
        frames.extend(periods)
        owners.extend([k] * len(periods))
    return frames, owners


def _prepare(request: FitRequest, settings: GrayBoxSettings,
             clock: StageClock | None = None, cache: SegmentCache | None = None) -> _Prepared:
    if not request.windows:
        raise InsufficientDataError("no telemetry windows to fit")
    parts = [_window_parts(w) for w in request.windows]
    intervals = {round(p[1], 9) for p in parts}
    if len(intervals) != 1:
        raise GrayBoxError(f"windows have different sample intervals: {sorted(intervals)}")
    interval = parts[0][1]
    asset_id = request.asset_id or parts[0][2]
    baseline = request.baseline
    if baseline is not None:
        if abs(baseline.sample_interval - interval) > 1e-9 * interval:
            raise GrayBoxError(f"baseline was sampled every {baseline.sample_interval} s, "
                               f"this telemetry every {interval} s")
    frames, owners = _operating_segments(parts, settings, interval)
    model = request.model
    with timed(clock, "residual"):
        integration, states = _integrate(request, frames, interval, cache)
        analysis = analysis_interval(request, settings, states, interval,
                                     int(_per_window([len(f) for f in frames], owners).min()))
        factor = decimation_factor(analysis, interval)
        window = settings.derivative_window(interval)
        def residual(frame, segment) -> dict[str, np.ndarray]:
            r = residual_frame(model, frame, settings.residual, interval, window, integration,
                               segment)
            return {name: decimate(r[name].to_numpy(), factor) for name in model.outputs}

        details = (interval, integration, settings.residual, window, factor)
        per_segment = [residual(frame, segment) if cache is None else
                       cache.remember("residual", model, segment, details,
                                      lambda f=frame, s=segment: residual(f, s))
                       for frame, segment in zip(frames, states)]
        decimated = {name: [r[name] for r in per_segment] for name in model.outputs}
        del per_segment
        # the level tier at the analysis interval too: a 1-Hz window costs several times fewer
        # integration steps and loses nothing (the level moves far slower than a sample)
        levels = _fit_levels(request, [segment.decimated(factor) for segment in states],
                             analysis, integration, owners, cache)
    starts = [frame.index[0] for frame in frames]
    ends = [frame.index[-1] + pd.Timedelta(seconds=interval) for frame in frames]
    hidden = (tuple(HiddenStart(frame.index[0].isoformat(), segment.initial_hidden)
                    for frame, segment in zip(frames, states)) if model.hidden_states else None)
    prepared = _Prepared(request, interval, analysis, min(starts).isoformat(),
                         max(ends).isoformat(), asset_id, integration, hidden,
                         conditions=operating_conditions(model, [s.u for s in states], owners))
    for index, name in enumerate(model.outputs):
        frozen = None if baseline is None else baseline.channel(name).structure
        with timed(clock, "stationarize_ar"):
            prepared.channels.append(_prepare_channel(name, decimated[name], frozen, settings,
                                                      analysis, seed=request.seed * 1000 + index,
                                                      owners=owners))
            prepared.channels[-1].level = levels.get(name)
    return prepared


def _integrate(request: FitRequest, frames: Sequence[pd.DataFrame], interval: float,
               cache: SegmentCache | None) -> tuple[Integration, list[WindowStates]]:
    """The integrator (a candidate: its baseline's) and every segment's full state.

    A new baseline's integrator is chosen at the data's own states
    (:func:`graybox.integration.choose_integration`); hidden states are first estimated with
    RK4 (the L-stable method where RK4 diverges or the model asks for it), and again if the
    choice differs.
    """
    model = request.model
    arrays = [window_arrays(model, frame) for frame in frames]
    estimate = estimate_states if cache is None else cache.estimate
    if request.baseline is not None:
        integration = request.baseline.integration_used
        return integration, [estimate(model, y, u, interval, integration)
                             for y, u in arrays]
    first = Integration("rosenbrock" if model.integrator == "rosenbrock" else "rk4")
    try:
        states = [estimate(model, y, u, interval, first) for y, u in arrays]
    except IntegrationError:
        if model.integrator != "auto":
            raise
        # stiff hidden dynamics: RK4 diverged where the L-stable method will not
        first = Integration("rosenbrock")
        states = [estimate(model, y, u, interval, first) for y, u in arrays]
    x = np.concatenate([s.states for s in states])
    u = np.concatenate([s.u for s in states])
    finite = np.isfinite(x).all(axis=1) & np.isfinite(u).all(axis=1)
    steps = np.concatenate([np.diff(s.states, axis=0) for s in states])
    change = np.sqrt(np.nanmean(steps ** 2, axis=0))
    integration = choose_integration(model, x[finite], u[finite], interval, change)
    if integration != first and model.hidden_states:
        states = [estimate(model, y, u, interval, integration) for y, u in arrays]
    return integration, states


def _fit_levels(request: FitRequest, windows: Sequence[WindowStates],
                interval: float, integration: Integration, owners: Sequence[int],
                cache: SegmentCache | None = None) -> dict[str, LevelTier]:
    """The level tier of every channel (:mod:`graybox.level_tier`) of ``windows`` sampled
    every ``interval`` seconds (the analysis interval: every ``factor``-th telemetry sample);
    ``owners`` the telemetry window of each segment.

    A candidate uses its baseline's horizon and operating centre; a candidate of a baseline
    stored without the tier gets none.
    """
    baseline = request.baseline
    outputs = request.model.outputs
    if baseline is None:
        horizon, references = horizon_samples(interval), {name: None for name in outputs}
    else:
        references = {name: baseline.channel(name).level for name in outputs}
        if any(level is None for level in references.values()):
            return {}
        horizon = next(iter(references.values())).horizon
    model, stride = request.model, start_stride(interval)

    def segment(window: WindowStates):
        return segment_level_data(model, window, interval, horizon, stride, integration)

    parts = [segment(window) if cache is None else
             cache.remember("level", model, window, (interval, horizon, stride, integration),
                            lambda w=window: segment(w))
             for window in windows]
    data = pool_level_data(model, windows, parts, horizon, stride)
    levels = {}
    for name in outputs:
        try:
            errors, features, segments = data[name]
            levels[name] = fit_level(errors, features, horizon, references[name],
                                     np.asarray(owners)[segments],
                                     operating_features(request.model))
        except InsufficientDataError as error:
            raise InsufficientDataError(f"channel {name!r}: level tier: {error}") from None
    return levels


def analysis_interval(request: FitRequest, settings: GrayBoxSettings,
                      frames: Sequence[WindowStates], sample_interval: float,
                      shortest_window: int | None = None) -> float:
    """Seconds between the residual samples the tiers see (a candidate: its baseline's).

    ``shortest_window``: telemetry samples of the shortest window, which caps the automatic
    choice (:func:`graybox.analysis_rate.choose_analysis_interval`).
    """
    if request.baseline is not None:
        return request.baseline.analysis_step
    if settings.analysis_interval == "native":
        return sample_interval
    if settings.analysis_interval == "auto":
        return choose_analysis_interval(request.model, frames, sample_interval,
                                        shortest_window=shortest_window,
                                        samples_needed=settings.samples_per_window)
    return max(1, round(settings.analysis_interval / sample_interval)) * sample_interval


def _what_helps(settings: GrayBoxSettings, interval: float, shortest: int) -> str:
    """The one setting that gives a starved window its samples."""
    if not isinstance(settings.analysis_interval, str):
        return (f"the class's settings fix analysis_interval = {settings.analysis_interval:g} s; "
                f"use \"auto\" (the default), which keeps enough samples, or a shorter interval")
    needed = (settings.min_samples + 1) * interval
    return (f"a window must cover more than {needed:g} s of operation at this rate ("
            f"{shortest} samples cover {shortest * interval:g} s): use longer windows "
            f"([nightly] window), or for an intermittent asset a longer grid.min_duration")


def _per_window(lengths: Sequence[int], owners: Sequence[int]) -> np.ndarray:
    """Sums of per-segment counts per window."""
    return np.bincount(np.asarray(owners, dtype=np.intp), weights=np.asarray(lengths, float),
                       minlength=max(owners) + 1).astype(int)


def _prepare_channel(name: str, segments: list[np.ndarray], frozen: ChannelStructure | None,
                     settings: GrayBoxSettings, interval: float, seed: int,
                     owners: Sequence[int] | None = None) -> _Channel:
    # owners[i]: the window of segment i (several segments per window: operating periods);
    # the sample-count checks below apply to each window's segments together
    owners = list(range(len(segments))) if owners is None else list(owners)
    selection = None
    if frozen is None:
        choice = choose_differencing(segments, settings.max_diff_order, settings.max_seasonal_order)
        differencing = choice.differencing
    else:
        differencing = frozen.differencing
    lost = differencing.lost
    usable = _per_window([max(0, len(s) - lost) for s in segments], owners)
    too_short = [k for k, n in enumerate(usable) if n <= settings.min_samples]
    if too_short:
        shortest = min(usable[k] for k in too_short) + lost
        raise InsufficientDataError(
            f"channel {name!r}: window(s) {too_short} have {shortest} residual samples at the "
            f"{interval:g}-s analysis interval; the method needs more than {differencing.lost} "
            f"for differencing plus min_samples = {settings.min_samples}: "
            f"{_what_helps(settings, interval, shortest)}")
    # a segment too short to difference contributes nothing
    y = [differencing.apply(s) if len(s) > lost else s[:0] for s in segments]
    if frozen is None:
        pooled = np.concatenate(y)
        center, scale = float(pooled.mean()), float(pooled.std())
        if scale <= 0:
            raise InsufficientDataError(f"channel {name!r}: the residual is constant")
    else:
        center, scale = frozen.center, frozen.scale
    z = [(s - center) / scale for s in y]
    if frozen is None:
        linear = fit_ar(z, max_order=settings.max_ar_order(interval),
                        criterion=settings.ar_criterion)
        selection = Selection(choice.acf_area, choice.raw_acf_area, choice.adf_statistic,
                              choice.candidate_period, settings.ar_criterion)
    else:
        linear = fit_ar(z, order=frozen.ar_order)
    w = [linear.innovations(s) for s in z]
    n_samples = int(sum(len(s) for s in z))
    if frozen is None:
        pooled_w = np.concatenate(w)
        longest = max(w, key=len)
        tau = choose_delay(longest, settings.max_delay(interval))
        dim = choose_dimension(longest, tau, settings.max_embedding_dim)
        nn_scale = settings.nn_scale_factor * float(pooled_w.std())
        structure = ChannelStructure(
            period=differencing.period, seasonal_order=differencing.seasonal_order,
            diff_order=differencing.order, ar_order=linear.order, center=center, scale=scale,
            tau=tau, embedding_dim=dim, hidden_units=settings.hidden_units, nn_scale=nn_scale,
            nonlinear_needed=False,  # decided after the held-out fit
            init_seed=seed, reference_points=settings.reference_points or None)
    else:
        structure = frozen
    span = structure.embedding_dim * structure.tau
    pairs = _per_window([max(0, len(s) - span) for s in w], owners)
    if pairs.min() <= settings.min_samples // 2:
        raise InsufficientDataError(
            f"channel {name!r}: {int(pairs.min()) + span} samples are too few for the network's "
            f"{structure.embedding_dim} delays of {structure.tau} plus min_samples / 2 = "
            f"{settings.min_samples // 2}: use longer windows or lower min_samples")
    return _Channel(name, structure, linear, w, n_samples, selection)


def _design(segments: list[np.ndarray], structure: ChannelStructure):
    parts = [lagged(s / structure.nn_scale, structure.embedding_dim, structure.tau) for s in segments]
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def _fit_networks(prepared: list[_Prepared], settings: GrayBoxSettings, chunk_size: int) -> None:
    """Fit every channel's network, batched by shape; sets ``channel.nonlinear`` (and, for new
    baselines, the ``nonlinear_needed`` decision)."""
    groups: dict[tuple[int, int], list[tuple[_Prepared, int, _Channel]]] = {}
    for item in prepared:
        for index, channel in enumerate(item.channels):
            key = (channel.structure.embedding_dim, channel.structure.hidden_units)
            groups.setdefault(key, []).append((item, index, channel))
    for (dim, hidden), members in groups.items():
        fresh = [(item, i, c) for item, i, c in members if item.request.baseline is None]
        warm = [(item, i, c) for item, i, c in members if item.request.baseline is not None]
        for needed in (True, False):
            members_now = [m for m in warm if m[2].structure.nonlinear_needed == needed]
            if not members_now:
                continue
            retrain = not needed and settings.null_network == "trained"
            train = (needed and settings.trains_needed_network) or retrain
            problems, starts = [], []
            for item, _, channel in members_now:
                # a needed network starts from its reference's weights (the same basin); a null
                # network with fixed features too (one minimum: the start only saves
                # iterations); a trained null network starts where its baseline started
                source = item.request.warm_start or item.request.baseline
                problems.append(_design(channel.w_segments, channel.structure))
                starts.append(initial_weights(hidden, dim, channel.structure.init_seed,
                                              settings.network.init_scale) if retrain
                              else source.channel(channel.name).nonlinear.weight_arrays())
            fits = fit_networks(problems, hidden, starts, settings.network, chunk_size=chunk_size,
                                train_input_weights=train)
            for (item, _, channel), fit in zip(members_now, fits):
                channel.nonlinear = NonlinearTier.from_arrays(fit.w, fit.W, fit.mse, None,
                                                              fit.iterations)
        if fresh:
            _fit_fresh(fresh, hidden, settings, chunk_size)


def _fit_fresh(members, hidden: int, settings: GrayBoxSettings, chunk_size: int) -> None:
    """New baselines: fit on the head of every window, measure the gain on the held-out tails,
    decide whether the tier is needed, then fit on everything.

    With ``needed_network = "fixed_features"`` the trial network, like the needed network it
    decides on, has ``needed_hidden_units`` seeded random hidden units and only its output
    weights are fitted (one minimum, no torch); with ``"trained"`` it is a fully trained
    network of ``hidden`` units.
    """
    fixed = not settings.trains_needed_network
    needed_units = settings.needed_units
    train, test = [], []
    for _, _, channel in members:
        heads, tails = [], []
        for s in channel.w_segments:
            cut = int(round(len(s) * (1 - settings.holdout_fraction)))
            heads.append(s[:cut])
            tails.append(s[cut:])
        train.append(_design(heads, channel.structure))
        test.append(_design(tails, channel.structure))
    seeds = [channel.structure.init_seed for _, _, channel in members]
    head_fits = fit_networks(train, needed_units, None, settings.network, random_state=seeds,
                             chunk_size=chunk_size, train_input_weights=not fixed)
    gains = []
    for (_, _, channel), head, (X_test, y_test) in zip(members, head_fits, test):
        prediction = np.tanh(np.tanh(X_test @ head.w.T) @ head.W)
        zero_error = float(np.mean(y_test ** 2))
        gains.append(1.0 - float(np.mean((y_test - prediction) ** 2)) / zero_error
                     if zero_error > 0 else 0.0)
        needed = bool(gains[-1] > settings.min_heldout_gain)
        channel.structure = replace(channel.structure, nonlinear_needed=needed,
                                    hidden_units=needed_units if needed else hidden)
    # The full fit starts from the seeded random weights, as the candidates of a baseline
    # without nonlinear structure do: zeta compares weights fitted by the same procedure.
    # Without structure, a fully trained network only fits noise, landing in one of many
    # shallow minima; its hidden layer then stays at the random weights (fixed features) and
    # only the output weights are fitted, a problem with a single minimum.
    for needed in (True, False):
        chosen = [i for i, (_, _, c) in enumerate(members) if c.structure.nonlinear_needed == needed]
        if not chosen:
            continue
        problems = [_design(members[i][2].w_segments, members[i][2].structure) for i in chosen]
        trained = (not fixed) if needed else settings.null_network == "trained"
        fits = fit_networks(problems, needed_units if needed else hidden, None, settings.network,
                            random_state=[seeds[i] for i in chosen], chunk_size=chunk_size,
                            train_input_weights=trained)
        for i, fit in zip(chosen, fits):
            members[i][2].nonlinear = NonlinearTier.from_arrays(fit.w, fit.W, fit.mse, gains[i],
                                                                fit.iterations)


def _finish(item: _Prepared, settings: GrayBoxSettings) -> Signature:
    channels = []
    for channel in item.channels:
        structure = channel.structure
        span = structure.embedding_dim * structure.tau
        if structure.nonlinear_needed:
            predictions = channel.nonlinear.predict([s / structure.nn_scale for s in channel.w_segments],
                                                    structure.tau)
            noise = [s[span:] - structure.nn_scale * p for s, p in zip(channel.w_segments, predictions)]
        else:
            noise = [s[span:] for s in channel.w_segments]
        channels.append(ChannelSignature(channel.name, structure, channel.linear, channel.nonlinear,
                                         describe_noise(noise), channel.n_samples, channel.selection,
                                         channel.level))
    return Signature(tuple(channels), ModelSpec.from_model(item.request.model), settings.residual,
                     item.sample_interval, channels[0].n_samples, settings, item.asset_id,
                     item.window_start, item.window_end, analysis_interval=item.analysis_interval,
                     integration=item.integration, hidden_starts=item.hidden_starts,
                     tuning=item.tuning, conditions=item.conditions)


def tuned_request(request: FitRequest) -> tuple[FitRequest, ParameterEstimate | None]:
    """The request with the white box it is fitted with: a candidate's tuned to its
    baseline's estimates (``Signature.tuning``), a new baseline's that asks for it
    (``estimate``) fitted to its own windows first, any other as given.

    Returns
    -------
    (FitRequest, ParameterEstimate or None)
        The estimate is returned for a new baseline that made one (recorded with it).
    """
    baseline = request.baseline
    if baseline is not None:
        if baseline.tuning is None:
            return request, None
        return replace(request, model=with_parameters(request.model,
                                                      baseline.tuning.parameters())), None
    if not request.estimate:
        return request, None
    try:
        estimate = estimate_parameters(request.model, request.windows, request.estimate)
    except GrayBoxError as error:
        raise GrayBoxError(f"asset {request.asset_id!r}: tuning the white box's "
                           f"{', '.join(request.estimate)} to the "
                           f"baseline's windows: {error}") from error
    return replace(request, model=with_parameters(request.model, estimate.parameters())), estimate


def fit_signatures(requests: Sequence[FitRequest], settings: GrayBoxSettings | None = None,
                   chunk_size: int = 32, clock: StageClock | None = None,
                   cache: SegmentCache | None = None) -> list[Signature | GrayBoxError]:
    """Fit many assets' signatures; all networks of a shape train in batched computations.

    Parameters
    ----------
    requests : sequence of FitRequest
    settings : GrayBoxSettings, optional
        Settings of new baselines (default ``GrayBoxSettings()``). A candidate is always
        fitted with its own baseline's settings, so one call can mix assets whose
        baselines were fitted with different settings.
    chunk_size : int, default 32
        Series per batched network computation (an execution detail: a series' result does
        not depend on it).
    clock : StageClock, optional
        Accumulates the seconds of the stages ``residual``, ``stationarize_ar``, ``network``
        and ``noise``.
    cache : SegmentCache, optional
        Hidden-state estimates of segments fitted before (by a calibration's earlier fits).

    Returns
    -------
    list
        Per request, its :class:`Signature`, or the :class:`GrayBoxError` that stopped it (one
        asset's bad data never stops the others).
    """
    default = settings or GrayBoxSettings()
    groups: dict[GrayBoxSettings, list[int]] = {}
    for position, request in enumerate(requests):
        effective = default if request.baseline is None else request.baseline.settings
        groups.setdefault(effective, []).append(position)
    results: list[Signature | GrayBoxError | None] = [None] * len(requests)
    # these are many small vector products: BLAS threads spin-waiting on a busy machine made
    # each 5 ms instead of microseconds (measured); parallelism belongs to processes
    with threadpool_limits(limits=1):
        for effective, positions in groups.items():
            for position, result in zip(positions, _fit_group([requests[p] for p in positions],
                                                              effective, chunk_size, clock,
                                                              cache)):
                results[position] = result
    return results


def _fit_group(requests: Sequence[FitRequest], settings: GrayBoxSettings,
               chunk_size: int, clock: StageClock | None, cache: SegmentCache | None
               ) -> list[Signature | GrayBoxError]:
    results: list[Signature | GrayBoxError | None] = [None] * len(requests)
    prepared, positions = [], []
    for position, request in enumerate(requests):
        try:
            with timed(clock, "tuning"):
                request, tuning = tuned_request(request)
            prepared.append(_prepare(request, settings, clock, cache))
            prepared[-1].tuning = tuning
            positions.append(position)
        except Exception as error:  # noqa: BLE001 - one asset's data never stops the others
            results[position] = _as_graybox_error(error, request)
    with timed(clock, "network"):
        failed = _fit_networks_isolated(prepared, settings, chunk_size)
    for position, item in zip(positions, prepared):
        if id(item) in failed:
            results[position] = failed[id(item)]
            continue
        try:
            with timed(clock, "noise"):
                results[position] = _finish(item, settings)
        except Exception as error:  # noqa: BLE001
            results[position] = _as_graybox_error(error, item.request)
    return results


def _fit_networks_isolated(prepared: list[_Prepared], settings: GrayBoxSettings,
                           chunk_size: int) -> dict[int, GrayBoxError]:
    """:func:`_fit_networks` of everything at once; if that raises, of each request alone
    (a request's fit does not depend on the others), so only the request that causes the
    error fails. A request whose network came out non-finite fails too (never a NaN
    signature). Returns the errors by ``id`` of the prepared request."""
    failed = {}
    try:
        _fit_networks(prepared, settings, chunk_size)
    except Exception as error:  # noqa: BLE001 - found and reported per request below
        if len(prepared) == 1:
            return {id(prepared[0]): _as_graybox_error(error, prepared[0].request)}
        for item in prepared:
            try:
                _fit_networks([item], settings, chunk_size)
            except Exception as alone:  # noqa: BLE001
                failed[id(item)] = _as_graybox_error(alone, item.request)
    for item in prepared:
        bad = [c.name for c in item.channels if id(item) not in failed and c.nonlinear is not None
               and not (np.isfinite(c.nonlinear.train_mse)
                        and all(np.isfinite(a).all() for a in c.nonlinear.weight_arrays()))]
        if bad:
            failed[id(item)] = GrayBoxError(
                f"asset {item.asset_id!r}: the network of channel(s) {', '.join(bad)} came out "
                f"non-finite (the residual holds values the network cannot fit)")
    return failed


def _as_graybox_error(error: Exception, request: FitRequest) -> GrayBoxError:
    if isinstance(error, GrayBoxError):
        return error
    return GrayBoxError(f"asset {request.asset_id!r}: {type(error).__name__}: {error}")


