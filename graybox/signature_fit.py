"""Batched fleet fitting: telemetry windows -> residual -> the tiers -> signature, for many
assets at once.

:func:`fit_signatures` prepares every request (residual at the telemetry's rate, decimated to
the analysis interval) and fits its early tiers (:mod:`graybox.tiers`: stationarizing and the
AR tier, the network's structure, the level), then each tier's batched part across the
requests (the networks, grouped by shape), then the late tiers (the noise). It names no
tier: it iterates over the kinds it is given. A request's result never depends on the other
requests of the call, and one asset's bad data never stops the others: an error in a
request's own preparation or tiers is its result, and when a batched computation raises,
each of its requests is fitted again alone, so the error is the result of the request that
causes it and the others are unaffected.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from graybox.analysis_rate import choose_analysis_interval, decimate, decimation_factor
from graybox.frozen_map import FrozenMap
from graybox.exceptions import GrayBoxError, InsufficientDataError, ShortWindowsError
from graybox.integration import (DEFAULT_SUBSTEPS, ERROR_POINTS, MAX_SUBSTEPS, Integration,
                                 IntegrationError, choose_integration)
from graybox.models.base import WhiteBoxModel
from graybox.models.spec import ModelSpec
from graybox.operating_conditions import operating_conditions
from graybox.parameter_estimate import ParameterEstimate
from graybox.parameter_estimation import estimate_parameters, with_parameters
from graybox.residual import infer_sample_interval, residual_frame
from graybox.settings import MIN_SAMPLES_TARGET, STRUCTURE_ROOM, GrayBoxSettings
from graybox.signature import ChannelSignature, HiddenStart, Signature
from graybox.stage_clock import StageClock, timed
from graybox.segment_cache import SegmentCache
from graybox.state_estimation import (INITIAL_FIT_MIN_SAMPLES, WindowStates, estimate_states,
                                      window_arrays)
from graybox.telemetry.policy import format_duration
from graybox.telemetry.window import TelemetryWindow, window_periods
from graybox.tiers import TIER_KINDS, Tier
from graybox.tiers.base import channel_fields
from graybox.tiers.fit_state import AssetFit, ChannelFit, per_window


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


def _window_parts(window) -> tuple[list[pd.DataFrame], float, str | None]:
    periods = window_periods(window)
    if not periods:
        raise InsufficientDataError("a window without any operating period")
    interval = getattr(window, "sample_interval", None) or infer_sample_interval(periods[0].index)
    return periods, float(interval), getattr(window, "asset_id", None)


def _operating_segments(parts, settings: GrayBoxSettings, interval: float
                        ) -> tuple[list[pd.DataFrame], list[int]]:
    """Every window's periods as segments, with the window each belongs to. In a window of
    several periods, those shorter than ``settings.shortest_period_samples`` are left out."""
    frames, owners = [], []
    for k, (periods, _, _) in enumerate(parts):
        if len(periods) > 1:
            shortest = settings.shortest_period_samples(interval)
            kept = [p for p in periods if len(p) >= shortest]
            if not kept:
                longest = max(len(p) for p in periods) * interval
                raise ShortWindowsError(
                    f"window {k} starting {periods[0].index[0].isoformat()}: none of its "
                    f"{len(periods)} operating periods is long enough to fit (the longest "
                    f"lasts {longest:g} s; a period needs ar_span + delay_span + "
                    f"derivative_span = {settings.shortest_period:g} s, and at least "
                    f"{settings.shortest_period_samples(interval)} samples)", (k,))
            periods = kept
        frames.extend(periods)
        owners.extend([k] * len(periods))
    return frames, owners


def _prepare(request: FitRequest, settings: GrayBoxSettings, clock: StageClock | None = None,
             cache: SegmentCache | None = None, kinds: Sequence[Tier] = TIER_KINDS) -> AssetFit:
    """The asset's residual at the analysis interval, then its early tiers (``kinds``')."""
    if not request.windows:
        raise InsufficientDataError("no telemetry windows to fit")
    parts = [_window_parts(w) for w in request.windows]
    intervals = {round(p[1], 9) for p in parts}
    if len(intervals) != 1:
        raise GrayBoxError(
            f"windows have different sample intervals: {sorted(intervals)} s (each window's "
            f"is inferred from its timestamps; if they jitter too much to agree, give the "
            f"class's grid its sample interval, e.g. grid = {{ sample_interval = "
            f"\"{format_duration(min(intervals))}\" }})")
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
                                     _shortest_window(frames, owners))
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
        windows = [segment.decimated(factor) for segment in states]
    starts = [frame.index[0] for frame in frames]
    ends = [frame.index[-1] + pd.Timedelta(seconds=interval) for frame in frames]
    hidden = (tuple(HiddenStart(frame.index[0].isoformat(), segment.initial_hidden)
                    for frame, segment in zip(frames, states)) if model.hidden_states else None)
    prepared = AssetFit(request, interval, analysis, min(starts).isoformat(),
                        max(ends).isoformat(), asset_id, integration, hidden, owners, windows,
                        cache,
                        conditions=operating_conditions(model, [s.u for s in states], owners))
    prepared.channels = [ChannelFit(name, decimated[name], request.seed * 1000 + index,
                                    None if baseline is None else baseline.channel(name),
                                    None if baseline is None else baseline.channel(name).structure)
                         for index, name in enumerate(model.outputs)]
    del decimated, states, windows
    for kind in kinds:
        if kind.early:
            with timed(clock, kind.stage):
                kind.fit(prepared, settings)
    # the states and the residual are not needed after the early tiers (memory: the networks
    # of every asset of the call are fitted together)
    prepared.windows = ()
    for channel in prepared.channels:
        channel.segments = []
    return prepared


def _fit_hidden_starts(requests: Sequence[FitRequest], settings: GrayBoxSettings,
                       cache: SegmentCache | None) -> None:
    """The initial hidden states of every request's segments, fitted side by side per white
    box and integrator (:meth:`SegmentCache.fit_starts`) before each request is prepared alone.

    A candidate's are fitted with its baseline's integrator, a new baseline's with the one its
    first estimate uses (:func:`_integrate`; a different choice afterwards is fitted alone); a
    request whose windows are not usable is left to :func:`_prepare` to report.
    """
    if cache is None:
        return
    for request in requests:
        if not request.model.hidden_states:
            continue
        try:
            parts = [_window_parts(w) for w in request.windows]
            interval = parts[0][1]
            frames, _ = _operating_segments(parts, settings, interval)
        except Exception:  # noqa: BLE001 - _prepare raises it for this request
            continue
        integration = (_first_integration(request.model) if request.baseline is None
                       else request.baseline.integration_used)
        for frame in frames:
            try:
                y, u = window_arrays(request.model, frame)
            except Exception:  # noqa: BLE001 - as above
                break
            cache.stage_start(request.model, y, u, interval, integration)
    cache.fit_starts()


def _first_integration(model) -> Integration:
    """The integrator of a new baseline's first hidden-state estimate."""
    return Integration("rosenbrock_w" if model.integrator == "rosenbrock" else "rk4")


