"""The fleet's recorded worst ratios per asset and night, read in a few searches.

A night is the UTC date of a candidate window's last instant (the date its window starts
on, unless ``[nightly] candidate_nights`` > 1 spans it over earlier nights: its night is the
last one, :func:`night_of_window`); its ratio is the run's
``max_ratio`` metric (the largest zeta/epsilon over the tiers and channels of the window;
the largest over the windows when a night has several). Runs are read with one (paged)
``search_runs`` over every vehicle class's experiment per date a window may end on
(``window_end LIKE 'YYYY-MM-DD%'``: MLflow compares tags only with ``=`` and ``LIKE``;
the nights and the day after the last), so exactly the runs of those nights are read,
never one call per asset. Only complete nightly candidates count, one per asset and window
(the latest recorded); reanalyses are left out.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Sequence

import pandas as pd

from registry import naming
from registry.backend import Backend
from registry.boundary import raises_registry_errors
from registry.fleet_runs import published_nights
from registry.history import _asset_runs

_DATE = re.compile(r"\d{4}-\d{2}-\d{2}")


@dataclass(frozen=True)
class NightRatio:
    """One asset's worst ratio of one night (None: recorded without a threshold)."""

    asset_id: str
    vehicle_class: str
    night: str
    ratio: float | None


@raises_registry_errors
def night_ratios(backend: Backend, nights: Sequence[str]) -> list[NightRatio]:
    """The worst ratio per asset and night, for the nights given (``YYYY-MM-DD``).

    Returns
    -------
    list of NightRatio
        One per asset and night with at least one recorded candidate window, by asset then
        night.
    """
    wanted = set(nights)
    experiment_ids = backend.experiment_ids()
    if not wanted or not experiment_ids:
        return []
    worst: dict[tuple[str, str], NightRatio] = {}
    for day in sorted(wanted):
        if _DATE.fullmatch(day) is None:
            raise ValueError(f"a night is a date YYYY-MM-DD, not {day!r}")
    # a window of night d ends on d (a window shorter than a day) or at midnight after d
    ends = wanted | {(pd.Timestamp(d) + pd.Timedelta(days=1)).strftime("%Y-%m-%d")
                     for d in wanted}
    for day in sorted(ends):
        runs = _asset_runs(backend, experiment_ids, [
            f"tags.`{naming.TAG_ROLE}` = '{naming.CANDIDATE}'",
            f"tags.`{naming.TAG_WINDOW_END}` LIKE '{day}%'"])
        for run in runs:
            tags = run.data.tags
            night = night_of_window(tags[naming.TAG_WINDOW_END])
            if night not in wanted:
                continue
            ratio = run.data.metrics.get("max_ratio")
            ratio = None if ratio is None or not math.isfinite(ratio) else float(ratio)
            key = (tags[naming.TAG_ASSET_ID], night)
            before = worst.get(key)
            if before is None or (ratio is not None and (before.ratio is None
                                                         or ratio > before.ratio)):
                worst[key] = NightRatio(key[0], tags.get(naming.TAG_VEHICLE_CLASS, ""), night,
                                        ratio)
    return [worst[key] for key in sorted(worst)]


@raises_registry_errors
def latest_candidate_night(backend: Backend) -> str | None:
    """The night of the most recent recorded candidate window (None if there is none)."""
    experiment_ids = backend.experiment_ids()
    if not experiment_ids:
        return None
    runs = backend.client.search_runs(
        experiment_ids, f"tags.`{naming.TAG_COMPLETE}` = 'true' and "
                        f"tags.`{naming.TAG_ROLE}` = '{naming.CANDIDATE}'",
        order_by=[f"tags.`{naming.TAG_WINDOW_END}` DESC"], max_results=50)
    for run in runs:
        if run.data.tags.get(naming.TAG_REANALYSIS) != "true":
            return night_of_window(run.data.tags[naming.TAG_WINDOW_END])
    return None


@raises_registry_errors
def latest_night(backend: Backend) -> str | None:
    """The latest night with a recorded candidate window or a published fleet-level run
    (None if there is neither)."""
    known = [night for night in (latest_candidate_night(backend),
                                 max(published_nights(backend), default=None)) if night]
    return max(known, default=None)


def night_of_window(window_end) -> str:
    """The night (``YYYY-MM-DD``) of a window ending at ``window_end`` (exclusive): the date
    of its last instant, so a multi-night window counts on its last night."""
    return (pd.Timestamp(window_end) - pd.Timedelta(microseconds=1)).strftime("%Y-%m-%d")
