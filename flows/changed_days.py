"""Days changed after they were analysed (``fleet-health import`` merged rows into them):
which windows the nightly run re-analyses, and when their marks are cleared.

``fleet-health import`` marks every asset-day it adds rows to
(:mod:`graybox.telemetry.changes`). The nightly run then takes, besides the windows past the
watermark and the late ones, the whole windows of the marked days that end by the watermark
(whatever the look-back: the user imported them on purpose), never before the baseline's
window. Their candidates are recorded again: the data hash differs, so the record is new,
with its alerts. A mark is cleared once the asset's run committed every window it selected
(a day not yet over stays marked until it is); a failed asset keeps its marks, so the next run
retries. Marks of days inside the baseline's window are cleared without analysis (the nightly
run never analyses those: refit the baseline to use them); the asset's note says so.
"""
from __future__ import annotations

import datetime
from typing import Iterable

import pandas as pd

from flows.discovery import utc, windows_in_dates

DAY = pd.Timedelta(days=1)


def changed_windows(marked: Iterable[datetime.date], dates: Iterable[datetime.date],
                    watermark: pd.Timestamp, window: pd.Timedelta
                    ) -> list[tuple[pd.Timestamp, pd.Timestamp]]:
    """The whole windows of the marked days that have a partition and end by ``watermark``
    (the later ones are pending anyway), in time order.

    Parameters
    ----------
    marked : iterable of datetime.date
        The asset's changed days (:func:`graybox.telemetry.changes.changed_days`).
    dates : iterable of datetime.date
        Its partitions.
    watermark : pandas.Timestamp
    window : pandas.Timedelta
        The nightly window (divides a day).
    """
    present = set(dates) & set(marked)
    return [(s, e) for s, e in windows_in_dates(present, window) if e <= utc(watermark)]


def days_done_by(marked: Iterable[datetime.date], end: pd.Timestamp) -> list[datetime.date]:
    """The marked days that are over by ``end`` (every window of theirs selected by a run
    as of ``end``, or inside a baseline window ending at ``end``)."""
    end = utc(end)
    return [d for d in marked if utc(pd.Timestamp(d)) + DAY <= end]