#: rows at the start of each segment of a white box with hidden states that the integrator
#: is not judged at: the hidden start is fitted to a segment's first samples (at least
#: :data:`~graybox.state_estimation.INITIAL_FIT_MIN_SAMPLES`, these) and is least determined
#: at the first of them, where an error in a lightly damped mode's start rings before it
#: decays (the 10-Hz servo's velocity: 3 m/s at its first row, below 0.1 m/s after it; its
#: RK4 start at 4 sub-steps -1.3 m/s, 0.06 at the next row); a model no integrator follows
#: fails on the rows after them as on those
HIDDEN_START_ROWS = INITIAL_FIT_MIN_SAMPLES


def _judged_rows(model, window: WindowStates) -> np.ndarray:
    """Which of a segment's rows the integrator is judged at
    (:func:`graybox.integration.choose_integration`): all but the first
    :data:`HIDDEN_START_ROWS` where the model has hidden states, every row otherwise."""
    judged = np.ones(len(window.states), dtype=bool)
    if model.hidden_states:
        judged[:HIDDEN_START_ROWS] = False
    return judged


def _first_estimate(model, y: np.ndarray, u: np.ndarray, interval: float, estimate
                    ) -> tuple[Integration, WindowStates]:
    """A new baseline's first hidden-state estimate of one segment and its integrator.

    An ``"auto"`` white box's is RK4 at the default sub-steps, then, where that diverges,
    RK4 at twice as many up to the most the choice takes (a lightly damped fast mode: the
    10-Hz servo's follows at 4 and is accurate at 32), then ``rosenbrock_w`` (a stiff one).
    """
    first = _first_integration(model)
    if model.integrator != "auto":
        return first, estimate(model, y, u, interval, first)
    while True:
        try:
            return first, estimate(model, y, u, interval, first)
        except IntegrationError:
            if 2 * first.substeps > MAX_SUBSTEPS // 2:
                break
            first = Integration("rk4", 2 * first.substeps)
    stiff = Integration("rosenbrock_w")
    return stiff, estimate(model, y, u, interval, stiff)


