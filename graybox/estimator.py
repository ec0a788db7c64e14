"""The gray box: telemetry -> residual -> three tiers -> signature, for one asset or a fleet.

:class:`GrayBox` is the estimator a user meets. :func:`fit_signatures` and
:func:`fit_baselines` are the fleet forms it is built on: they take many assets at once and
fit all their networks in batched computations (grouped by network shape).
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, replace
from typing import Sequence

import numpy as np
import pandas as pd

from graybox.calibration import Calibration, TierThreshold, threshold_from_deltas
from graybox.drift import Drift, compute_drift, tier_deltas
from graybox.embedding import choose_delay, choose_dimension
from graybox.exceptions import GrayBoxError, InsufficientDataError
from graybox.linear_tier import LinearTier, fit_ar
from graybox.models.base import WhiteBoxModel
from graybox.noise_tier import describe_noise
from graybox.nonlinear_tier import (FitSettings, NonlinearTier, fit_networks, initial_weights,
                                    lagged)
from graybox.residual import RESIDUAL_METHODS, infer_sample_interval, residual_frame
from graybox.signature import (TIERS, ChannelSignature, ChannelStructure, Selection, Signature)
from graybox.stationarize import choose_differencing


@dataclass(frozen=True)
class GrayBoxSettings:
    """Every choice of the method that is not learned from data.

    Attributes
    ----------
    residual : {"one_step", "inverse"}
        Eqs. 2-3 or Eq. 13.
    max_ar_order : int
    ar_criterion : {"bic", "aic"}
    max_diff_order, max_seasonal_order : int
        Upper bounds of ``m1`` and ``m2``.
    hidden_units : int
        ``J`` of the Eq. 25 network.
    max_delay, max_embedding_dim : int
        Upper bounds of ``tau`` and ``m``.
    holdout_fraction : float
        Tail of each baseline window held out to decide whether the network is needed.
    min_heldout_gain : float
        Relative held-out error reduction the network must achieve to count as needed.
    network : FitSettings
        Optimizer settings (identical for baselines, calibration refits and candidates).
    nn_scale_factor : float
        The network sees the AR residual divided by this many of its baseline standard
        deviations, which keeps targets well inside tanh's (-1, 1).
    min_samples : int
        Fewest residual samples per window after differencing and embedding.
    calibration_splits : int
        Pieces each healthy window is cut into for calibrating epsilon.
    null_network : {"fixed_features", "trained"}
        How a network is fitted where the baseline has no nonlinear structure to explain.
        ``"fixed_features"``: the hidden layer stays at seeded random weights and only the
        output weights are fitted (one minimum, so healthy zeta is stable). ``"trained"``:
        every weight is fitted from the same seeded start (more sensitive to a nonlinearity
        that appears, but a network fitted to noise can land in another shallow minimum).
    """

    residual: str = "one_step"
    max_ar_order: int = 20
    ar_criterion: str = "bic"
    max_diff_order: int = 2
    max_seasonal_order: int = 1
    hidden_units: int = 8
    max_delay: int = 20
    max_embedding_dim: int = 6
    holdout_fraction: float = 0.2
    min_heldout_gain: float = 0.01
    network: FitSettings = FitSettings()
    nn_scale_factor: float = 4.0
    min_samples: int = 200
    calibration_splits: int = 8
    null_network: str = "fixed_features"

    def __post_init__(self):
        if self.residual not in RESIDUAL_METHODS:
            raise ValueError(f"residual must be one of {RESIDUAL_METHODS}, got {self.residual!r}")
        if self.ar_criterion not in ("aic", "bic"):
            raise ValueError(f"ar_criterion must be 'aic' or 'bic', got {self.ar_criterion!r}")
        if not 0 < self.holdout_fraction < 1:
            raise ValueError("holdout_fraction must be in (0, 1)")
        if self.null_network not in ("fixed_features", "trained"):
            raise ValueError(f"null_network must be 'fixed_features' or 'trained', "
                             f"got {self.null_network!r}")

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "GrayBoxSettings":
        data = dict(data)
        if "network" in data and isinstance(data["network"], dict):
            data["network"] = FitSettings(**data["network"])
        return cls(**data)


@dataclass(frozen=True)
class FitRequest:
    """One asset's fit in a fleet batch.

    Attributes
    ----------
    model : WhiteBoxModel
    windows : sequence of TelemetryWindow or DataFrame
        Uniform-grid telemetry; each window is a separate segment (its residual, differences
        and delays never cross into another window).
    baseline : Signature, optional
        Frozen structure to fit with (a candidate). None fits a new baseline structure.
    warm_start : Signature, optional
        Network weights to start from; defaults to ``baseline``.
    asset_id : str, optional
    seed : int
        Seeds the random initial weights of a new baseline.
    """

    model: WhiteBoxModel
    windows: Sequence
    baseline: Signature | None = None
    warm_start: Signature | None = None
    asset_id: str | None = None
    seed: int = 0


@dataclass
class _Channel:
    name: str
    structure: ChannelStructure | None
    linear: LinearTier
    w_segments: list[np.ndarray]
    n_samples: int
    selection: Selection | None = None
    nonlinear: NonlinearTier | None = None


@dataclass
class _Prepared:
    request: FitRequest
    sample_interval: float
    window_start: str | None
    window_end: str | None
    asset_id: str | None
    channels: list[_Channel] = field(default_factory=list)


def _window_parts(window) -> tuple[pd.DataFrame, float, str | None]:
    frame = getattr(window, "frame", window)
    if not isinstance(frame, pd.DataFrame):
        raise TypeError(f"expected a TelemetryWindow or DataFrame, got {type(window).__name__}")
    interval = getattr(window, "sample_interval", None) or infer_sample_interval(frame.index)
    return frame, float(interval), getattr(window, "asset_id", None)


def _prepare(request: FitRequest, settings: GrayBoxSettings) -> _Prepared:
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
    residuals = [residual_frame(request.model, frame, settings.residual, interval)
                 for frame, _, _ in parts]
    starts = [frame.index[0] for frame, _, _ in parts]
    ends = [frame.index[-1] + pd.Timedelta(seconds=interval) for frame, _, _ in parts]
    prepared = _Prepared(request, interval, min(starts).isoformat(), max(ends).isoformat(),
                         asset_id)
    for index, name in enumerate(request.model.states):
        segments = [r[name].to_numpy() for r in residuals]
        frozen = None if baseline is None else baseline.channel(name).structure
        prepared.channels.append(_prepare_channel(name, segments, frozen, settings,
                                                  seed=request.seed * 1000 + index))
    return prepared


def _prepare_channel(name: str, segments: list[np.ndarray], frozen: ChannelStructure | None,
                     settings: GrayBoxSettings, seed: int) -> _Channel:
    selection = None
    if frozen is None:
        choice = choose_differencing(segments, settings.max_diff_order, settings.max_seasonal_order)
        differencing = choice.differencing
    else:
        differencing = frozen.differencing
    too_short = [i for i, s in enumerate(segments) if len(s) <= differencing.lost + settings.min_samples]
    if too_short:
        raise InsufficientDataError(
            f"channel {name!r}: window(s) {too_short} have too few samples for differencing "
            f"{differencing} plus {settings.min_samples} samples")
    y = [differencing.apply(s) for s in segments]
    if frozen is None:
        pooled = np.concatenate(y)
        center, scale = float(pooled.mean()), float(pooled.std())
        if scale <= 0:
            raise InsufficientDataError(f"channel {name!r}: the residual is constant")
    else:
        center, scale = frozen.center, frozen.scale
    z = [(s - center) / scale for s in y]
    if frozen is None:
        linear = fit_ar(z, max_order=settings.max_ar_order, criterion=settings.ar_criterion)
        selection = Selection(choice.acf_area, choice.raw_acf_area, choice.adf_statistic,
                              choice.candidate_period, settings.ar_criterion)
    else:
        linear = fit_ar(z, order=frozen.ar_order)
    w = [linear.innovations(s) for s in z]
    n_samples = int(sum(len(s) for s in z))
    if frozen is None:
        pooled_w = np.concatenate(w)
        longest = max(w, key=len)
        tau = choose_delay(longest, settings.max_delay)
        dim = choose_dimension(longest, tau, settings.max_embedding_dim)
        nn_scale = settings.nn_scale_factor * float(pooled_w.std())
        structure = ChannelStructure(
            period=differencing.period, seasonal_order=differencing.seasonal_order,
            diff_order=differencing.order, ar_order=linear.order, center=center, scale=scale,
            tau=tau, embedding_dim=dim, hidden_units=settings.hidden_units, nn_scale=nn_scale,
            nonlinear_needed=False,  # decided after the held-out fit
            init_seed=seed)
    else:
        structure = frozen
    span = structure.embedding_dim * structure.tau
    if min(len(s) for s in w) <= span + settings.min_samples // 2:
        raise InsufficientDataError(f"channel {name!r}: too few samples for the network's "
                                    f"{structure.embedding_dim} delays of {structure.tau}")
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
                                train_input_weights=needed or retrain)
            for (item, _, channel), fit in zip(members_now, fits):
                channel.nonlinear = NonlinearTier.from_arrays(fit.w, fit.W, fit.mse, None,
                                                              fit.iterations)
        if fresh:
            _fit_fresh(fresh, hidden, settings, chunk_size)


def _fit_fresh(members, hidden: int, settings: GrayBoxSettings, chunk_size: int) -> None:
    """New baselines: fit on the head of every window, measure the gain on the held-out tails,
    decide whether the tier is needed, then fit on everything."""
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
    head_fits = fit_networks(train, hidden, None, settings.network, random_state=seeds,
                             chunk_size=chunk_size)
    gains = []
    for (_, _, channel), head, (X_test, y_test) in zip(members, head_fits, test):
        prediction = np.tanh(np.tanh(X_test @ head.w.T) @ head.W)
        zero_error = float(np.mean(y_test ** 2))
        gains.append(1.0 - float(np.mean((y_test - prediction) ** 2)) / zero_error
                     if zero_error > 0 else 0.0)
        channel.structure = replace(channel.structure,
                                    nonlinear_needed=bool(gains[-1] > settings.min_heldout_gain))
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
        fits = fit_networks(problems, hidden, None, settings.network,
                            random_state=[seeds[i] for i in chosen], chunk_size=chunk_size,
                            train_input_weights=needed or settings.null_network == "trained")
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
                                         describe_noise(noise), channel.n_samples, channel.selection))
    return Signature(tuple(channels), item.request.model.to_dict(), settings.residual,
                     item.sample_interval, channels[0].n_samples, settings.to_dict(), item.asset_id,
                     item.window_start, item.window_end)


def fit_signatures(requests: Sequence[FitRequest], settings: GrayBoxSettings | None = None,
                   chunk_size: int = 32) -> list[Signature | GrayBoxError]:
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

    Returns
    -------
    list
        Per request, its :class:`Signature`, or the :class:`GrayBoxError` that stopped it (one
        asset's bad data never stops the others).
    """
    default = settings or GrayBoxSettings()
    groups: dict[str, tuple[GrayBoxSettings, list[int]]] = {}
    for position, request in enumerate(requests):
        effective = (default if request.baseline is None
                     else GrayBoxSettings.from_dict(request.baseline.settings))
        key = json.dumps(effective.to_dict(), sort_keys=True)
        groups.setdefault(key, (effective, []))[1].append(position)
    results: list[Signature | GrayBoxError | None] = [None] * len(requests)
    for effective, positions in groups.values():
        for position, result in zip(positions, _fit_group([requests[p] for p in positions],
                                                          effective, chunk_size)):
            results[position] = result
    return results


