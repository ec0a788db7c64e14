"""The fleet at a glance: assets x recent nights, the record the heat map is drawn from.

A cell is an asset's worst zeta/epsilon ratio of a night (the largest over the tiers and
channels of the windows starting that UTC day, from the registry), or None when no window
was recorded; it may carry a mark from the nightly run's statuses: ``failed`` (on the
night of the window that failed), ``stale``, ``unusable baseline``, ``not operating`` or
``dormant`` (on the run's night). Rows are sorted worst first: the assets flagged on the last
night (a ratio above 1 or a mark of :data:`FLAGGING`: ``not operating`` is drawn, so that a
calm night is not mistaken for a missing one, but is not a problem; ``dormant``, not
operating for longer than ``[alerts] not_operating_after``, is), then those flagged on an
earlier night, then the rest, each group by its worst ratio; :meth:`FleetView.fold` keeps the top
rows and folds the rest into one band.

The night of a run is the last UTC day ended by its ``as_of`` (:func:`night_of`). Each
night's statuses (:func:`night_document`) are kept with the night's fleet-level run
(:mod:`registry.fleet_nights`), so a view of past nights gets their marks back
(:func:`collect_view`).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Iterable, Mapping, Sequence

import pandas as pd

from flows.results import (DORMANT, FAILED, NO_BASELINE, NO_TELEMETRY, NOT_OPERATING, OK,
                           UP_TO_DATE, RunSummary)

STALE, UNUSABLE_BASELINE = "stale", "unusable baseline"   # flows.results statuses
#: statuses drawn on the heat map (each distinctly)
MARKED = (FAILED, STALE, UNUSABLE_BASELINE, NOT_OPERATING, DORMANT)
#: marks that flag their row (a problem), as an alarm does
FLAGGING = (FAILED, STALE, UNUSABLE_BASELINE, DORMANT)
DEFAULT_NIGHTS = 14
DEFAULT_TOP = 40
VIEW_FILE = "fleet_view.json"          #: the view, as an artifact of a night's fleet run


def night_of(as_of) -> str:
    """The night of a run as of ``as_of``: the last UTC day it ended (``YYYY-MM-DD``)."""
    stamp = pd.Timestamp(as_of)
    stamp = stamp.tz_localize("UTC") if stamp.tzinfo is None else stamp.tz_convert("UTC")
    return (stamp.floor("D") - pd.Timedelta(days=1)).strftime("%Y-%m-%d")


def window_nights(last: str, count: int) -> tuple[str, ...]:
    """The ``count`` nights ending with ``last``, oldest first."""
    if count < 1:
        raise ValueError(f"a view needs at least one night, got {count}")
    end = pd.Timestamp(last)
    return tuple((end - pd.Timedelta(days=i)).strftime("%Y-%m-%d")
                 for i in range(count - 1, -1, -1))


@dataclass(frozen=True)
class Mark:
    """A status drawn on one asset-night (one of :data:`MARKED`), with why."""

    asset_id: str
    vehicle_class: str
    night: str
    status: str
    reason: str = ""

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Mapping) -> "Mark":
        return cls(**dict(data))


@dataclass(frozen=True)
class AssetNights:
    """One row: an asset's worst ratio and mark per night (None: nothing recorded)."""

    asset_id: str
    vehicle_class: str
    ratios: tuple[float | None, ...]
    marks: tuple[str | None, ...]

    @property
    def worst(self) -> float | None:
        """The largest ratio over the nights (None when no night has one)."""
        known = [r for r in self.ratios if r is not None]
        return max(known) if known else None

    @property
    def flagged(self) -> bool:
        """An alarm (ratio above 1) or a flagging mark on some night."""
        worst = self.worst
        return (worst is not None and worst > 1.0) or any(m in FLAGGING for m in self.marks)

    @property
    def flagged_last_night(self) -> bool:
        """An alarm or a flagging mark on the view's last night (a problem now)."""
        last = self.ratios[-1] if self.ratios else None
        return (last is not None and last > 1.0) or bool(self.marks
                                                         and self.marks[-1] in FLAGGING)

    def sort_key(self) -> tuple:
        """Worst first: flagged on the last night, then flagged earlier, then the rest; each
        group by its worst ratio, largest first, then by asset id."""
        group = 0 if self.flagged_last_night else 1 if self.flagged else 2
        worst = self.worst
        return (group, -(worst if worst is not None else -1.0), self.asset_id)

    def to_dict(self) -> dict:
        return {"asset_id": self.asset_id, "vehicle_class": self.vehicle_class,
                "ratios": list(self.ratios), "marks": list(self.marks)}

    @classmethod
    def from_dict(cls, data: Mapping) -> "AssetNights":
        return cls(data["asset_id"], data["vehicle_class"],
                   tuple(None if r is None else float(r) for r in data["ratios"]),
                   tuple(data["marks"]))


