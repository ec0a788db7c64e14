"""The level tier's kind: each channel's level against the white box's k-step prediction
(:mod:`graybox.level_tier`), fitted from the white box's states, not the residual."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from graybox.analysis_rate import integrates, largest_rate, linearised_eigenvalues
from graybox.exceptions import InsufficientDataError, StructureMismatchError
from graybox.level_tier import (LevelTier, drifting_state_names, extrapolation, fit_level,
                                level_horizon, operating_features, pool_level_data,
                                segment_level_data, start_stride)
from graybox.resolution import reading_resolution
from graybox.settings import GrayBoxSettings
from graybox.state_estimation import WindowStates
from graybox.tiers.base import Tier
from graybox.tiers.fit_state import AssetFit, per_window

if TYPE_CHECKING:  # pragma: no cover - typing only
    from graybox.signature import ChannelSignature


class LevelTierKind(Tier):
    """The level tier (:mod:`graybox.level_tier`): the channel's level at the baseline's
    operating point.

    One parameter, ``level``; its change is in units of the baseline's regression residual
    standard deviation. Its :meth:`outside` is the candidate's own
    :func:`~graybox.level_tier.extrapolation` (not the asset's input conditions): a night
    whose operating-condition correction is twice the largest of a baseline day's has its
    level change divided by four in :meth:`drift_deltas` (:meth:`discount`), since the
    correction was only checked up to that reach: beyond it a slope's error grows the level
    error in proportion to the distance and the model error's curvature, which a linear
    correction leaves, with its square. Absent from signatures stored before the tier existed.
    """

    name = "level"
    tensor_part = "level"
    field = "level"
    record_type = LevelTier
    stage = "residual"  # reported with the residual, as it is a white-box computation too

    def fit(self, asset: AssetFit, settings: GrayBoxSettings) -> None:
        """The level of every channel, from the segments' states at the analysis interval
        (:func:`~graybox.level_tier.segment_level_data`, pooled, then
        :func:`~graybox.level_tier.fit_level`). A candidate uses its baseline's horizon and
        operating centre; a candidate of a baseline stored without the tier gets none."""
        model, interval, owners = asset.request.model, asset.analysis_interval, asset.owners
        channels = asset.channels
        if channels[0].reference is None:
            horizon, references = self.horizon(asset, settings), [None] * len(channels)
        else:
            references = [channel.reference.level for channel in channels]
            if any(level is None for level in references):
                for channel in channels:
                    channel.records[self.name] = None
                return
            horizon = references[0].horizon
        stride, integration = start_stride(interval, horizon), asset.integration

        def segment(window: WindowStates):
            return segment_level_data(model, window, interval, horizon, stride, integration)

        cache = asset.cache
        parts = [segment(window) if cache is None else
                 cache.remember("level", model, window, (interval, horizon, stride, integration),
                                lambda w=window: segment(w))
                 for window in asset.windows]
        # the hidden states whose drift is a feature: a baseline finds them, a candidate takes
        # its baseline's (none for a record stored before them)
        if channels[0].reference is None:
            drift = drifting_state_names(model, asset.windows)
        else:
            drift = {channel.name: reference.drifting or ()
                     for channel, reference in zip(channels, references)}
        data = pool_level_data(model, asset.windows, parts, horizon, stride, drift)
        operating = operating_features(model, asset.conditions)   # the inputs: every channel's
        first_hidden = 1 + len(model.inputs)
        for index, (channel, reference) in enumerate(zip(channels, references)):
            resolution = None if reference is not None else reading_resolution(
                np.concatenate([window.y[:, index] for window in asset.windows]))
            try:
                errors, features, segments = data[channel.name]
                # a drifting hidden state's change since its estimate places a night too: a
                # night that moves it further than the baseline's days did is outside their
                # range (no controller sets it, and a sensor fault does not move it)
                counted = operating + tuple(range(first_hidden, features.shape[1]))
                drifting = None if reference is not None else drift[channel.name] or None
                channel.records[self.name] = fit_level(errors, features, horizon, reference,
                                                       np.asarray(owners)[segments],
                                                       counted, resolution, drifting)
            except InsufficientDataError as error:
                raise InsufficientDataError(f"channel {channel.name!r}: level tier: "
                                            f"{error}") from None

    @staticmethod
    def horizon(asset: AssetFit, settings: GrayBoxSettings) -> int:
        """A baseline's ``k`` (:func:`~graybox.level_tier.level_horizon`): from the white
        box's fastest time constant at the baseline's states, within its segments and
        calibration pieces."""
        lengths = [len(window.y) for window in asset.windows]
        piece = max(settings.min_sample_count,
                    int(per_window(lengths, asset.owners).min()) // settings.calibration_splits)
        eigenvalues = linearised_eigenvalues(asset.request.model, asset.windows)
        rate = largest_rate(eigenvalues)
        return level_horizon(1.0 / rate if rate > 0 else 0.0, asset.analysis_interval,
                             lengths, piece, integrates(eigenvalues))

    def fit_metrics(self, channel: ChannelSignature) -> dict[str, float | None]:
        """The level and the spread of the k-step errors about it."""
        return {f"level.{channel.channel}.level": channel.level.level,
                f"level.{channel.channel}.residual_std": channel.level.residual_std}

    def summary_lines(self, channel: ChannelSignature) -> list[str]:
        """The level, the spread about it, the horizon, the slopes and the samples."""
        from graybox.summary import field_lines, format_number

        level = channel.level
        return ["Level tier"] + field_lines(
            [("Level", format_number(level.level)),
             ("Residual std", format_number(level.residual_std)),
             ("Horizon", f"{level.horizon} samples"),
             ("Slopes", ", ".join(map(format_number, level.slopes)) or "-"),
             ("Samples", level.n_obs)], "  ")

    def hint(self, changes: Sequence[Mapping[str, Any]], conditions: str | None = None,
             count: int = 3) -> str:
        """How far the level moved, ``level moved from 129.02 to 129.49 (+0.47)`` (the
        channel's k-step prediction error at the baseline's operating point, in the
        channel's units)."""
        if not changes:
            return super().hint(changes, conditions, count)
        a, b = changes[0]["baseline"], changes[0]["candidate"]
        return f"level moved from {a:.6g} to {b:.6g} ({b - a:+.3g})"

    def parameters(self, channel: ChannelSignature) -> tuple[list[str], np.ndarray]:
        if channel.level is None:
            raise StructureMismatchError(f"channel {channel.channel!r} has no level tier (a "
                                         f"signature stored before the tier existed)")
        return ["level"], np.array([channel.level.level])

    def deltas(self, candidate: ChannelSignature, baseline: ChannelSignature) -> np.ndarray:
        delta = super().deltas(candidate, baseline)
        spread = baseline.level.residual_std
        return delta / spread if spread > 0 else delta

    def outside(self, candidate: ChannelSignature, baseline: ChannelSignature,
                conditions: float = 0.0) -> float:
        return extrapolation(candidate.level, baseline.level)

    def epsilon_floor(self, candidate: ChannelSignature, baseline: ChannelSignature,
                      conditions: float = 0.0, alpha: float | None = None) -> float:
        """The zeta of a change of one step of the channel's reading (the baseline's
        ``resolution``), discounted as the change is. A steady reading rounds to its step:
        each night's level is off by up to half a step however many samples it averages, so
        two nights' levels may differ by a whole step with nothing changed. The baseline's
        few days need not show it (five days that rounded alike), and calibration then
        takes a hundredth of a degree for a fault. 0 where the reading is not quantized."""
        step, spread = baseline.level.resolution, baseline.level.residual_std
        if not step or not spread:
            return 0.0
        return (step / spread / self.discount(candidate, baseline, conditions)) ** 2

    def discount(self, candidate: ChannelSignature, baseline: ChannelSignature,
                 conditions: float = 0.0) -> float:
        """The square of :meth:`outside` where that exceeds 1. The level's correction takes
        out the first-order dependence on the operating point, so what is left beyond the
        baseline's reach is a slope's error (growing as the distance ``x``) and the model
        error's curvature the linear correction cannot follow (growing as ``x²``);
        calibration bounded their sum at ``x = 1``, so ``x²`` bounds it beyond."""
        return max(1.0, self.outside(candidate, baseline, conditions)) ** 2
