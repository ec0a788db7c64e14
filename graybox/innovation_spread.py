"""How much a window's one-step innovations spread, against its healthy baseline's.

The detection's linear and noise tiers read the one-step residual (Eq. 3) at the analysis
interval, differenced and standardised as the baseline's, through the baseline's
autoregression: what is left, the innovation ``w(t) = z(t) - sum_i a_i z(t - i)``, is close to
white, and its variance is the baseline's ``innovation_variance`` when healthy. A sensor that
got noisier raises it directly: its noise enters every one-step residual. The k-step errors a
parameter, bias or gain hypothesis is fitted on integrate the process noise over ``k`` samples
and barely see it (measured on the gas turbine: sensor noise x1.3 moved their spread by 2-4 %,
as much as one healthy day from the next; the innovations' by 12-14 %, healthy days within
1.5 %). This is the evidence of a noise hypothesis (:mod:`graybox.diagnosis`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pandas as pd

from graybox.analysis_rate import decimate
from graybox.effective_samples import effective_sample_size
from graybox.models.base import WhiteBoxModel
from graybox.residual import residual_frame
from graybox.signature import Signature


@dataclass(frozen=True)
class InnovationSpread:
    """One channel's one-step innovations over a window, against the baseline.

    Attributes
    ----------
    channel : str
    ratio : float
        Their variance (about the window's mean) over the baseline's innovation variance:
        1 when healthy.
    samples : int
        Innovations in the window.
    effective_samples : float
        Their effective number (:func:`graybox.effective_samples.effective_sample_size`).
    """

    channel: str
    ratio: float
    samples: int
    effective_samples: float


def innovation_spreads(baseline: Signature, model: WhiteBoxModel, frames: Sequence[pd.DataFrame],
                       sample_interval: float) -> dict[str, InnovationSpread]:
    """Each output channel's :class:`InnovationSpread` over the operating periods ``frames``.

    Parameters
    ----------
    baseline : Signature
        Its residual method, integrator, analysis interval and each channel's differencing,
        standardisation and linear tier are applied to the window.
    model : WhiteBoxModel
        The baseline's white box (a tuned baseline's: tuned).
    frames : sequence of DataFrame
        The window's operating periods, at the telemetry rate.
    sample_interval : float
        Seconds between telemetry samples.

    Returns
    -------
    dict of str to InnovationSpread
        Channels whose periods are all too short to difference and filter are left out.
    """
    return pooled_spreads(baseline, period_innovations(baseline, model, frames, sample_interval))


def period_innovations(baseline: Signature, model: WhiteBoxModel, frames: Sequence[pd.DataFrame],
                       sample_interval: float, states: Sequence | None = None
                       ) -> dict[str, list[np.ndarray | None]]:
    """Each output channel's one-step innovations per operating period of ``frames`` (None for
    a period too short to difference and filter): what :func:`pooled_spreads` pools, so that
    spreads over several runs of the periods (from each window on) integrate each period once.
    Parameters as :func:`innovation_spreads`; ``states``: each period's full states under
    ``model`` and the baseline's integration when already estimated
    (:func:`graybox.state_estimation.estimate_states`)."""
    factor = max(1, round(baseline.analysis_step / sample_interval))
    window = baseline.settings.derivative_window(sample_interval)
    states = [None] * len(frames) if states is None else states
    residuals = [residual_frame(model, frame, baseline.residual_method, sample_interval, window,
                                baseline.integration_used, estimated)
                 for frame, estimated in zip(frames, states)]
    out = {}
    for name in model.outputs:
        channel = baseline.channel(name)
        structure, linear = channel.structure, channel.linear
        out[name] = []
        for residual in residuals:
            series = decimate(residual[name].to_numpy(), factor)
            if len(series) <= structure.differencing.lost + linear.order + 1:
                out[name].append(None)
                continue
            z = (structure.differencing.apply(series) - structure.center) / structure.scale
            out[name].append(linear.innovations(z))
    return out


def pooled_spreads(baseline: Signature, innovations: dict[str, list[np.ndarray | None]],
                   first: int = 0) -> dict[str, InnovationSpread]:
    """:func:`innovation_spreads` from :func:`period_innovations`, over the periods from index
    ``first`` on."""
    spreads = {}
    for name, per_period in innovations.items():
        linear = baseline.channel(name).linear
        pieces = [p for p in per_period[first:] if p is not None]
        samples = sum(len(p) for p in pieces)
        if samples < 4:
            continue
        mean = np.concatenate(pieces).mean()
        centred = [p - mean for p in pieces]
        variance = float(sum(np.sum(p ** 2) for p in centred) / samples)
        spreads[name] = InnovationSpread(name, variance / linear.innovation_variance, samples,
                                         effective_sample_size(centred))
    return spreads
