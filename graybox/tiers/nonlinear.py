"""The nonlinear tier's kind: the Eq. 25 tanh network of the AR residual
(:mod:`graybox.nonlinear_tier`), its structure chosen per asset and its training batched
across assets, and its drift measured in function space."""
from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Iterator, Sequence

import numpy as np

from graybox.channel_structure import ChannelStructure
from graybox.embedding import choose_delay, choose_dimension
from graybox.exceptions import GrayBoxError, InsufficientDataError, StructureMismatchError
from graybox.network_settings import FitSettings, NetworkFit
from graybox.nonlinear_tier import (NonlinearTier, fit_networks, initial_weights,
                                   lagged_segments, window_centred)
from graybox.settings import GrayBoxSettings
from graybox.tiers.base import Tier
from graybox.tiers.fit_state import AssetFit, ChannelFit, per_window

if TYPE_CHECKING:  # pragma: no cover - typing only
    from graybox.signature import ChannelSignature


class NonlinearTierKind(Tier):
    """The network tier: output weights ``W_1j`` then input weights ``w_jk``.

    Its parameters are the weights, and :meth:`parameter_changes` their changes, so that Eq. 28
    is recorded and shown. The alarm measure (:meth:`deltas`) is the change of the network's
    *function* on a fixed reference set of delay vectors: hidden units permute and flip sign
    (``tanh`` is odd: ``(w_j, W_1j) -> (-w_j, -W_1j)``) and trade weight along flat directions
    while the function stays the same, so two fits of equally healthy data can land far apart
    in weight space; their functions cannot. A structure without ``reference_points`` (stored
    before the measure existed) keeps Eq. 28 on the weights.
    """

    name = "nonlinear"
    field = "nonlinear"
    record_type = NonlinearTier
    stage = "network"

    def fit(self, asset: AssetFit, settings: GrayBoxSettings) -> None:
        """Choose a new baseline's embedding (delay, dimension, scale) from the AR residual
        (:func:`choose_delay`, :func:`choose_dimension`) and check every window leaves the
        network enough delay vectors; the network itself is trained in :meth:`fit_batch`."""
        interval = asset.analysis_interval
        for channel in asset.channels:
            w = channel.w_segments
            if channel.reference is None:
                longest = max(w, key=len)
                tau = choose_delay(longest, settings.max_delay(interval))
                channel.structure = replace(
                    channel.structure, tau=tau,
                    embedding_dim=choose_dimension(longest, tau, settings.max_embedding_dim),
                    hidden_units=settings.hidden_units,
                    nn_scale=settings.nn_scale_factor * float(np.concatenate(w).std()),
                    nonlinear_needed=False,  # decided after the held-out fit
                    init_seed=channel.seed, reference_points=settings.reference_points or None,
                    centred_network=True)
            structure = channel.structure
            span = structure.embedding_dim * structure.tau
            pairs = per_window([max(0, len(s) - span) for s in w], asset.owners)
            if pairs.min() <= settings.min_sample_count // 2:
                raise InsufficientDataError(
                    f"channel {channel.name!r}: {int(pairs.min()) + span} samples are too few "
                    f"for the network's {structure.embedding_dim} delays of {structure.tau} plus "
                    f"min_samples / 2 = {settings.min_sample_count // 2}: use longer windows or "
                    f"lower min_samples")

    def fit_batch(self, assets: Sequence[AssetFit], settings: GrayBoxSettings,
                  chunk_size: int) -> dict[int, GrayBoxError]:
        """Train every channel's network, batched by shape (:func:`fit_networks`); for new
        baselines also decide ``nonlinear_needed``. An asset whose network came out
        non-finite is an error (never a NaN signature)."""
        _fit_networks(assets, settings, chunk_size)
        failed = {}
        for item in assets:
            bad = [c.name for c in item.channels if not _finite(c.records[self.name])]
            if bad:
                failed[id(item)] = GrayBoxError(
                    f"asset {item.asset_id!r}: the network of channel(s) {', '.join(bad)} came "
                    f"out non-finite (the residual holds values the network cannot fit)")
        return failed

    def tensors(self, channel: ChannelSignature) -> dict[str, np.ndarray]:
        """``input_weights`` of shape (J, m) and ``output_weights`` (J,)."""
        w, W = channel.nonlinear.weight_arrays()
        return {"input_weights": w, "output_weights": W}

    def fit_metrics(self, channel: ChannelSignature) -> dict[str, float | None]:
        """The network's training error and iterations, and its held-out gain when chosen
        with one."""
        c, tier = channel.channel, channel.nonlinear
        metrics = {f"fit.{c}.nn_train_mse": tier.train_mse,
                   f"fit.{c}.nn_iterations": tier.iterations}
        if tier.heldout_gain is not None:
            metrics[f"fit.{c}.nn_heldout_gain"] = tier.heldout_gain
        return metrics

    def summary_lines(self, channel: ChannelSignature) -> list[str]:
        """The network's size, training error, held-out gain and iterations."""
        from graybox.summary import field_lines, format_number

        network = channel.nonlinear
        return [f"Nonlinear tier: tanh network, {network.hidden_units} hidden units x "
                f"{network.embedding_dim} delays"] + field_lines(
            [("Training MSE", format_number(network.train_mse)),
             ("Held-out gain", format_number(network.heldout_gain)),
             ("Iterations", network.iterations)], "  ")

    def parameters(self, channel: ChannelSignature) -> tuple[list[str], np.ndarray]:
        w, W = channel.nonlinear.weight_arrays()
        names = [f"W1_{j}" for j in range(1, len(W) + 1)]
        names += [f"w_{j}_{k}" for j in range(1, w.shape[0] + 1) for k in range(1, w.shape[1] + 1)]
        return names, np.concatenate([W, w.ravel()])

    def parameter_changes(self, candidate: ChannelSignature,
                          baseline: ChannelSignature) -> np.ndarray:
        """``W_1j - W_1j0`` and ``w_jk - w_jk0``, whose squares sum to Eq. 28's zeta."""
        return super().deltas(candidate, baseline)

    def deltas(self, candidate: ChannelSignature, baseline: ChannelSignature) -> np.ndarray:
        """``(f(z_r) - f0(z_r)) / sqrt(R)`` over the reference set: their squares sum to the
        mean squared change of the network's one-step prediction (scaled units)."""
        reference = reference_set(baseline)
        if reference is None:
            return self.parameter_changes(candidate, baseline)
        current, healthy = candidate.nonlinear, baseline.nonlinear
        if (current.hidden_units, current.embedding_dim) != (healthy.hidden_units,
                                                             healthy.embedding_dim):
            raise StructureMismatchError(
                f"channel {candidate.channel!r} nonlinear tier has {current.hidden_units} x "
                f"{current.embedding_dim} input weights, the baseline {healthy.hidden_units} x "
                f"{healthy.embedding_dim}: fit the candidate with the baseline's structure")
        return (network_function(current, reference) -
                network_function(healthy, reference)) / np.sqrt(len(reference))