def _integrate(request: FitRequest, frames: Sequence[pd.DataFrame], interval: float,
               cache: SegmentCache | None) -> tuple[Integration, list[WindowStates]]:
    """The integrator (a candidate: its baseline's) and every segment's full state.

    A new baseline's integrator is chosen at the data's own states
    (:func:`graybox.integration.choose_integration`); hidden states are first estimated with
    RK4 (:func:`_first_estimate`: more sub-steps or ``rosenbrock_w`` where RK4 at the default
    diverges on the first segment, and ``rosenbrock_w`` where the model asks for it), and
    again if the choice differs.
    """
    model = request.model
    arrays = [window_arrays(model, frame) for frame in frames]
    estimate = estimate_states if cache is None else cache.estimate
    if request.baseline is not None:
        integration = request.baseline.integration_used
        return integration, [estimate(model, y, u, interval, integration)
                             for y, u in arrays]
    stiff = Integration("rosenbrock_w")
    first, head = _first_estimate(model, *arrays[0], interval, estimate)
    # a white box that no integrator follows fails on its first segment, not after the
    # whole baseline's estimates (a 10-Hz servo's: 400 s and 5 GB an asset)
    chosen = _check_integrable(model, head, interval)
    states = [head]
    if first.method == "rk4" and first.substeps > DEFAULT_SUBSTEPS:
        # RK4 diverged at the default sub-steps: every segment estimated with the first
        # segment's choice (the 10-Hz servo's RK4 follows at 4 sub-steps, the choice takes
        # 32), not with the first estimate's and then again, their hidden starts fitted side
        # by side (a 10-Hz segment's start fit at 32 sub-steps: 150 s of CPU alone)
        if chosen is not None and chosen != first:
            first, states = chosen, []
        if cache is not None:
            for y, u in arrays[len(states):]:
                cache.stage_start(model, y, u, interval, first)
            cache.fit_starts()
    try:
        states += [estimate(model, y, u, interval, first) for y, u in arrays[len(states):]]
    except IntegrationError:
        if model.integrator != "auto" or first == stiff:
            raise
        first = stiff
        states = [estimate(model, y, u, interval, first) for y, u in arrays]
    integration = _choose_at(model, states, interval)
    if integration != first and model.hidden_states:
        states = [estimate(model, y, u, interval, integration) for y, u in arrays]
    return integration, states


def _check_integrable(model, window: WindowStates, interval: float) -> Integration | None:
    """The integrator chosen at one segment's states (at its :func:`_judged_rows`), raising
    :class:`IntegrationError` where none reaches the bound
    (:func:`graybox.integration.choose_integration`; the baseline's choice itself is made on
    every segment's states after). A segment shorter than the choice's sample points is not
    judged alone (None)."""
    finite = np.isfinite(window.states).all(axis=1) & np.isfinite(window.u).all(axis=1)
    if finite.sum() <= ERROR_POINTS:
        return None
    return _choose_at(model, [window], interval)


def _choose_at(model, windows: Sequence[WindowStates], interval: float) -> Integration:
    """:func:`graybox.integration.choose_integration` at the segments' finite states, judged at
    their :func:`_judged_rows`, the bound's unit (each state's RMS sample-to-sample change)
    from those rows too: a wrong start's jump would widen it."""
    x = np.concatenate([w.states for w in windows])
    u = np.concatenate([w.u for w in windows])
    rows = [_judged_rows(model, w) for w in windows]
    if all(r.sum() < 2 for r in rows):
        # every segment within its hidden start's rows (short operating periods of a slow
        # logger): judged at all of them, not at none (a bound of no steps is NaN)
        rows = [np.ones(len(w.states), dtype=bool) for w in windows]
    finite = np.isfinite(x).all(axis=1) & np.isfinite(u).all(axis=1)
    steps = np.concatenate([np.diff(w.states[r], axis=0) for w, r in zip(windows, rows)])
    change = np.sqrt(np.nanmean(steps ** 2, axis=0))
    return choose_integration(model, x[finite], u[finite], interval, change,
                              np.concatenate(rows)[finite])


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


