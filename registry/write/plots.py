"""Figures logged with every fit, drawn to be looked at rather than read.

* :func:`residual_figure`: the white-box residual ``r(t)`` with its autocorrelation, and the
  autocorrelation of the final noise against the white-noise band (how much structure the
  three tiers took out);
* :func:`tier_fit_figure`: each tier's fit: the stationarized residual against the AR
  forecast, the AR residual against the network forecast, and the noise histogram against
  the Gaussian with the noise tier's mean and variance;
* :func:`zeta_trend_figure`: the asset's zeta per tier and channel over the nights, with
  epsilon drawn in and alarms marked;
* :func:`diagnosis_figure`: an alarmed window's residual against the baseline and what its
  best fault hypotheses explain of it and leave.

Figures are plain :class:`matplotlib.figure.Figure` objects on the Agg canvas: no pyplot,
no global backend state, safe in threads.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.dates import AutoDateLocator, ConciseDateFormatter
from matplotlib.figure import Figure

from graybox.autocovariance import autocorrelation as series_autocorrelation
from graybox.decompose import ChannelDecomposition
from graybox.diagnosis import Diagnosis
from graybox.signature import Signature
from graybox.tiers import TIERS, tier_order
from graybox.alert_diagnosis import NO_SINGLE_CAUSE, cause_text, hypothesis_entry

ZOOM_SAMPLES = 400
ACF_LAGS = 60
#: points drawn of a line at most (a 1-Hz night has thousands of k-step errors)
PLOT_POINTS = 2000
_BLUE, _ORANGE, _RED, _GREY = "#1f77b4", "#ff7f0e", "#d62728", "#7f7f7f"
_GREEN, _PURPLE = "#2ca02c", "#9467bd"
_HYPOTHESIS_COLOURS = (_RED, _GREEN, _PURPLE)


def _figure(width: float, height: float) -> Figure:
    figure = Figure(figsize=(width, height), dpi=100, layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation at lags ``0..max_lag`` of the finite values of ``x``.

    :func:`graybox.autocovariance.autocorrelation` (biased estimator, as in the ACF plot),
    with the lags cut to the series' length.
    """
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if len(x) < 2:
        return np.zeros(1)
    return series_autocorrelation(x, min(max_lag, len(x) - 1))


def residual_figure(decompositions: Sequence[ChannelDecomposition], title: str = "") -> Figure:
    """The residual of each channel over the window, and its ACF beside the final noise's."""
    rows = len(decompositions)
    figure = _figure(12, 3.2 * rows)
    axes = figure.subplots(rows, 2, squeeze=False, width_ratios=(2, 1))
    for (left, right), part in zip(axes, decompositions):
        residual = part.residual
        left.plot(residual.index, residual.to_numpy(), lw=0.5, color=_BLUE)
        left.axhline(0.0, color=_GREY, lw=0.8)
        left.set_title(f"{part.channel}: residual r(t) = x*(t) - x^(t)")
        left.set_ylabel("residual")
        raw = autocorrelation(residual.to_numpy(), ACF_LAGS)
        noise = autocorrelation(part.noise.to_numpy(), ACF_LAGS)
        lags = np.arange(len(raw))
        right.vlines(lags, 0, raw, color=_BLUE, lw=2, label="residual")
        right.plot(np.arange(len(noise)), noise, "o", ms=3, color=_ORANGE, label="final noise")
        band = 1.96 / np.sqrt(max(len(part.noise), 1))
        right.axhspan(-band, band, color=_GREY, alpha=0.25, lw=0, label="white-noise 95% band")
        right.axhline(0.0, color=_GREY, lw=0.8)
        right.set_xlabel("lag (samples)")
        right.set_title("autocorrelation")
        right.legend(fontsize=7, loc="upper right")
    if title:
        figure.suptitle(title)
    return figure