def network_function(tier, points: np.ndarray) -> np.ndarray:
    """The Eq. 25 network's output ``tanh(tanh(z w^T) W)`` at delay vectors ``points``."""
    w, W = tier.weight_arrays()
    return np.tanh(np.tanh(points @ w.T) @ W)


def reference_set(baseline: ChannelSignature) -> np.ndarray | None:
    """The fixed delay vectors on which a network's drift is measured, or None (Eq. 28).

    ``reference_points`` draws, seeded by the baseline's ``init_seed``, from a normal
    distribution with independent coordinates at the spread of the network's scaled input
    (the AR residual, nearly white, divided by ``nn_scale``): the same points for the
    baseline, its calibration pieces and every candidate, placed where the data lie.
    """
    structure = baseline.structure
    count = structure.reference_points or 0
    if count <= 0:
        return None
    variance = float(baseline.noise.variance)
    spread = (np.sqrt(variance) / structure.nn_scale
              if np.isfinite(variance) and variance > 0 and structure.nn_scale > 0 else 0.25)
    rng = np.random.default_rng([int(structure.init_seed), 0x2EF])
    return rng.normal(0.0, spread, (count, structure.embedding_dim))


def network_input(structure: ChannelStructure, segments: Sequence[np.ndarray],
                  owners: Sequence[int]) -> list[np.ndarray]:
    """The AR residual a channel's network models, per segment: each window's less that
    window's mean (:func:`window_centred`; ``owners`` names each segment's window), or as it
    is where the frozen ``structure`` was stored before (``centred_network`` None)."""
    if structure.centred_network:
        return window_centred(segments, owners)
    return list(segments)