def _finish(item: AssetFit, settings: GrayBoxSettings, clock: StageClock | None,
            kinds: Sequence[Tier]) -> Signature:
    """Fit the late tiers (the noise) and assemble the signature."""
    for kind in kinds:
        if not kind.early:
            with timed(clock, kind.stage):
                kind.fit(item, settings)
    channels = tuple(ChannelSignature(channel.name, channel.structure,
                                      n_samples=channel.n_samples, selection=channel.selection,
                                      **channel_fields(kinds, channel.records))
                     for channel in item.channels)
    return Signature(channels, ModelSpec.from_model(item.request.model), settings.residual,
                     item.sample_interval, channels[0].n_samples, settings, item.asset_id,
                     item.window_start, item.window_end, analysis_interval=item.analysis_interval,
                     integration=item.integration, hidden_starts=item.hidden_starts,
                     tuning=item.tuning, conditions=item.conditions,
                     holds=holds_over(item.request.windows))


def holds_over(windows) -> FrozenMap | None:
    """Per channel, the longest hold over ``windows`` (``TelemetryWindow.holds``; a frame has
    none); None where there is none."""
    longest: dict[str, float] = {}
    for window in windows:
        for channel, seconds in (window.holds if isinstance(window, TelemetryWindow) else ()):
            longest[channel] = max(seconds, longest.get(channel, 0.0))
    return FrozenMap(longest) if longest else None


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
                   cache: SegmentCache | None = None, kinds: Sequence[Tier] = TIER_KINDS
                   ) -> list[Signature | GrayBoxError]:
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
        Accumulates the seconds of the stages ``tuning``, ``residual`` and each tier's
        :attr:`~graybox.tiers.base.Tier.stage` (``stationarize_ar``, ``network``, ``noise``;
        the level tier's is ``residual``).
    cache : SegmentCache, optional
        Hidden-state estimates of segments fitted before (by a calibration's earlier fits).
    kinds : sequence of Tier, default TIER_KINDS
        The tiers fitted, in order (:mod:`graybox.tiers.base`): the built-in ones, and any
        tier added after them (its records kept in ``ChannelSignature.tiers``).

    Returns
    -------
    list
        Per request, its :class:`Signature`, or the :class:`GrayBoxError` that stopped it (one
        asset's bad data never stops the others).
    """
    default = settings or GrayBoxSettings()
    groups: dict[GrayBoxSettings, list[int]] = {}
    for position, request in enumerate(requests):
        effective = (_resolved(default, request) if request.baseline is None
                     else request.baseline.settings)
        groups.setdefault(effective, []).append(position)
    results: list[Signature | GrayBoxError | None] = [None] * len(requests)
    # these are many small vector products: BLAS threads spin-waiting on a busy machine made
    # each 5 ms instead of microseconds (measured); parallelism belongs to processes
    with threadpool_limits(limits=1):
        # per group of requests with the same settings: tune each white box, fit the hidden
        # starts side by side, prepare each asset (its residual and early tiers), every
        # tier's batched fit across the group's assets, then each asset's late tiers
        for group_settings, positions in groups.items():
            tuned: dict[int, tuple[FitRequest, ParameterEstimate | None]] = {}
            for position in positions:
                try:
                    with timed(clock, "tuning"):
                        tuned[position] = tuned_request(requests[position])
                except Exception as error:  # noqa: BLE001 - one asset never stops the others
                    results[position] = _as_graybox_error(error, requests[position])
            group_cache = cache
            if group_cache is None and any(t[0].model.hidden_states for t in tuned.values()):
                group_cache = SegmentCache(storing=False)
            with timed(clock, "residual"):
                _fit_hidden_starts([t[0] for t in tuned.values()], group_settings, group_cache)
            prepared: dict[int, AssetFit] = {}
            for position, (request, tuning) in tuned.items():
                try:
                    prepared[position] = _prepare(request, group_settings, clock, group_cache,
                                                  kinds)
                    prepared[position].tuning = tuning
                except Exception as error:  # noqa: BLE001 - as above
                    results[position] = _as_graybox_error(error, request)
            failed = _fit_batched(list(prepared.values()), group_settings, chunk_size, kinds,
                                  clock)
            for position, item in prepared.items():
                try:
                    results[position] = (failed[id(item)] if id(item) in failed else
                                         _finish(item, group_settings, clock, kinds))
                except Exception as error:  # noqa: BLE001
                    results[position] = _as_graybox_error(error, item.request)
            del prepared         # the group's residuals, not held while the next is prepared
    # a candidate of several nights whose earlier night ran too little is fitted on the
    # nights that ran; one whose own (last) night ran too little keeps its error
    short = [p for p, r in enumerate(requests)
             if r.baseline is not None and isinstance(results[p], ShortWindowsError)]
    if short:
        _, refitted = without_short_windows(
            [requests[p] for p in short], [results[p] for p in short],
            lambda again: fit_signatures(again, settings, chunk_size, clock, cache, kinds),
            least=1, keep_last=True)
        for p, result in zip(short, refitted):
            results[p] = result
    return results


#: windows a baseline keeps at the least when it leaves out those with too little operation
MIN_BASELINE_WINDOWS = 3


def without_short_windows(requests: Sequence[FitRequest], results: list,
                          refit: Callable[[list[FitRequest]], list], least: int,
                          keep_last: bool = False) -> tuple[list[FitRequest], list]:
    """The fits of ``requests`` (``results``) redone without their windows that held too
    little operation to fit (a wind turbine's calm day, a machine idle most of a day: a
    :class:`ShortWindowsError` names them), where at least ``least`` others remain (and,
    with ``keep_last``, the last window is not one of them: a candidate's own night). Each
    refitted signature records the windows left out (``Signature.left_out``, their first
    timestamps); the others are returned as they are.

    Returns
    -------
    (requests, results)
        The requests as fitted at last, and their results.
    """
    requests, results = list(requests), list(results)
    left_out: dict[int, list[str]] = {}
    while True:
        retry = []
        for p, result in enumerate(results):
            if not isinstance(result, ShortWindowsError) or not result.windows:
                continue
            windows = requests[p].windows
            short = set(result.windows)
            kept = [w for k, w in enumerate(windows) if k not in short]
            if (len(kept) < least or len(kept) == len(windows)
                    or (keep_last and len(windows) - 1 in short)):
                continue
            left_out.setdefault(p, []).extend(window_periods(w)[0].index[0].isoformat()
                                              for k, w in enumerate(windows) if k in short)
            requests[p] = replace(requests[p], windows=kept)
            retry.append(p)
        if not retry:
            break
        for p, result in zip(retry, refit([requests[p] for p in retry])):
            results[p] = result
    for p, starts in left_out.items():
        if isinstance(results[p], Signature):
            results[p] = replace(results[p], left_out=tuple(sorted(starts)))
    return requests, results




def _resolved(settings: GrayBoxSettings, request: FitRequest) -> GrayBoxSettings:
    """A new baseline's settings with ``min_samples = "auto"`` resolved from its shortest
    window's operating samples (:meth:`GrayBoxSettings.for_windows`); windows that cannot be
    read here get the target count, and :func:`_prepare` reports what is wrong with them."""
    if settings.min_samples != "auto":
        return settings
    try:
        parts = [_window_parts(w) for w in request.windows]
        shortest = _shortest_window(*_operating_segments(parts, settings, parts[0][1]))
    except Exception:  # noqa: BLE001 - _prepare raises it for this request
        return settings.for_windows(MIN_SAMPLES_TARGET + STRUCTURE_ROOM)
    return settings.for_windows(shortest)


def _shortest_window(frames: Sequence[pd.DataFrame], owners: Sequence[int]) -> int:
    """Operating samples of the window with the fewest (:func:`_operating_segments`' output)."""
    return int(per_window([len(f) for f in frames], owners).min())


def _fit_batched(prepared: list[AssetFit], settings: GrayBoxSettings, chunk_size: int,
                 kinds: Sequence[Tier] = TIER_KINDS, clock: StageClock | None = None
                 ) -> dict[int, GrayBoxError]:
    """Every tier's :meth:`~graybox.tiers.base.Tier.fit_batch` of all assets at once; where
    that raises, of each asset alone (an asset's fit does not depend on the others), so only
    the asset that causes the error fails. Returns the errors by ``id`` of the asset."""
    failed: dict[int, GrayBoxError] = {}
    for kind in kinds:
        items = [item for item in prepared if id(item) not in failed]
        with timed(clock, kind.stage):
            try:
                failed.update(kind.fit_batch(items, settings, chunk_size))
            except Exception as error:  # noqa: BLE001 - found and reported per asset below
                if len(items) == 1:
                    failed[id(items[0])] = _as_graybox_error(error, items[0].request)
                    continue
                for item in items:
                    try:
                        failed.update(kind.fit_batch([item], settings, chunk_size))
                    except Exception as alone:  # noqa: BLE001
                        failed[id(item)] = _as_graybox_error(alone, item.request)
    return failed


def _as_graybox_error(error: Exception, request: FitRequest) -> GrayBoxError:
    """The error of one request, its message naming the asset (a GrayBoxError keeps its
    class; one raised below the request, such as the white box's, is told whose it is)."""
    named = f"asset {request.asset_id!r}"
    if not isinstance(error, GrayBoxError):
        return GrayBoxError(f"{named}: {type(error).__name__}: {error}")
    if request.asset_id and named not in str(error) and len(error.args) == 1:
        error.args = (f"{named}: {error.args[0]}",)
    return error