def _fit_group(requests: Sequence[FitRequest], settings: GrayBoxSettings,
               chunk_size: int) -> list[Signature | GrayBoxError]:
    results: list[Signature | GrayBoxError | None] = [None] * len(requests)
    prepared, positions = [], []
    for position, request in enumerate(requests):
        try:
            prepared.append(_prepare(request, settings))
            positions.append(position)
        except (GrayBoxError, np.linalg.LinAlgError) as error:
            results[position] = _as_graybox_error(error, request)
    _fit_networks(prepared, settings, chunk_size)
    for position, item in zip(positions, prepared):
        try:
            results[position] = _finish(item, settings)
        except (GrayBoxError, np.linalg.LinAlgError) as error:
            results[position] = _as_graybox_error(error, item.request)
    return results


def _as_graybox_error(error: Exception, request: FitRequest) -> GrayBoxError:
    if isinstance(error, GrayBoxError):
        return error
    return GrayBoxError(f"asset {request.asset_id!r}: {type(error).__name__}: {error}")


def fit_baselines(requests: Sequence[FitRequest], settings: GrayBoxSettings | None = None,
                  false_alarm_rate: float = 0.01, chunk_size: int = 32
                  ) -> list[tuple[Signature, Calibration] | GrayBoxError]:
    """Fit baselines and calibrate their epsilons (see :mod:`graybox.calibration`).

    Each request's windows are its K >= 3 healthy windows, each as long as a nightly window
    (typically one day). Each window is left out in turn: the others refit the baseline, and
    the window, cut into ``settings.calibration_splits`` pieces, is fitted as nightly
    candidates of that refit. All assets' refits are batched like the baselines.

    Returns
    -------
    list
        Per request ``(signature, calibration)`` or the error that stopped it.
    """
    if not 0 < false_alarm_rate < 1:
        raise ValueError(f"false_alarm_rate must be in (0, 1), got {false_alarm_rate}")
    settings = settings or GrayBoxSettings()
    fresh = [replace(r, baseline=None, warm_start=None) for r in requests]
    signatures = fit_signatures(fresh, settings, chunk_size)
    results: list = list(signatures)
    jobs = []  # (position, baseline signature, number of windows)
    for position, (request, signature) in enumerate(zip(fresh, signatures)):
        if isinstance(signature, GrayBoxError):
            continue
        if len(request.windows) < 3:
            results[position] = InsufficientDataError(
                f"asset {signature.asset_id!r}: calibration needs at least 3 healthy windows "
                f"(one per night), got {len(request.windows)}")
            continue
        jobs.append((position, signature, len(request.windows)))
    # every window is left out once: the others refit the baseline (frozen structure)...
    rest_requests = [replace(fresh[p], windows=[w for j, w in enumerate(fresh[p].windows) if j != k],
                             baseline=sig)
                     for p, sig, count in jobs for k in range(count)]
    rests = fit_signatures(rest_requests, settings, chunk_size)
    # ...and the left-out window's pieces are fitted as nightly candidates of that refit
    piece_requests, owners = [], []
    for (p, sig, count), first in zip(jobs, np.cumsum([0] + [c for _, _, c in jobs])):
        for k in range(count):
            rest = rests[first + k]
            for piece in _split(fresh[p].windows[k], settings.calibration_splits):
                piece_requests.append(replace(fresh[p], windows=[piece], baseline=sig,
                                              warm_start=rest if isinstance(rest, Signature) else sig))
                owners.append((p, first + k))
    pieces = fit_signatures(piece_requests, settings, chunk_size)
    collected: dict[int, list] = {p: [] for p, _, _ in jobs}
    for (p, rest_index), piece in zip(owners, pieces):
        collected[p].append((rests[rest_index], piece))
    for p, sig, count in jobs:
        pairs = collected[p]
        failure = next((x for pair in pairs for x in pair if isinstance(x, GrayBoxError)), None)
        if failure is not None:
            results[p] = failure
            continue
        results[p] = (sig, _calibrate(sig, pairs, count, false_alarm_rate))
    return results


