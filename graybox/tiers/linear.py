"""The linear tier's kind: the stationarized residual's AR coefficients
(:mod:`graybox.linear_tier`), fitted after the residual is differenced and standardized."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from graybox.channel_structure import ChannelStructure, Selection
from graybox.exceptions import ConstantSeriesError, ShortWindowsError
from graybox.linear_tier import LinearTier, fit_ar
from graybox.settings import GrayBoxSettings
from graybox.stationarize import choose_differencing
from graybox.tiers.base import Tier, stood_still
from graybox.telemetry.layout import NS_PER_DAY, NS_PER_SECOND
from graybox.tiers.fit_state import AssetFit, per_window

if TYPE_CHECKING:  # pragma: no cover - typing only
    from graybox.signature import ChannelSignature


class LinearTierKind(Tier):
    """The AR tier: coefficients ``a_1..a_n``; changes ``a_i - a_i0``.

    :meth:`fit` chooses a new baseline's differencing (:func:`choose_differencing`), centre,
    scale and AR order, and sets the channel's ``structure`` with them (its network fields
    zero until the nonlinear tier chooses them); a candidate keeps its reference's. It sets
    ``w_segments``, the AR residual the nonlinear tier models.
    """

    name = "linear"
    tensor_part = "coefficients"
    field = "linear"
    record_type = LinearTier
    stage = "stationarize_ar"

    def fit(self, asset: AssetFit, settings: GrayBoxSettings) -> None:
        interval, owners = asset.analysis_interval, asset.owners
        for channel in asset.channels:
            name, segments, frozen = channel.name, channel.segments, channel.structure
            if frozen is None:
                choice = choose_differencing(segments, settings.max_diff_order,
                                             settings.max_seasonal_order)
                differencing = choice.differencing
            else:
                differencing = frozen.differencing
            lost = differencing.lost
            # the sample-count checks apply to each window's segments together
            usable = per_window([max(0, len(s) - lost) for s in segments], owners)
            too_short = [k for k, n in enumerate(usable) if n <= settings.min_sample_count]
            if too_short:
                shortest = min(usable[k] for k in too_short) + lost
                raise ShortWindowsError(
                    f"channel {name!r}: window(s) {too_short} have {shortest} residual samples "
                    f"at the {interval:g}-s analysis interval; the method needs more than "
                    f"{differencing.lost} for differencing plus min_samples = "
                    f"{settings.min_sample_count}: {_what_helps(settings, interval, shortest)}",
                    tuple(too_short))
            # a segment too short to difference contributes nothing
            y = [differencing.apply(s) if len(s) > lost else s[:0] for s in segments]
            if frozen is None:
                pooled = np.concatenate(y)
                center, scale = float(pooled.mean()), float(pooled.std())
                if scale <= 0:
                    raise stood_still(name, ConstantSeriesError("the residual is constant"))
            else:
                center, scale = frozen.center, frozen.scale
            z = [(s - center) / scale for s in y]
            if frozen is None:
                linear = fit_ar(z, max_order=settings.max_ar_order(interval),
                                criterion=settings.ar_criterion)
                channel.selection = Selection(choice.acf_area, choice.raw_acf_area,
                                              choice.adf_statistic, choice.candidate_period,
                                              settings.ar_criterion)
                channel.structure = ChannelStructure(
                    period=differencing.period, seasonal_order=differencing.seasonal_order,
                    diff_order=differencing.order, ar_order=linear.order, center=center,
                    scale=scale, tau=0, embedding_dim=0, hidden_units=0, nn_scale=0.0,
                    nonlinear_needed=False, init_seed=0)
            else:
                try:
                    linear = fit_ar(z, order=frozen.ar_order)
                except ConstantSeriesError as error:
                    raise stood_still(name, error) from None
            channel.records[self.name] = linear
            channel.w_segments = [linear.innovations(s) for s in z]
            channel.n_samples = int(sum(len(s) for s in z))

    def fit_metrics(self, channel: ChannelSignature) -> dict[str, float | None]:
        """The AR innovations' variance."""
        return {f"fit.{channel.channel}.ar_innovation_variance":
                channel.linear.innovation_variance}

    def summary_lines(self, channel: ChannelSignature) -> list[str]:
        """The AR order, innovation variance, stationarity and coefficients with their
        standard errors."""
        from graybox.summary import (COEFFICIENT_HEADERS, coefficient_rows, field_lines,
                                     format_number, table_lines)

        linear = channel.linear
        lines = [f"Linear tier: AR({linear.order}), Yule-Walker"]
        lines += field_lines([("Innovation variance", format_number(linear.innovation_variance)),
                              ("Stationary", "yes" if linear.is_stationary else "no")], "  ")
        if linear.order:
            names = [f"a{i}" for i in range(1, linear.order + 1)]
            rows = coefficient_rows(names, linear.coefficients, linear.standard_errors)
            lines += table_lines(COEFFICIENT_HEADERS, rows, indent="  ")
        return lines

    def parameters(self, channel: ChannelSignature) -> tuple[list[str], np.ndarray]:
        coefficients = channel.linear.coefficients
        return [f"a{i}" for i in range(1, len(coefficients) + 1)], np.asarray(coefficients, float)


def _what_helps(settings: GrayBoxSettings, interval: float, shortest: int) -> str:
    """The one setting that gives a starved window its samples."""
    if not isinstance(settings.analysis_interval, str):
        return (f"the class's settings fix analysis_interval = {settings.analysis_interval:g} s; "
                f"use \"auto\" (the default), which keeps enough samples, or a shorter interval")
    needed = (settings.min_sample_count + 1) * interval
    day = NS_PER_DAY / NS_PER_SECOND
    if needed > day:
        # a window is at most a day: only fewer samples per fit can help at this logging rate
        return (f"a window must cover more than {needed:g} s of operation at this rate, "
                f"longer than a day, and windows are at most a day ([nightly] window): log "
                f"faster, or lower the class's settings.min_samples below the samples a window "
                f"holds (a day holds {int(day // interval)} at {interval:g} s; "
                f"fewer samples give wider thresholds)")
    return (f"a window must cover more than {needed:g} s of operation at this rate ("
            f"{shortest} samples cover {shortest * interval:g} s): use longer windows "
            f"([nightly] window), or for an intermittent asset a longer grid.min_duration")