@dataclass(frozen=True)
class FoldedBand:
    """The rows folded below the top ones: how many, how many flagged, and per night the
    largest ratio among them."""

    count: int
    flagged: int
    ratios: tuple[float | None, ...]

    @property
    def label(self) -> str:
        text = f"{self.count} more asset{'' if self.count == 1 else 's'}"
        return text + (f" ({self.flagged} flagged)" if self.flagged else " (healthy)")


@dataclass(frozen=True)
class FleetView:
    """Assets x nights: the heat map's data.

    Attributes
    ----------
    nights : tuple of str
        ``YYYY-MM-DD``, oldest first.
    rows : tuple of AssetNights
        Worst first (see the module docstring).
    coverage : tuple of (str, int)
        Counts of the latest night with a nightly run: ``assets``, ``monitored`` (ok or up
        to date), ``stale``, ``failed``, ``without baseline``, ``unusable baseline``,
        ``no telemetry``, ``not operating``, ``dormant`` (empty when no run recorded its
        statuses; a night recorded before a count existed lacks it).
    coverage_night : str or None
        The night those counts are of.
    """

    nights: tuple[str, ...]
    rows: tuple[AssetNights, ...]
    coverage: tuple[tuple[str, int], ...] = ()
    coverage_night: str | None = None

    def fold(self, top: int) -> tuple[tuple[AssetNights, ...], FoldedBand | None]:
        """The ``top`` worst rows, and the rest as one band (None when nothing is folded;
        a single leftover row is shown rather than folded)."""
        if top < 0:
            raise ValueError(f"top must be >= 0, got {top}")
        if len(self.rows) <= top + 1:
            return self.rows, None
        shown, rest = self.rows[:top], self.rows[top:]
        ratios = []
        for i in range(len(self.nights)):
            known = [row.ratios[i] for row in rest if row.ratios[i] is not None]
            ratios.append(max(known) if known else None)
        return shown, FoldedBand(len(rest), sum(row.flagged for row in rest), tuple(ratios))

    def to_dict(self) -> dict:
        return {"nights": list(self.nights), "rows": [row.to_dict() for row in self.rows],
                "coverage": dict(self.coverage), "coverage_night": self.coverage_night}

    @classmethod
    def from_dict(cls, data: Mapping) -> "FleetView":
        return cls(tuple(data["nights"]), tuple(AssetNights.from_dict(r) for r in data["rows"]),
                   tuple((k, int(v)) for k, v in dict(data.get("coverage", {})).items()),
                   data.get("coverage_night"))


def build_view(nights: Sequence[str], ratios: Iterable, marks: Iterable[Mark] = (),
               coverage: Mapping[str, int] | None = None,
               coverage_night: str | None = None) -> FleetView:
    """The view of ``nights`` from per-asset-night ratios and marks.

    Parameters
    ----------
    nights : sequence of str
        ``YYYY-MM-DD``, oldest first.
    ratios : iterable
        Records with ``asset_id``, ``vehicle_class``, ``night`` and ``ratio``
        (:class:`registry.fleet_nights.NightRatio`); those of other nights are ignored.
    marks : iterable of Mark
        Later marks of the same asset-night replace earlier ones; marks of nights before
        the first are drawn on the first, those after the last are ignored.
    coverage : mapping, optional
    coverage_night : str, optional
    """
    column = {night: i for i, night in enumerate(nights)}
    classes: dict[str, str] = {}
    cells: dict[str, list] = {}
    flags: dict[str, list] = {}

    def row(asset: str, vehicle_class: str) -> None:
        if asset not in cells:
            cells[asset] = [None] * len(nights)
            flags[asset] = [None] * len(nights)
        classes[asset] = classes.get(asset) or vehicle_class

    for item in ratios:
        if item.night not in column:
            continue
        row(item.asset_id, item.vehicle_class)
        ratio = item.ratio
        if ratio is not None and math.isfinite(ratio):
            before = cells[item.asset_id][column[item.night]]
            cells[item.asset_id][column[item.night]] = ratio if before is None else max(before,
                                                                                         ratio)
    for mark in marks:
        if mark.status not in MARKED or not nights or mark.night > nights[-1]:
            continue
        # a failure of a window older than the view stays visible on its first night
        where = column.get(mark.night, 0)
        row(mark.asset_id, mark.vehicle_class)
        flags[mark.asset_id][where] = mark.status
    rows = sorted((AssetNights(asset, classes[asset], tuple(cells[asset]), tuple(flags[asset]))
                   for asset in cells), key=AssetNights.sort_key)
    return FleetView(tuple(nights), tuple(rows), tuple((coverage or {}).items()), coverage_night)