def _split(window, parts: int) -> list[pd.DataFrame]:
    """Cut a window into ``parts`` contiguous pieces of (nearly) equal length."""
    frame = getattr(window, "frame", window)
    bounds = np.linspace(0, len(frame), parts + 1).round().astype(int)
    return [frame.iloc[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


def _calibrate(baseline: Signature, pairs: list[tuple[Signature, Signature]], windows: int,
               false_alarm_rate: float) -> Calibration:
    """Epsilons from (rest, piece) pairs: a piece of a window against the baseline refitted
    without that window, rescaled to a night against the full baseline."""
    alpha = false_alarm_rate / (len(baseline.channels) * len(TIERS))
    total = baseline.n_samples
    reference = total / windows
    thresholds = []
    for channel in baseline.channel_names:
        for tier in TIERS:
            deltas = []
            for rest, piece in pairs:
                delta = tier_deltas(piece.channel(channel), rest.channel(channel), tier)[1]
                # Var(theta_n) ~ V / n: the piece and its reference are independent, so the
                # change has variance V (1/n_piece + 1/n_rest); a night against the baseline
                # has V (1/n_night + 1/n_baseline)
                scale = (1 / reference + 1 / total) / (1 / piece.n_samples + 1 / rest.n_samples)
                deltas.append(delta * np.sqrt(scale))
            epsilon, mean, dof = threshold_from_deltas(deltas, alpha)
            thresholds.append(TierThreshold(channel, tier, epsilon, mean, dof,
                                            tuple(float(d @ d) for d in deltas)))
    return Calibration(tuple(thresholds), false_alarm_rate, alpha, int(round(reference)),
                       len(pairs))


class GrayBox:
    """The gray-box estimator for one asset.

    Without ``baseline`` it learns a structure and healthy parameters from K >= 3 healthy
    windows and calibrates epsilon (``signature_``, ``calibration_``). With ``baseline`` it
    fits a candidate with the baseline's frozen structure, starting from the baseline's
    network weights, so that zeta measures drift rather than the optimizer's luck.

    Parameters
    ----------
    model : WhiteBoxModel
        The physics model used as residual filter.
    baseline : Signature, optional
        Fit a candidate against this baseline.
    settings : GrayBoxSettings, optional
        Defaults to ``GrayBoxSettings()`` for a baseline and to the baseline's own settings
        for a candidate.
    false_alarm_rate : float, default 0.01
        Target false alarms per asset and window, sets epsilon.
    calibrate : bool, default True
        Calibrate epsilon when fitting a baseline (needs at least 3 windows).
    random_state : int, default 0
        Seeds the random initial network weights of a baseline.

    Attributes
    ----------
    signature_ : Signature
    calibration_ : Calibration or None

    Examples
    --------
    >>> baseline = GrayBox(model).fit(healthy_days)                       # doctest: +SKIP
    >>> candidate = GrayBox(model, baseline=baseline.signature_).fit(night)   # doctest: +SKIP
    >>> drift = compute_drift(candidate.signature_, baseline.signature_,
    ...                       baseline.calibration_)                        # doctest: +SKIP
    """

    def __init__(self, model: WhiteBoxModel, baseline: Signature | None = None,
                 settings: GrayBoxSettings | None = None, false_alarm_rate: float = 0.01,
                 calibrate: bool = True, random_state: int = 0):
        self.model = model
        self.baseline = baseline
        self.settings = settings
        self.false_alarm_rate = false_alarm_rate
        self.calibrate = calibrate
        self.random_state = random_state

    def fit(self, windows) -> "GrayBox":
        """Fit on one window or a sequence of windows (TelemetryWindow or uniform-grid DataFrame).

        Returns
        -------
        self
        """
        windows = [windows] if isinstance(windows, pd.DataFrame) or hasattr(windows, "frame") else list(windows)
        settings = self.settings
        if self.baseline is not None:
            if settings is not None and settings.to_dict() != self.baseline.settings:
                raise GrayBoxError("a candidate must be fitted with its baseline's settings "
                                   "(leave settings out, or GrayBoxSettings.from_dict("
                                   "baseline.settings))")
            settings = GrayBoxSettings.from_dict(self.baseline.settings)
        settings = settings or GrayBoxSettings()
        request = FitRequest(self.model, windows, self.baseline, seed=self.random_state)
        self.calibration_ = None
        if self.baseline is None and self.calibrate:
            result = fit_baselines([request], settings, self.false_alarm_rate)[0]
            if isinstance(result, GrayBoxError):
                raise result
            self.signature_, self.calibration_ = result
        else:
            result = fit_signatures([request], settings)[0]
            if isinstance(result, GrayBoxError):
                raise result
            self.signature_ = result
        return self

    def drift(self, windows) -> Drift:
        """Fit a candidate on ``windows`` against this fitted baseline and return its drift."""
        candidate = GrayBox(self.model, baseline=self.signature_, settings=self.settings).fit(windows)
        return compute_drift(candidate.signature_, self.signature_, self.calibration_)
