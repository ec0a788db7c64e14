"""The operating conditions a signature was fitted under, and how far a night lies outside
its baseline's.

A coarse white box leaves a model error in the residual that depends on how the plant is
driven: a compressor's duty cycle follows the day's air demand, a conveyor's heating its
day's load. Every tier's parameters move with it, and a baseline of a few days has only seen
the conditions of those days. Calibration (:mod:`graybox.calibration`, step 5) learns how much
healthy days differ from each other; a night driven beyond every baseline day's conditions
differs by more, and no threshold from those days covers it.

The conditions are the exogenous inputs (those no controller sets, see
``WhiteBoxModel.controlled_inputs``: a fault a loop compensates moves the loop's output, and
must not read as a night outside the range). Per telemetry window, each input's mean and
standard deviation over the window's operating samples and the standard deviation of its
sample-to-sample steps within segments (level, spread and *excitation*: how hard it was
stepped, a cloudy day's irradiance against a clear day's) are its *figures*; the same
figures are kept for each of the window's :data:`PIECES` equal pieces (a day's pieces are
its times of day).

A baseline's *centre* is the mean of its windows' figures and its *reach* the largest distance
of one window from the centre, per figure. A figure counts only where the baseline's windows
differ by more than chance: a two-way analysis of variance of the pieces' figures (window by
piece, additive) tests the windows' effect against what is left after the windows' and the
times of day's, at :data:`VARYING_LEVEL`. A daily cycle every window shares (the gas turbine's
load, a mast's afternoon gusts) is the pieces' effect and does not hide the windows'; a plant
driven the same way every day has windows that differ by chance alone, and a night a little
beyond the reach of five such days is not outside anything. A candidate lies :func:`outside`
by the largest ratio, over the counted figures and over its own windows, of a window's
distance from the centre to the reach: above 1, it was driven beyond any baseline day.
An excitation counts even where the days agree on it, with a reach of at least three
standard errors of a day's figure from the same analysis's residual (a night stepped three
times harder than five alike days is outside them however alike they were); it answers
only to the noise tier (``Tier.condition_figures``): what a coarse white box mispredicts
from one sample to the next grows with the step, so the residual's variance and tails
follow the excitation while the AR and network tiers' dynamics follow the operating point.
A fault whose effect feeds back into an exogenous input (a road's grade per second moves
with the bus's speed) can be taken for a harder-driven night by the noise tier only. A
candidate of several nights is as far outside as its farthest night: their average would put
a night far beyond the range together with one inside it back near the centre.
:class:`graybox.tiers.Tier` divides the AR, network and noise tiers' changes by that ratio
where it exceeds 1 (zeta by its square), as the level tier's change is divided by its own
extrapolation, which counts an input only where the same test finds its means differ
(:meth:`OperatingConditions.varying_inputs`): a tier's healthy change grows with the distance,
and calibration measured it only up to the reach. Calibration divides each left-out
day's changes by its own ratio to the other days, so the threshold describes a night within
the range and the two stay consistent.

Measured on the plant zoo and the detection grid (docs/benchmarks.md, "Nights driven beyond
the baseline's conditions").
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import ClassVar, Sequence

import numpy as np
from scipy import special

from graybox.models.base import WhiteBoxModel

#: pieces a window is cut into to tell how much its figures vary within it
PIECES = 8
#: significance at which the baseline's windows must differ in a figure for it to count
VARYING_LEVEL = 0.01
#: the figures kept per input, in the order of :meth:`OperatingConditions.figures`
FIGURE_KINDS = ("mean", "spread", "excitation")


@dataclass(frozen=True)
class OperatingConditions:
    """Per telemetry window, the exogenous inputs' means and standard deviations.

    Attributes
    ----------
    inputs : tuple of str
        The exogenous inputs (model input names), in the order of the figures.
    means, spreads : tuple of tuple of float
        Per window, per input: mean and standard deviation over the operating samples.
    piece_means, piece_spreads : tuple of tuple of tuple of float
        Per window, per piece (:data:`PIECES` equal pieces of its operating samples), per
        input: the same figures.
    excitations, piece_excitations : tuple or None
        The same per window and per piece for the standard deviation of the input's
        sample-to-sample steps within segments; None in a record stored before it.
    """

    inputs: tuple[str, ...]
    means: tuple[tuple[float, ...], ...]
    spreads: tuple[tuple[float, ...], ...]
    piece_means: tuple[tuple[tuple[float, ...], ...], ...]
    piece_spreads: tuple[tuple[tuple[float, ...], ...], ...]
    excitations: tuple[tuple[float, ...], ...] | None = None
    piece_excitations: tuple[tuple[tuple[float, ...], ...], ...] | None = None

    omitted_when_none: ClassVar[frozenset[str]] = frozenset({"excitations",
                                                             "piece_excitations"})

    def figures(self) -> np.ndarray:
        """Array of shape (windows, k * inputs): each window's means, its spreads, then its
        excitations where the record has them (:data:`FIGURE_KINDS`)."""
        parts = [_array(self.means), _array(self.spreads)]
        if self.excitations is not None:
            parts.append(_array(self.excitations))
        return np.hstack(parts)

    def reach(self) -> np.ndarray:
        """Per figure, the largest distance of a window from the windows' centre."""
        figures = self.figures()
        return np.abs(figures - figures.mean(axis=0)).max(axis=0)

    def varying(self) -> np.ndarray:
        """Per figure, whether the windows differ by more than chance: the windows' effect
        in a two-way additive analysis of variance of the pieces' figures (window by piece),
        F test at :data:`VARYING_LEVEL`. All False with fewer than two windows or windows of
        unequal piece counts."""
        analysis = self._two_way()
        if analysis is None:
            return np.zeros(self.figures().shape[1], dtype=bool)
        between, within, window_dof, dof, _ = analysis
        critical = special.fdtri(window_dof, dof, 1 - VARYING_LEVEL)   # scipy.stats.f.ppf
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(within > 0, between / within, np.where(between > 0, np.inf, 0.0))
        return ratio > critical

    def _two_way(self) -> tuple[np.ndarray, np.ndarray, int, int, int] | None:
        """The two-way additive analysis of variance of the pieces' figures (window by
        piece): per figure the windows' mean square and the residual mean square, with
        their degrees of freedom and the pieces per window; None where it cannot be made
        (fewer than two windows or pieces, or windows of unequal piece counts)."""
        table = self.piece_figures()
        windows = len(self.means)
        if windows < 2 or table is None or table.shape[1] < 2:
            return None
        pieces = table.shape[1]
        grand = table.mean(axis=(0, 1))
        window_effect = table.mean(axis=1) - grand
        piece_effect = table.mean(axis=0) - grand
        left = table - grand - window_effect[:, None, :] - piece_effect[None, :, :]
        between = pieces * (window_effect ** 2).sum(axis=0) / (windows - 1)
        dof = (windows - 1) * (pieces - 1)
        return between, (left ** 2).sum(axis=(0, 1)) / dof, windows - 1, dof, pieces

    def varying_inputs(self) -> tuple[str, ...]:
        """The inputs whose windows' means differ by more than chance (:meth:`varying`)."""
        means = self.varying()[:len(self.inputs)]
        return tuple(name for name, moves in zip(self.inputs, means) if moves)

    def piece_figures(self) -> np.ndarray | None:
        """Array of shape (windows, pieces, k * inputs), the columns of :meth:`figures`;
        None when the windows have different numbers of pieces."""
        if len({len(w) for w in self.piece_means}) != 1:
            return None
        means = np.asarray(self.piece_means, float).reshape(len(self.piece_means), -1,
                                                             len(self.inputs))
        parts = [means, np.asarray(self.piece_spreads, float).reshape(means.shape)]
        if self.piece_excitations is not None:
            parts.append(np.asarray(self.piece_excitations, float).reshape(means.shape))
        return np.concatenate(parts, axis=2)

    def chance_reach(self) -> np.ndarray:
        """Per figure, three standard errors of a window's figure from the pieces' variation
        the two-way analysis of :meth:`varying` leaves (``3 sqrt(within / pieces)``): how far
        windows that differ by chance alone may lie apart. 0 without a table."""
        analysis = self._two_way()
        if analysis is None:
            return np.zeros(self.figures().shape[1])
        _, within, _, _, pieces = analysis
        return 3.0 * np.sqrt(within / pieces)

