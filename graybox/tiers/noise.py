"""The noise tier's kind: the moments of what the linear and nonlinear tiers leave
(:mod:`graybox.noise_tier`)."""
from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np

from graybox.noise_tier import NoiseTier, describe_noise, sampling_zeta_quantile
from graybox.settings import GrayBoxSettings
from graybox.exceptions import ConstantSeriesError
from graybox.tiers.base import Tier, stood_still
from graybox.tiers.fit_state import AssetFit, ChannelFit
from graybox.tiers.nonlinear import network_input

if TYPE_CHECKING:  # pragma: no cover - typing only
    from graybox.signature import ChannelSignature


class NoiseTierKind(Tier):
    """The noise tier: mean, variance, skewness and excess kurtosis of the final residual.

    Changes are in units of the baseline noise standard deviation (mean), relative (variance),
    or as they are (skewness, kurtosis), each divided by its sampling standard deviation under
    the baseline residual's own distribution (:attr:`graybox.noise_tier.NoiseTier.moment_weights`;
    a baseline stored before it: a Gaussian's, :data:`graybox.noise_tier.MOMENT_WEIGHTS`).

    Its changes are discounted beyond the baseline's inputs' excitation too (the spread of
    their sample-to-sample steps, :mod:`graybox.operating_conditions`): what a coarse white
    box mispredicts from one sample to the next grows with how far the inputs moved between
    them, so the residual's variance and tails grow with the excitation where its level and
    dynamics need not.
    """

    name = "noise"
    tensor_part = "moments"
    field = "noise"
    record_type = NoiseTier
    stage = "noise"
    early = False
    condition_figures = ("mean", "spread", "excitation")

    def fit(self, asset: AssetFit, settings: GrayBoxSettings) -> None:
        """Describe the final residual (:func:`describe_noise`): the network's one-step errors
        where the network is needed, else the AR residual itself (after the network's delays
        either way)."""
        for channel in asset.channels:
            try:
                channel.records[self.name] = describe_noise(final_residual(channel, asset.owners))
            except ConstantSeriesError as error:
                raise stood_still(channel.name, error) from None
            channel.network_errors = None      # described: an array of the series' length

    def fit_metrics(self, channel: ChannelSignature) -> dict[str, float | None]:
        """The four moments and the Ljung-Box test."""
        return {f"noise.{channel.channel}.{name}": getattr(channel.noise, name)
                for name in ("mean", "variance", "skewness", "excess_kurtosis",
                             "ljung_box_statistic", "ljung_box_pvalue")}

    def summary_lines(self, channel: ChannelSignature) -> list[str]:
        """The four moments and the Ljung-Box test."""
        from graybox.summary import field_lines, format_number, format_pvalue

        noise = channel.noise
        white = "white at 1 %" if noise.is_white else "NOT white at 1 %"
        return ["Noise tier"] + field_lines(
            [("Mean", format_number(noise.mean)),
             ("Variance", format_number(noise.variance)),
             ("Skewness", format_number(noise.skewness)),
             ("Excess kurtosis", format_number(noise.excess_kurtosis)),
             (f"Ljung-Box Q({noise.ljung_box_lags})",
              f"{format_number(noise.ljung_box_statistic)}   "
              f"p {format_pvalue(noise.ljung_box_pvalue)}   {white}")], "  ")

    def parameters(self, channel: ChannelSignature) -> tuple[list[str], np.ndarray]:
        names = ["mean", "variance", "skewness", "excess_kurtosis"]
        return names, np.asarray(channel.noise.moments)

    def epsilon_floor(self, candidate: ChannelSignature, baseline: ChannelSignature,
                      conditions: float = 0.0, alpha: float | None = None) -> float:
        """The zeta the four moments' sampling noise alone exceeds with probability
        ``alpha`` (:func:`graybox.noise_tier.sampling_zeta_quantile`, the candidate's and
        the baseline's samples), discounted as the changes are. The calibration's few
        healthy days can be more alike than their own sampling noise (a 15-minute export
        gives 96 samples a day, five days whose kurtosis happened to agree): its epsilon
        then sits below what a healthy night's moments cross by chance alone."""
        if alpha is None:
            return 0.0
        quantile = sampling_zeta_quantile(baseline.noise, candidate.noise.n_obs, alpha)
        return quantile / self.discount(candidate, baseline, conditions) ** 2

    def deltas(self, candidate: ChannelSignature, baseline: ChannelSignature) -> np.ndarray:
        delta = super().deltas(candidate, baseline)
        variance = baseline.noise.variance
        delta = delta / np.array([np.sqrt(variance), variance, 1.0, 1.0])
        return delta * np.sqrt(baseline.noise.moment_weights)


def final_residual(channel: ChannelFit, owners: Sequence[int]) -> list[np.ndarray]:
    """What the linear and nonlinear tiers leave of a channel's residual, per segment, after
    the network's delays: a needed network's one-step errors (the nonlinear tier's
    ``network_errors``, from its fit; where its fit kept no prediction, a trained network's,
    the network is run over its input here, :func:`graybox.tiers.nonlinear.network_input`,
    ``owners`` naming each segment's window), else the AR residual itself."""
    structure, w = channel.structure, channel.w_segments
    span = structure.embedding_dim * structure.tau
    if not structure.nonlinear_needed:
        return [s[span:] for s in w]
    if channel.network_errors is not None:
        return channel.network_errors
    predictions = channel.nonlinear.predict(
        [s / structure.nn_scale for s in network_input(structure, w, owners)], structure.tau)
    return [s[span:] - structure.nn_scale * p for s, p in zip(w, predictions)]