# -- from a nightly run's summary ------------------------------------------------------------

def summary_marks(summary: RunSummary, night: str) -> list[Mark]:
    """The marks of a nightly run whose night is ``night``: a failed asset on the night of
    the window that failed (the run's night when unknown), the other marked statuses on the
    run's night."""
    out = []
    for asset in summary.assets:
        if asset.status not in MARKED:
            continue
        where = night
        if asset.status == FAILED and asset.error is not None and asset.error.window_start:
            where = min(night, pd.Timestamp(asset.error.window_start).strftime("%Y-%m-%d"))
        out.append(Mark(asset.asset_id, asset.vehicle_class, where, asset.status,
                        asset.reason()))
    return out


def coverage_counts(summary: RunSummary) -> dict[str, int]:
    """How much of the fleet a nightly run covered (see :class:`FleetView`)."""
    counts = summary.counts()
    return {"assets": len(summary.assets),
            "monitored": counts.get(OK, 0) + counts.get(UP_TO_DATE, 0),
            "stale": counts.get(STALE, 0), "failed": counts.get(FAILED, 0),
            "without baseline": counts.get(NO_BASELINE, 0),
            "unusable baseline": counts.get(UNUSABLE_BASELINE, 0),
            "no telemetry": counts.get(NO_TELEMETRY, 0),
            "not operating": counts.get(NOT_OPERATING, 0),
            "dormant": counts.get(DORMANT, 0)}


def night_document(summary: RunSummary) -> dict:
    """What a nightly run keeps of its night with the fleet-level run: the night, its marks,
    its coverage counts and the nights it recorded windows in (JSON types)."""
    night = night_of(summary.as_of)
    from registry import night_of_window

    recorded = sorted({night_of_window(w.window_end) for a in summary.assets for w in a.windows})
    return {"night": night, "as_of": summary.as_of, "flow_run_id": summary.flow_run_id,
            "coverage": coverage_counts(summary), "nights_recorded": recorded,
            "marks": [mark.to_dict() for mark in summary_marks(summary, night)]}


# -- from the registry -----------------------------------------------------------------------

def collect_view(registry, last_night: str, count: int = DEFAULT_NIGHTS,
                 tonight: dict | None = None) -> FleetView:
    """The view of the ``count`` nights ending with ``last_night``, from the registry.

    Without ``tonight`` (the report), every night's ratios are read from the candidates
    recorded (:func:`registry.fleet_nights.night_ratios`) and the marks and coverage from
    the nights' fleet-level runs. With ``tonight`` (a :func:`night_document` being
    published by the nightly run), the latest view published up to that night
    (``fleet_view.json`` of its fleet-level run) gives the cells and marks of its nights,
    except the nights tonight's run recorded windows in, which are read again; the nights
    it does not cover are read; tonight's marks and coverage are added. A nightly view
    thus reads about one night of runs, not ``count``.
    """
    from registry import NightRatio

    nights = window_nights(last_night, count)
    runs = {night: run for night, run in registry.published_nights().items() if night in nights}
    if tonight is None:
        documents = registry.night_statuses(runs)
        marks = [Mark.from_dict(m) for night in sorted(documents)
                 for m in documents[night].get("marks", [])]
        latest = max(documents) if documents else None
        coverage = documents[latest].get("coverage", {}) if latest else {}
        return build_view(nights, registry.night_ratios(nights), marks, coverage, latest)

    previous = None
    for night in sorted(runs, reverse=True):
        document = registry.night_file(runs[night], VIEW_FILE)
        if document is not None:
            previous = FleetView.from_dict(document)
            break
    recorded = set(tonight.get("nights_recorded", ()))
    covered = set() if previous is None else set(previous.nights) - recorded
    ratios: list = registry.night_ratios([n for n in nights if n not in covered])
    marks: list[Mark] = []
    for row in () if previous is None else previous.rows:
        for night, ratio, mark in zip(previous.nights, row.ratios, row.marks):
            if night in covered and ratio is not None:
                ratios.append(NightRatio(row.asset_id, row.vehicle_class, night, ratio))
            if mark is not None:
                marks.append(Mark(row.asset_id, row.vehicle_class, night, mark))
    marks += [Mark.from_dict(m) for m in tonight.get("marks", [])]
    return build_view(nights, ratios, marks, tonight.get("coverage", {}), tonight["night"])
