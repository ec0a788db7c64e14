"""Plain-text summaries of a signature and of a drift, as statsmodels' ``summary()`` prints.

Pure string building with fixed-width columns: the same record always gives the same text.
Numbers follow statsmodels' rule (``forg``): fixed decimals between 1e-4 and 1e4, scientific
notation outside, so a column stays aligned whatever the magnitude.

>>> print(signature.summary())                                            # doctest: +SKIP
>>> print(drift.summary())                                                # doctest: +SKIP
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Sequence

from scipy import special

from graybox.operating_conditions import covered

if TYPE_CHECKING:
    from graybox.drift import Drift
    from graybox.signature import ChannelSignature, Signature
    from graybox.tiers.base import Tier

#: characters of a summary's rules (``=`` and ``-`` lines)
WIDTH = 78
#: columns of the label in ``Label:  value`` lines
LABEL_WIDTH = 24
#: columns of a number in a table
NUMBER_WIDTH = 11
#: two-sided normal quantile of the coefficients' 95 % interval
Z_95 = 1.959963984540054


def format_number(value: float | None, decimals: int = 4) -> str:
    """A number as statsmodels' ``forg`` writes it: fixed point between 1e-4 and 1e4.

    Parameters
    ----------
    value : float or None
        None is written ``-`` (not measured, e.g. an uncalibrated epsilon).
    decimals : int, default 4
        Decimals in fixed point; scientific notation keeps ``decimals - 1``.

    Returns
    -------
    str
    """
    if value is None:
        return "-"
    value = float(value)
    if not math.isfinite(value):
        return str(value)
    if value == 0 or 1e-4 <= abs(value) < 1e4:
        return f"{value:.{decimals}f}"
    return f"{value:.{decimals - 1}e}"


def format_seconds(value: float) -> str:
    """Seconds as ``10 s`` or ``0.5 s``."""
    return f"{value:g} s"


def field_lines(fields: Sequence[tuple[str, object]], indent: str = "") -> list[str]:
    """``Label:  value`` lines with the values aligned at :data:`LABEL_WIDTH`."""
    width = LABEL_WIDTH - len(indent)
    return [f"{indent}{label + ':':<{width}}{value}".rstrip() for label, value in fields]


def table_lines(headers: Sequence[str], rows: Sequence[Sequence[str]], text_columns: int = 1,
                indent: str = "") -> list[str]:
    """A fixed-width table: the first ``text_columns`` left-aligned, the rest numbers.

    Text columns are as wide as their longest cell plus two; number columns
    :data:`NUMBER_WIDTH` (or their longest cell plus one), right-aligned.
    """
    widths = []
    for index, header in enumerate(headers):
        cells = [header] + [row[index] for row in rows]
        longest = max(len(cell) for cell in cells)
        widths.append(longest + 2 if index < text_columns else max(NUMBER_WIDTH, longest + 1))

    def line(cells: Sequence[str]) -> str:
        text = "".join(f"{cell:<{width}}" if index < text_columns else f"{cell:>{width}}"
                       for index, (cell, width) in enumerate(zip(cells, widths)))
        return (indent + text).rstrip()

    return [line(headers)] + [line(row) for row in rows]


def title_lines(title: str) -> list[str]:
    """The title centred over a ``=`` rule."""
    return [f"{title:^{WIDTH}}".rstrip(), "=" * WIDTH]


def differencing_text(period: int, seasonal_order: int, order: int) -> str:
    """The operator ``(1 - B)^order (1 - B^period)^seasonal_order``, or ``none``."""
    parts = []
    if order:
        parts.append("(1 - B)" + (f"^{order}" if order > 1 else ""))
    if seasonal_order:
        parts.append(f"(1 - B^{period})" + (f"^{seasonal_order}" if seasonal_order > 1 else ""))
    return " ".join(parts) if parts else "none"


def format_pvalue(value: float) -> str:
    """A p-value with three decimals (``0.000`` below 0.0005, as statsmodels prints it)."""
    return "nan" if math.isnan(value) else f"{value:.3f}"


def coefficient_rows(names: Sequence[str], values: Sequence[float],
                     errors: Sequence[float]) -> list[list[str]]:
    """Rows ``name, coef, std err, z, P>|z|, [0.025, 0.975]`` (normal approximation)."""
    rows = []
    for name, value, error in zip(names, values, errors):
        if error > 0:
            z = value / error
        else:  # an exact coefficient: infinitely many standard errors from 0, unless it is 0
            z = math.copysign(math.inf, value) if value else math.nan
        p = math.nan if math.isnan(z) else float(2.0 * special.ndtr(-abs(z)))
        rows.append([name, format_number(value), format_number(error), format_number(z, 3),
                     format_pvalue(p), format_number(value - Z_95 * error),
                     format_number(value + Z_95 * error)])
    return rows


COEFFICIENT_HEADERS = ("", "coef", "std err", "z", "P>|z|", "[0.025", "0.975]")


def _model_parameters(signature: Signature) -> str:
    values = []
    for name, value in signature.model.parameters.items():
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        values.append(f"{name}={format_number(value) if number else 'table'}")
    return ", ".join(values) if values else "-"


def _header(signature: Signature) -> list[str]:
    integration = signature.integration_used
    fields = [("Asset", signature.asset_id or "-"),
              ("Window start", signature.window_start or "-"),
              ("Window end", signature.window_end or "-"),
              ("Model", signature.model.spec),
              ("Model parameters", _model_parameters(signature)),
              ("Residual", signature.residual_method),
              ("Sample interval", format_seconds(signature.sample_interval)),
              ("Analysis interval", format_seconds(signature.analysis_step)),
              ("Integration", f"{integration.method}, {integration.substeps} sub-steps"),
              ("Samples", signature.n_samples),
              ("Channels", ", ".join(signature.channel_names))]
    tuning = signature.tuning
    if tuning is not None:
        fields.append(("Tuning", f"{', '.join(tuning.names)}; "
                                 f"{'converged' if tuning.converged else 'NOT converged'}; "
                                 f"{tuning.n_obs} k-step errors"))
    if signature.holds:
        fields.append(("Longest holds", ", ".join(f"{channel} {format_seconds(seconds)}"
                                                  for channel, seconds in signature.holds.items())))
    ranges = covered(signature.conditions)
    if ranges:
        fields.append(("Days' conditions", "; ".join(ranges)))
    lines = title_lines("Gray-box signature") + field_lines(fields)
    if tuning is not None:
        lines += ["-" * WIDTH, "Tuned white-box parameters"]
        rows = coefficient_rows(tuning.names, tuning.values, tuning.standard_errors)
        lines += table_lines(COEFFICIENT_HEADERS, rows, indent="  ")
    return lines


def _channel(channel: ChannelSignature, kinds: Sequence[Tier]) -> list[str]:
    s = channel.structure
    lines = ["=" * WIDTH, f"Channel {channel.channel}   ({channel.n_samples} samples)",
             "-" * WIDTH, "Structure"]
    fields = [("Differencing", differencing_text(s.period, s.seasonal_order, s.diff_order)),
              ("AR order", s.ar_order),
              ("Embedding", f"tau {s.tau}, dimension {s.embedding_dim}, "
                            f"{s.hidden_units} hidden units"),
              ("Network needed", "yes" if s.nonlinear_needed else "no"),
              ("Scaling", f"center {format_number(s.center)}, scale {format_number(s.scale)}, "
                          f"network {format_number(s.nn_scale)}")]
    if channel.selection is not None:
        selection = channel.selection
        fields += [("AR order chosen by", selection.ar_criterion.upper()),
                   ("ACF area", f"{format_number(selection.raw_acf_area)} raw, "
                                f"{format_number(selection.acf_area)} differenced"),
                   ("ADF statistic", format_number(selection.adf_statistic)),
                   ("Period found", selection.candidate_period or "none")]
    lines += field_lines(fields, "  ")
    for kind in kinds:
        if kind.present(channel):
            lines += kind.summary_lines(channel)
    return lines


def signature_summary(signature: Signature, kinds: Sequence[Tier] | None = None) -> str:
    """The text of :meth:`graybox.signature.Signature.summary`.

    Parameters
    ----------
    signature : Signature
    kinds : sequence of Tier, optional
        The tiers shown where a channel has them, each as its kind writes it
        (:meth:`~graybox.tiers.base.Tier.summary_lines`); default
        :data:`graybox.tiers.TIER_KINDS`.

    Returns
    -------
    str
        A header (asset, window, model, intervals, samples, tuning), then per channel its
        structure and its tiers (linear, nonlinear, noise and level).
    """
    if kinds is None:
        from graybox.tiers import TIER_KINDS    # the tiers write their sections with this module

        kinds = TIER_KINDS
    lines = _header(signature)
    for channel in signature.channels:
        lines += _channel(channel, kinds)
    return "\n".join(lines + ["=" * WIDTH])


def drift_summary(drift: Drift) -> str:
    """The text of :meth:`graybox.drift.Drift.summary`.

    Parameters
    ----------
    drift : Drift

    Returns
    -------
    str
        Per channel and tier zeta, epsilon, their ratio and whether zeta exceeds epsilon
        (``YES``; ``-`` without a threshold), notes on the nonlinear tier's weights and the
        level tier's extrapolation, then the parameters that moved most.
    """
    alarms = drift.alarms
    fields = [("Samples", drift.n_samples), ("Tiers compared", len(drift.entries)),
              ("Alarms", ", ".join(f"{e.channel} {e.tier}" for e in alarms) or "none")]
    lines = title_lines("Gray-box drift") + field_lines(fields) + ["-" * WIDTH]
    rows = [[e.channel, e.tier, format_number(e.zeta), format_number(e.epsilon),
             format_number(e.ratio), "-" if e.epsilon is None else "YES" if e.exceeded else "no"]
            for e in drift.entries]
    lines += table_lines(("channel", "tier", "zeta", "epsilon", "ratio", "exceeded"), rows,
                         text_columns=2)
    notes = [f"{e.channel} {e.tier}: zeta on the weights (Eq. 28) "
             f"{format_number(e.parameter_zeta)}"
             for e in drift.entries if e.parameter_zeta is not None]
    notes += [f"{', '.join(tiers)}: outside the baseline's operating range "
              f"({format_number(value)} x its reach), change discounted"
              for value, tiers in drift.discounted.items()]
    if drift.conditions:
        notes.append(f"farthest outside: {drift.conditions}")
    if notes:
        lines += ["-" * WIDTH, "Notes"] + [f"  {note}" for note in notes]
    changes = [[e.channel, e.tier, c.name, format_number(c.baseline), format_number(c.candidate),
                format_number(c.contribution)] for e in drift.entries for c in e.top_changes]
    if changes:
        lines += ["-" * WIDTH, "Top changes"]
        lines += table_lines(("channel", "tier", "parameter", "baseline", "candidate",
                              "contribution"), changes, text_columns=3)
    return "\n".join(lines + ["=" * WIDTH])