def _array(rows) -> np.ndarray:
    return np.asarray(rows, float).reshape(len(rows), -1)


def _floats(values: np.ndarray) -> tuple[float, ...]:
    return tuple(float(v) for v in np.nan_to_num(values))


def exogenous_inputs(model: WhiteBoxModel) -> tuple[int, ...]:
    """Positions in ``model.inputs`` of the inputs no controller sets."""
    return tuple(i for i, name in enumerate(model.inputs) if name not in model.controlled_inputs)


def operating_conditions(model: WhiteBoxModel, inputs: Sequence[np.ndarray],
                         owners: Sequence[int]) -> OperatingConditions | None:
    """The conditions of a fit from its segments' input arrays.

    Parameters
    ----------
    model : WhiteBoxModel
    inputs : sequence of ndarray of shape (T, n_inputs)
        Each operating segment's inputs, in model order.
    owners : sequence of int
        The telemetry window of each segment (windows numbered from 0).

    Returns
    -------
    OperatingConditions or None
        None for a model without exogenous inputs.
    """
    positions = list(exogenous_inputs(model))
    if not positions:
        return None
    owners = np.asarray(owners)
    figures = {"means": [], "spreads": [], "piece_means": [], "piece_spreads": [],
               "excitations": [], "piece_excitations": []}
    for window in np.unique(owners):
        parts = [np.asarray(inputs[i], float).reshape(len(inputs[i]), -1)[:, positions]
                 for i in np.flatnonzero(owners == window)]
        u = np.concatenate(parts)
        steps = np.concatenate([np.diff(p, axis=0) for p in parts])   # none across segments
        pieces = [p for p in np.array_split(u, PIECES) if len(p)]
        step_pieces = np.array_split(steps, PIECES)[:len(pieces)]
        with warnings.catch_warnings():
            # a piece with an all-NaN input, or no step at all: its figure is 0 (_floats)
            warnings.simplefilter("ignore", RuntimeWarning)
            figures["means"].append(_floats(np.nanmean(u, axis=0)))
            figures["spreads"].append(_floats(np.nanstd(u, axis=0)))
            figures["excitations"].append(_floats(np.nanstd(steps, axis=0)))
            figures["piece_means"].append(tuple(_floats(np.nanmean(p, axis=0)) for p in pieces))
            figures["piece_spreads"].append(tuple(_floats(np.nanstd(p, axis=0)) for p in pieces))
            figures["piece_excitations"].append(tuple(_floats(np.nanstd(p, axis=0))
                                                      for p in step_pieces))
    return OperatingConditions(tuple(model.inputs[i] for i in positions),
                               **{name: tuple(rows) for name, rows in figures.items()})


