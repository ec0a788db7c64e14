"""Apply a fitted signature to a window and expose every intermediate series (for plots)."""
from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from graybox.analysis_rate import decimate, decimation_factor
from graybox.models.base import WhiteBoxModel
from graybox.residual import infer_sample_interval, residual_frame
from graybox.signature import Signature
from graybox.tiers.nonlinear import network_input


@dataclass(frozen=True)
class ChannelDecomposition:
    """One channel's series through the tiers, each with its own timestamps.

    Attributes
    ----------
    residual : Series
        ``r(t)`` from the white box.
    stationary : Series
        ``(y - center) / scale`` after differencing: what the AR tier models.
    ar_prediction : Series
        The AR tier's one-step forecast of ``stationary``.
    ar_residual : Series
        ``w(t)``, what the AR tier leaves.
    network_prediction : Series
        The Eq. 25 network's one-step forecast of ``w(t)`` (in ``w`` units).
    noise : Series
        The final residual the noise tier describes.
    """

    channel: str
    residual: pd.Series
    stationary: pd.Series
    ar_prediction: pd.Series
    ar_residual: pd.Series
    network_prediction: pd.Series
    noise: pd.Series


def decompose(signature: Signature, model: WhiteBoxModel, window) -> list[ChannelDecomposition]:
    """Run one window through ``signature``'s structure and fitted tiers (no refitting).

    Parameters
    ----------
    signature : Signature
    model : WhiteBoxModel
        The white box the signature was fitted with.
    window : TelemetryWindow or DataFrame
        Uniform-grid telemetry.

    Returns
    -------
    list of ChannelDecomposition, one per channel
        At the signature's analysis interval (see :mod:`graybox.analysis_rate`).
    """
    frame = getattr(window, "frame", window)
    interval = getattr(window, "sample_interval", None) or infer_sample_interval(frame.index)
    settings = signature.settings
    residuals = residual_frame(model, frame, signature.residual_method, interval,
                               settings.derivative_window(interval),
                               integration=signature.integration_used)
    factor = decimation_factor(signature.analysis_step, interval)
    # a block mean stands at the block's last instant (it covers the interval up to it)
    blocks = residuals.index[factor - 1::factor][: len(residuals) // factor]
    out = []
    for channel in signature.channels:
        structure = channel.structure
        r = pd.Series(decimate(residuals[channel.channel].to_numpy(), factor), blocks)
        differencing = structure.differencing
        index = r.index[differencing.lost:]
        z = (differencing.apply(r.to_numpy()) - structure.center) / structure.scale
        w = channel.linear.innovations(z)
        n = channel.linear.order
        w_index = index[n:]
        span = structure.embedding_dim * structure.tau
        fitted_on = network_input(structure, [w], [0])[0]      # as the network was fitted
        net = structure.nn_scale * channel.nonlinear.predict(
            fitted_on / structure.nn_scale, structure.tau)[0]
        noise = w[span:] - net if structure.nonlinear_needed else w[span:]
        out.append(ChannelDecomposition(
            channel.channel, r, pd.Series(z, index), pd.Series(z[n:] - w, w_index),
            pd.Series(w, w_index), pd.Series(net, w_index[span:]), pd.Series(noise, w_index[span:])))
    return out