def tier_fit_figure(decompositions: Sequence[ChannelDecomposition], signature: Signature,
                    title: str = "") -> Figure:
    """Each tier's fit per channel (the last ``ZOOM_SAMPLES`` samples of the window)."""
    rows = len(decompositions)
    figure = _figure(15, 3.2 * rows)
    axes = figure.subplots(rows, 3, squeeze=False)
    for (linear, nonlinear, noise_axis), part in zip(axes, decompositions):
        channel = signature.channel(part.channel)
        stationary = part.stationary.iloc[-ZOOM_SAMPLES:]
        forecast = part.ar_prediction.iloc[-ZOOM_SAMPLES:]
        linear.plot(stationary.index, stationary.to_numpy(), lw=0.8, color=_BLUE,
                    label="stationarized residual")
        linear.plot(forecast.index, forecast.to_numpy(), lw=0.8, color=_ORANGE,
                    label=f"AR({channel.linear.order}) forecast")
        linear.set_title(f"{part.channel}: linear tier")
        linear.legend(fontsize=7, loc="upper right")
        w = part.ar_residual.iloc[-ZOOM_SAMPLES:]
        net = part.network_prediction.iloc[-ZOOM_SAMPLES:]
        needed = "used" if channel.structure.nonlinear_needed else "monitored only"
        nonlinear.plot(w.index, w.to_numpy(), lw=0.8, color=_BLUE, label="AR residual w(t)")
        nonlinear.plot(net.index, net.to_numpy(), lw=0.8, color=_ORANGE,
                       label=f"network forecast ({needed})")
        nonlinear.set_title(f"{part.channel}: nonlinear tier (tau={channel.structure.tau}, "
                            f"m={channel.structure.embedding_dim})")
        nonlinear.legend(fontsize=7, loc="upper right")
        values = part.noise.to_numpy()
        values = values[np.isfinite(values)]
        noise_axis.hist(values, bins=50, density=True, color=_BLUE, alpha=0.6, label="final noise")
        tier = channel.noise
        sd = np.sqrt(max(tier.variance, 1e-300))
        grid = np.linspace(tier.mean - 4 * sd, tier.mean + 4 * sd, 200)
        noise_axis.plot(grid, np.exp(-0.5 * ((grid - tier.mean) / sd) ** 2) / (sd * np.sqrt(2 * np.pi)),
                        color=_ORANGE, lw=1.5, label="Gaussian, same mean and variance")
        noise_axis.set_title(f"{part.channel}: noise tier")
        noise_axis.text(0.02, 0.97, f"skewness {tier.skewness:.2f}\nexcess kurtosis "
                                    f"{tier.excess_kurtosis:.2f}\nLjung-Box p {tier.ljung_box_pvalue:.2f}",
                        transform=noise_axis.transAxes, va="top", fontsize=7)
        noise_axis.legend(fontsize=7, loc="upper right")
    for axis in axes.ravel():
        for label in axis.get_xticklabels():
            label.set_rotation(20)
    if title:
        figure.suptitle(title)
    return figure


def zeta_trend_figure(history: pd.DataFrame, title: str = "") -> Figure:
    """Zeta over the nights per channel and tier, epsilon dashed, alarms in red.

    Parameters
    ----------
    history : pandas.DataFrame
        Columns ``window_end, channel, tier, zeta, epsilon`` (as from
        ``Registry.zeta_history``).
    """
    channels = list(dict.fromkeys(history["channel"])) if len(history) else ["(none)"]
    # the built-in tiers always, and any tier added through ``kinds=`` that has nights
    tiers = sorted(set(TIERS) | set(history["tier"] if len(history) else ()), key=tier_order)
    figure = _figure(4.2 * len(tiers), 2.8 * len(channels))
    axes = figure.subplots(len(channels), len(tiers), squeeze=False, sharex=True)
    for row, channel in zip(axes, channels):
        for axis, tier in zip(row, tiers):
            part = history[(history["channel"] == channel) & (history["tier"] == tier)] \
                if len(history) else history
            part = part.sort_values("window_end")
            axis.set_title(f"{channel}: {tier} tier")
            if not len(part):
                axis.text(0.5, 0.5, "no nights yet", ha="center", va="center",
                          transform=axis.transAxes, color=_GREY)
                continue
            when = pd.to_datetime(part["window_end"], utc=True)
            zeta = part["zeta"].to_numpy(float)
            epsilon = part["epsilon"].to_numpy(float)
            axis.plot(when, zeta, "-o", ms=3, lw=1, color=_BLUE, label="zeta")
            if np.isfinite(epsilon).any():
                axis.plot(when, epsilon, "--" if len(when) > 1 else "_", ms=20, mew=1.5,
                          drawstyle="steps-mid", color=_ORANGE, lw=1.2, label="epsilon")
            alarm = np.isfinite(epsilon) & (zeta > epsilon)
            if alarm.any():
                axis.plot(when[alarm], zeta[alarm], "o", ms=6, color=_RED, label="alarm")
            top = np.nanmax(np.concatenate([zeta, epsilon[np.isfinite(epsilon)]]))
            axis.set_ylim(0, 1.15 * top if top > 0 else 1.0)
            if len(when) == 1:
                axis.set_xlim(when.iloc[0] - pd.Timedelta(days=2), when.iloc[0] + pd.Timedelta(days=2))
            locator = AutoDateLocator(minticks=3, maxticks=6)
            axis.xaxis.set_major_locator(locator)
            axis.xaxis.set_major_formatter(ConciseDateFormatter(locator))
            axis.legend(fontsize=7, loc="upper left")
    if title:
        figure.suptitle(title)
    return figure


