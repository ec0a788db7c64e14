"""Which asset-days changed since they were analysed: markers in the telemetry store.

A day partition that an import changed is marked by an empty file
``<root>/asset_id=<id>/.changed/<YYYY-MM-DD>`` (hidden: the layout ignores dot entries).
The nightly run re-analyses the windows of a marked day that lie before its watermark
and removes the marker once every window it selected for the asset was committed
(:mod:`flows.nightly`). One file per day: marking and clearing are single atomic file
operations, so an import and a run never lose each other's marks.
"""
from __future__ import annotations

import datetime
import pathlib
import re
from typing import Iterable

from graybox.telemetry.layout import ASSET_PREFIX, validate_asset_id

CHANGES_DIR = ".changed"
_DAY_RE = re.compile(r"\d{4}-\d{2}-\d{2}")


def _directory(root, asset_id: str) -> pathlib.Path:
    validate_asset_id(asset_id)
    return pathlib.Path(root) / f"{ASSET_PREFIX}{asset_id}" / CHANGES_DIR


def mark_changed(root, asset_id: str, days: Iterable[datetime.date]) -> None:
    """Mark the asset's partitions of ``days`` as changed since analysed.

    Parameters
    ----------
    root : str or path-like
        The telemetry root.
    asset_id : str
    days : iterable of datetime.date
        UTC dates of the changed partitions.
    """
    directory = _directory(root, asset_id)
    directory.mkdir(parents=True, exist_ok=True)
    for day in days:
        (directory / day.isoformat()).touch()


def changed_days(root, asset_id: str) -> list[datetime.date]:
    """The asset's marked days, sorted (empty when none; malformed names are ignored)."""
    directory = _directory(root, asset_id)
    if not directory.is_dir():
        return []
    days = []
    for entry in directory.iterdir():
        if _DAY_RE.fullmatch(entry.name):
            try:
                days.append(datetime.date.fromisoformat(entry.name))
            except ValueError:
                continue
    return sorted(days)


def clear_changed(root, asset_id: str, days: Iterable[datetime.date]) -> None:
    """Remove the marks of ``days`` (analysed again); missing marks are fine."""
    directory = _directory(root, asset_id)
    for day in days:
        (directory / day.isoformat()).unlink(missing_ok=True)
