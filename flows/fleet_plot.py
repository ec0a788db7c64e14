"""The fleet heat map: assets x nights, coloured by the worst zeta/epsilon ratio.

A pure function of a :class:`flows.fleet_view.FleetView`: the worst ``top`` assets one row
each, the rest folded into one band row (its cells the largest ratio among them), nights
left to right. Colours follow the alert severities (below 0.8 green, up to 1 yellow, above
1 orange, from 2 red, from 5 dark red: ``[alerts]`` defaults); a failed asset-night is
black (``F``), stale grey (``S``), an unusable baseline purple (``U``), not operating
blue-grey (``N``), dormant (not operating for longer than ``[alerts] not_operating_after``)
dark blue (``D``); a night without a recorded window is hatched. Plain :class:`matplotlib.figure.Figure` on the Agg canvas, as
in :mod:`registry.write.plots`.
"""
from __future__ import annotations

import io

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch, Rectangle

from flows.fleet_view import DEFAULT_TOP, MARKED, STALE, UNUSABLE_BASELINE, FleetView
from flows.results import DORMANT, FAILED, NOT_OPERATING

#: ratio bands (lower bounds) and their colours
RATIO_BOUNDS = (0.0, 0.8, 1.0, 2.0, 5.0, 1e300)
RATIO_COLORS = ("#a5d6a7", "#fff59d", "#fb8c00", "#e53935", "#7f0000")
RATIO_LABELS = ("ratio < 0.8", "0.8 - 1", "1 - 2 (alarm)", "2 - 5 (major)", ">= 5 (critical)")
MARK_STYLE = {FAILED: ("#000000", "F", "failed"), STALE: ("#9e9e9e", "S", "stale"),
              UNUSABLE_BASELINE: ("#6a1b9a", "U", "unusable baseline"),
              NOT_OPERATING: ("#78909c", "N", "not operating"),
              DORMANT: ("#0d47a1", "D", "dormant (not operating too long)")}
LETTERS_UP_TO = 80          # rows above which the mark letters are left out


def fleet_heatmap_figure(view: FleetView, top: int = DEFAULT_TOP, title: str = "") -> Figure:
    """The heat map of ``view``: its ``top`` worst rows and one band for the rest."""
    shown, band = view.fold(top)
    labels = [row.asset_id for row in shown]
    ratios = [row.ratios for row in shown]
    marks = [row.marks for row in shown]
    if band is not None:
        labels.append(band.label)
        ratios.append(band.ratios)
        marks.append((None,) * len(view.nights))
    rows, nights = len(labels), len(view.nights)
    values = np.array([[np.nan if r is None else r for r in line] for line in ratios],
                      float).reshape(rows, nights)
    codes = np.array([[np.nan if m is None else MARKED.index(m) for m in line]
                      for line in marks], float).reshape(rows, nights)

    figure = Figure(figsize=(4.8 + 0.42 * nights, 1.9 + 0.19 * max(rows, 3)), dpi=100,
                    layout="constrained")
    FigureCanvasAgg(figure)
    axis = figure.subplots()
    extent = (-0.5, nights - 0.5, rows - 0.5, -0.5)
    axis.add_patch(Rectangle((-0.5, -0.5), nights, rows, facecolor="white", edgecolor="#bdbdbd",
                             hatch="////", lw=0, zorder=0))
    if rows:                    # an image of no rows has a singular extent
        axis.imshow(np.ma.masked_invalid(values), cmap=ListedColormap(RATIO_COLORS),
                    norm=BoundaryNorm(RATIO_BOUNDS, len(RATIO_COLORS)), aspect="auto",
                    interpolation="nearest", extent=extent, zorder=1)
        axis.imshow(np.ma.masked_invalid(codes),
                    cmap=ListedColormap([MARK_STYLE[m][0] for m in MARKED]),
                    norm=BoundaryNorm(np.arange(len(MARKED) + 1) - 0.5, len(MARKED)),
                    aspect="auto", interpolation="nearest", extent=extent, zorder=2)
    if rows <= LETTERS_UP_TO:
        for i, j in zip(*np.nonzero(np.isfinite(codes))):
            axis.text(j, i, MARK_STYLE[MARKED[int(codes[i, j])]][1], ha="center", va="center",
                      color="white", fontsize=7, fontweight="bold", zorder=3)
    axis.set_xlim(-0.5, nights - 0.5)
    axis.set_ylim(max(rows, 1) - 0.5, -0.5)      # an empty view keeps a valid axis
    axis.set_xticks(range(nights), [night[5:] for night in view.nights], rotation=90,
                    fontsize=8)
    axis.set_yticks(range(rows), labels, fontsize=8 if rows <= 60 else 6)
    axis.set_xticks(np.arange(nights + 1) - 0.5, minor=True)
    axis.set_yticks(np.arange(rows + 1) - 0.5, minor=True)
    axis.grid(which="minor", color="white", lw=0.6)
    axis.tick_params(which="minor", length=0)
    if band is not None:
        axis.axhline(rows - 1.5, color="#424242", lw=1.5, zorder=4)
        axis.get_yticklabels()[-1].set_fontstyle("italic")
    years = sorted({night[:4] for night in view.nights})
    axis.set_xlabel(f"night (UTC date, {'/'.join(years)})")
    if not rows:
        axis.text(0.5, 0.5, "no asset recorded in these nights", ha="center", va="center",
                  transform=axis.transAxes, color="#616161")
    handles = [Patch(facecolor=c, label=t) for c, t in zip(RATIO_COLORS, RATIO_LABELS)]
    handles += [Patch(facecolor=MARK_STYLE[m][0], label=f"{MARK_STYLE[m][1]}: {MARK_STYLE[m][2]}")
                for m in MARKED]
    handles.append(Patch(facecolor="white", edgecolor="#bdbdbd", hatch="////",
                         label="no window recorded"))
    axis.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7,
                title="worst zeta/epsilon", title_fontsize=7, frameon=False)
    axis.set_title(title or _title(view, len(shown), band), fontsize=9, loc="left")
    return figure


def _title(view: FleetView, shown: int, band) -> str:
    flagged = sum(row.flagged for row in view.rows)
    text = f"Fleet at a glance: {len(view.rows)} assets, {flagged} flagged"
    if view.nights:
        text += f"\nnights {view.nights[0]} to {view.nights[-1]}"
    return text + (f" (worst {shown} shown, {band.count} folded)" if band is not None else "")


def heatmap_png(view: FleetView, top: int = DEFAULT_TOP, dpi: int = 100) -> bytes:
    """The heat map as PNG bytes."""
    buffer = io.BytesIO()
    fleet_heatmap_figure(view, top).savefig(buffer, format="png", dpi=dpi)
    return buffer.getvalue()