def _design(segments: list[np.ndarray], structure: ChannelStructure):
    return lagged_segments(segments, structure.embedding_dim, structure.tau, structure.nn_scale)


def _fit_networks(prepared: Sequence[AssetFit], settings: GrayBoxSettings,
                  chunk_size: int) -> None:
    """Fit every channel's network, batched by shape; sets ``channel.records["nonlinear"]``
    (and, for new baselines, the ``nonlinear_needed`` decision)."""
    groups: dict[tuple[int, int], list[tuple[AssetFit, int, ChannelFit]]] = {}
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
                problems.append(_design(
                    network_input(channel.structure, channel.w_segments, item.owners),
                    channel.structure))
                starts.append(initial_weights(hidden, dim, channel.structure.init_seed,
                                              settings.network.init_scale) if retrain
                              else source.channel(channel.name).nonlinear.weight_arrays())
            fits = _one_by_one(problems, hidden, starts, None, settings.network, chunk_size,
                               train)
            for (item, _, channel), fit in zip(members_now, fits):
                channel.records["nonlinear"] = NonlinearTier.from_arrays(
                    fit.w, fit.W, fit.mse, None, fit.iterations)
                channel.network_errors = network_errors(channel, fit.prediction)
        if fresh:
            _fit_fresh(fresh, dim, hidden, settings, chunk_size)