def outside(candidate: OperatingConditions | None, baseline: OperatingConditions | None,
            kinds: Sequence[str] = FIGURE_KINDS) -> float:
    """How far outside its baseline's conditions a candidate was driven: the largest ratio,
    over the baseline's counted figures of the given kinds (:func:`covered`) and over the
    candidate's windows, of a window's distance from the baseline's centre to the
    baseline's reach. Above 1: beyond every baseline window. 0 where either lacks the
    record, their inputs differ, or no figure of those kinds counts.

    Parameters
    ----------
    candidate, baseline : OperatingConditions or None
    kinds : sequence of str, default FIGURE_KINDS
        The kinds of figure that count (``"mean"``, ``"spread"``, ``"excitation"``): a
        tier's :attr:`~graybox.tiers.Tier.condition_figures`.
    """
    return farthest(candidate, baseline, kinds)[0]


def farthest(candidate: OperatingConditions | None, baseline: OperatingConditions | None,
             kinds: Sequence[str] = FIGURE_KINDS) -> tuple[float, str | None]:
    """:func:`outside` and the figure that sets it, said for an engineer: the input, the
    candidate's value and the range of the baseline's windows (None where nothing counts).

    Examples
    --------
    ``(2.1, "demand_flow mean 4.42 (baseline days 2.91 to 3.62)")``
    """
    if candidate is None or baseline is None or candidate.inputs != baseline.inputs:
        return 0.0, None
    figures = baseline.figures()
    # a baseline stored before the excitation figure has fewer columns: those it has count
    width = min(figures.shape[1], candidate.figures().shape[1])
    counted = (_counted(baseline) & np.isin(_kinds(baseline), list(kinds)))[:width]
    if not counted.any():
        return 0.0, None
    reach = _reach(baseline)[:width]
    center = figures.mean(axis=0)[:width]
    # each of the candidate's windows on its own: a night far outside the range must not
    # hide behind a night inside it in their average (a two-night candidate)
    windows = candidate.figures()[:, :width]
    ratios = np.where(counted, np.abs(windows - center) / np.where(counted, reach, 1.0),
                      -np.inf)
    window, index = np.unravel_index(int(np.argmax(ratios)), ratios.shape)
    return float(ratios[window, index]), (
        f"{_figure_name(baseline, index)} {windows[window, index]:.4g} (baseline days "
        f"{figures[:, index].min():.4g} to {figures[:, index].max():.4g})")