def _thinned(values: np.ndarray) -> np.ndarray:
    """Every n-th value, at most :data:`PLOT_POINTS` of them."""
    return values[::max(1, -(-len(values) // PLOT_POINTS))]


def diagnosis_figure(diagnosis: Diagnosis, title: str = "") -> Figure:
    """An alarmed window's residual and its best hypotheses' fits, per channel concerned.

    Left: the residual ``r(t)`` (the k-step errors with the baseline's explanation taken
    out) and the part each hypothesis explains (a noise hypothesis, read on the one-step
    innovations, explains no part of it: listed only). Right: what each leaves, against the baseline's +-2 sd: the cause that fits
    leaves errors that look healthy.

    Parameters
    ----------
    diagnosis : Diagnosis
        With its :attr:`~graybox.diagnosis.Diagnosis.evidence`.
    title : str, optional

    Raises
    ------
    ValueError
        If the diagnosis carries no evidence (read back, or built by hand).
    """
    evidence = diagnosis.evidence
    if evidence is None or not evidence.fits:
        raise ValueError("the diagnosis carries no evidence to draw (only a fresh diagnosis "
                         "of a window does)")
    rows = evidence.concerned()
    figure = _figure(14, 3.2 * len(rows))
    axes = figure.subplots(len(rows), 2, squeeze=False, sharex=True)
    for (left, right), channel in zip(axes, rows):
        part = evidence.channels[channel]
        times, band = _thinned(part.times), 2 * part.residual_std
        left.plot(times, _thinned(part.residual), lw=0.6, color=_GREY, label="residual r(t)")
        right.axhspan(-band, band, color=_GREY, alpha=0.2, lw=0, label="baseline +-2 sd")
        for rank, (fit, colour) in enumerate(zip(evidence.fits, _HYPOTHESIS_COLOURS)):
            hypothesis = fit.hypothesis
            label = f"{rank + 1}. {cause_text(hypothesis_entry(hypothesis))}"
            remaining = fit.remaining[channel]
            spread = np.sqrt(np.mean(remaining ** 2)) / max(part.residual_std, 1e-300)
            above = 2 + len(evidence.fits) - rank      # the best drawn on top
            if hypothesis.kind == "noise":
                # read on the one-step innovations, not on r(t): a legend entry only
                left.plot([], [], color=colour, lw=1.0,
                          label=f"{label} (one-step innovations' spread)")
            else:
                left.plot(times, _thinned(evidence.explained(rank, channel)), lw=1.0,
                          color=colour, label=label, zorder=above)
            right.plot(times, _thinned(remaining), lw=0.5, color=colour, alpha=0.7,
                       label=f"{rank + 1}. leaves rms {spread:.2f} sd", zorder=above)
        left.axhline(0.0, color="black", lw=0.6)
        right.axhline(0.0, color="black", lw=0.6)
        left.set_title(f"{part.channel}: residual and what each hypothesis explains")
        right.set_title(f"{part.channel}: what each hypothesis leaves")
        left.set_ylabel("k-step error - baseline")
        left.legend(fontsize=7, loc="upper left")
        right.legend(fontsize=7, loc="upper left")
    for axis in axes.ravel():
        for label in axis.get_xticklabels():
            label.set_rotation(20)
    heading = diagnosis.summary() if diagnosis.explained else \
        f"{NO_SINGLE_CAUSE} (the best hypotheses drawn)"
    figure.suptitle(f"{title}: {heading}" if title else heading)
    return figure