def _fit_fresh(members, dim: int, hidden: int, settings: GrayBoxSettings,
               chunk_size: int) -> None:
    """New baselines of one group (embedding dimension ``dim``): fit on the head of every
    window, measure the gain on the held-out tails, decide whether the tier is needed, then
    fit on everything.

    With ``needed_network = "fixed_features"`` the trial network, like the needed network it
    decides on, has ``needed_hidden_units`` seeded random hidden units and only its output
    weights are fitted (one minimum, no torch); with ``"trained"`` it is a fully trained
    network of ``hidden`` units.
    """
    fixed = not settings.trains_needed_network
    needed_units = settings.needed_units
    train, test = [], []
    for item, _, channel in members:
        heads, tails = [], []
        for s in network_input(channel.structure, channel.w_segments, item.owners):
            cut = int(round(len(s) * (1 - settings.holdout_fraction)))
            heads.append(s[:cut])
            tails.append(s[cut:])
        train.append(_design(heads, channel.structure))
        test.append(_design(tails, channel.structure))
    seeds = [channel.structure.init_seed for _, _, channel in members]
    head_fits = fit_networks(train, needed_units,
                             _output_layer_starts(needed_units, dim, seeds, settings)
                             if fixed else None, settings.network, random_state=seeds,
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
    # A trained full fit starts from the seeded random weights, as the candidates of a
    # baseline without nonlinear structure do: zeta compares weights fitted by the same
    # procedure. Without structure, a fully trained network only fits noise, landing in one
    # of many shallow minima; its hidden layer then stays at the random weights (fixed
    # features) and only the output weights are fitted, a problem with a single minimum,
    # from zero (_output_layer_starts).
    for needed in (True, False):
        chosen = [i for i, (_, _, c) in enumerate(members) if c.structure.nonlinear_needed == needed]
        if not chosen:
            continue
        problems = [_design(network_input(members[i][2].structure, members[i][2].w_segments,
                                          members[i][0].owners),
                            members[i][2].structure) for i in chosen]
        trained = (not fixed) if needed else settings.null_network == "trained"
        units, chosen_seeds = needed_units if needed else hidden, [seeds[i] for i in chosen]
        fits = _one_by_one(problems, units,
                           None if trained else _output_layer_starts(units, dim, chosen_seeds,
                                                                     settings),
                           chosen_seeds, settings.network, chunk_size, trained)
        for i, fit in zip(chosen, fits):
            members[i][2].records["nonlinear"] = NonlinearTier.from_arrays(
                fit.w, fit.W, fit.mse, gains[i], fit.iterations)
            members[i][2].network_errors = network_errors(members[i][2], fit.prediction)


def _output_layer_starts(hidden: int, dim: int, seeds: Sequence[int],
                         settings: GrayBoxSettings) -> list[tuple[np.ndarray, np.ndarray]]:
    """The starts of a new baseline's fixed-feature fits: each seed's random hidden layer
    (:func:`initial_weights`, the features the network keeps) and output weights at zero.

    The output layer's problem has one minimum, so its start decides only the iterations to
    it. The seeded random output weights (the start before 2026-11-28) put the network's
    output far into tanh's flat tails on the drive's residuals, and Levenberg-Marquardt took
    9-19 iterations to come back; from zero the output is 0, tanh's slope 1, and the first
    step is close to the ridge regression of the target on the features: 4-6 iterations to
    the same minimum (within the fit's tolerance: the drive's networks' outputs 1e-6 to 1e-5
    of their RMS apart). Candidates start from their baseline's weights, as before.
    """
    return [(initial_weights(hidden, dim, seed, settings.network.init_scale)[0],
             np.zeros(hidden)) for seed in seeds]


def _one_by_one(problems: list, hidden: int, starts: list | None, seeds: list | None,
                network: FitSettings, chunk_size: int, trained: bool) -> Iterator[NetworkFit]:
    """Each problem's network fit (:func:`fit_networks`), in order, as the caller takes it.

    Trained networks are fitted in batched computations, without their prediction. An
    output layer is fitted on its own either way (:mod:`graybox.output_layer_fit`): here one
    problem at a time, with its prediction, and each problem is let go of (its entry in
    ``problems`` set to None) once fitted. The caller keeps what it needs of a fit (the
    network's errors, :func:`network_errors`) before it takes the next, so no more than one
    prediction of a series' length is alive at a time, and the errors a channel keeps (one
    array of its series' length, until the noise tier has described them) take the place of
    its problem's design, which is larger.
    """
    if trained:
        yield from fit_networks(problems, hidden, starts, network, random_state=seeds,
                                chunk_size=chunk_size, train_input_weights=True)
        return
    for index in range(len(problems)):
        problem, problems[index] = problems[index], None
        yield from fit_networks([problem], hidden, None if starts is None else [starts[index]],
                                network, random_state=None if seeds is None else [seeds[index]],
                                chunk_size=chunk_size, train_input_weights=False,
                                keep_predictions=True)


def network_errors(channel: ChannelFit, prediction: np.ndarray | None
                   ) -> list[np.ndarray] | None:
    """A needed network's in-sample one-step errors ``w(t) - nn_scale * f(z(t))`` (``z`` from
    :func:`network_input`, so the errors keep each window's mean), per segment of the channel
    (after the network's delays), from the fit's own ``prediction``
    (its design's rows, the segments one after another): what the noise tier describes. None
    for a channel whose network is not needed, or without a prediction (a trained network's
    fit), or one that does not line up with the segments.

    The output-layer fit computes the prediction as
    :meth:`graybox.nonlinear_tier.NonlinearTier.predict` does, on the segments' delay vectors
    one after another: the same numbers (but for a segment's last few rows, whose output-layer
    sum BLAS adds in another order when the segment is run alone: a difference at that sum's
    rounding, about 1e-16) without a second pass of the network over the data, which was most
    of the noise tier's time.
    """
    structure = channel.structure
    if prediction is None or not structure.nonlinear_needed:
        return None
    span = structure.embedding_dim * structure.tau
    lengths = [max(0, len(s) - span) for s in channel.w_segments]
    if sum(lengths) != len(prediction):
        return None
    predictions = np.split(prediction, np.cumsum(lengths)[:-1])
    return [s[span:] - structure.nn_scale * p for s, p in zip(channel.w_segments, predictions)]


def _finite(tier: NonlinearTier) -> bool:
    return bool(np.isfinite(tier.train_mse)
                and all(np.isfinite(a).all() for a in tier.weight_arrays()))