def covered(baseline: OperatingConditions | None) -> tuple[str, ...]:
    """The figures :func:`outside` counts for a baseline, each with its days' range, said for
    an engineer: the conditions its nights are judged against (a night beyond them is said
    so in its alert, :func:`farthest`). Empty where no figure counts (a plant driven alike
    every day, or no exogenous input).

    Examples
    --------
    ``("outdoor_temp mean 8.12 to 12.3",)``
    """
    if baseline is None:
        return ()
    figures = baseline.figures()
    return tuple(f"{_figure_name(baseline, index)} {figures[:, index].min():.4g} to "
                 f"{figures[:, index].max():.4g}"
                 for index in np.flatnonzero(_counted(baseline)))


def _counted(baseline: OperatingConditions) -> np.ndarray:
    """Per figure, whether :func:`outside` counts it: a mean or spread where its windows
    differ beyond chance (:meth:`OperatingConditions.varying`) and reach from their centre,
    an excitation wherever its reach (:func:`_reach`) is above 0."""
    excitation = _kinds(baseline) == "excitation"
    return np.where(excitation, True, baseline.varying()) & (_reach(baseline) > 0)


def _reach(baseline: OperatingConditions) -> np.ndarray:
    """Per figure, the windows' reach; an excitation's is at least its
    :meth:`OperatingConditions.chance_reach`: days driven alike differ by that much."""
    reach = baseline.reach()
    return np.where(_kinds(baseline) == "excitation",
                    np.maximum(reach, baseline.chance_reach()), reach)


def _kinds(conditions: OperatingConditions) -> np.ndarray:
    """Per column of :meth:`OperatingConditions.figures`, its kind (:data:`FIGURE_KINDS`)."""
    return np.repeat(FIGURE_KINDS, len(conditions.inputs))[:conditions.figures().shape[1]]


def _figure_name(conditions: OperatingConditions, index: int) -> str:
    """``"<input> mean"``, ``"<input> spread"`` or ``"<input> excitation"`` for a column of
    :meth:`OperatingConditions.figures`."""
    return f"{conditions.inputs[index % len(conditions.inputs)]} {_kinds(conditions)[index]}"
