"""Where telemetry lives: asset ids, the partition layout, and UTC time in integer ns.

Layout (hive-partitioned Parquet)::

    <root>/asset_id=<id>/date=<YYYY-MM-DD>/<any>.parquet

Files whose name starts with ``.`` or does not end in ``.parquet`` are ignored (temporary and
hidden files).
"""
from __future__ import annotations

import datetime
import pathlib
import re

import pandas as pd

from graybox.exceptions import InvalidAssetIdError, TelemetryError
from graybox.timestamps import utc

ASSET_ID_PATTERN: re.Pattern = re.compile(r"[A-Za-z0-9_.-]{1,64}")
"""Valid asset ids (use with ``fullmatch``); ``"."`` and ``".."`` are rejected besides."""

ASSET_PREFIX = "asset_id="
DATE_PREFIX = "date="
_DATE_RE = re.compile(r"\d{4}-\d{2}-\d{2}")
FILE_NAME_RE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*\.parquet")
NS_PER_SECOND = 1_000_000_000
NS_PER_DAY = 86_400 * NS_PER_SECOND


def validate_asset_id(asset_id: str) -> str:
    """Return ``asset_id`` if it is a valid asset id, else raise.

    A valid id matches ``[A-Za-z0-9_.-]{1,64}`` and is neither ``"."`` nor ``".."``, so it is
    safe to use as a path component and in registry names.

    Parameters
    ----------
    asset_id : str
        The id to check.

    Returns
    -------
    str
        ``asset_id`` unchanged.

    Raises
    ------
    InvalidAssetIdError
        If ``asset_id`` is not a string or is not a valid id.
    """
    if (not isinstance(asset_id, str) or ASSET_ID_PATTERN.fullmatch(asset_id) is None
            or asset_id in (".", "..")):
        raise InvalidAssetIdError(
            f"invalid asset id {asset_id!r}: must match [A-Za-z0-9_.-]{{1,64}} "
            f"and not be '.' or '..'")
    return asset_id



def list_assets(root) -> list[str]:
    """Ids of the assets in the store.

    Parameters
    ----------
    root : str or path-like
        The telemetry root.

    Returns
    -------
    list of str
        Sorted ids of the ``asset_id=<id>`` directories. Directories whose id is not a valid
        asset id are skipped.

    Raises
    ------
    FileNotFoundError
        If ``root`` is not a directory (a misconfigured root should not look like an empty
        fleet).
    """
    root = pathlib.Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"telemetry root {str(root)!r} is not a directory")
    ids = []
    for entry in root.iterdir():
        if not entry.name.startswith(ASSET_PREFIX) or not entry.is_dir():
            continue
        asset_id = entry.name[len(ASSET_PREFIX):]
        try:
            ids.append(validate_asset_id(asset_id))
        except InvalidAssetIdError:
            continue
    return sorted(ids)


def list_dates(root, asset_id: str) -> list[datetime.date]:
    """Partition dates present for one asset.

    Parameters
    ----------
    root : str or path-like
        The telemetry root.
    asset_id : str
        The asset.

    Returns
    -------
    list of datetime.date
        Sorted dates of the ``date=<YYYY-MM-DD>`` directories; empty if the asset has none.

    Raises
    ------
    InvalidAssetIdError
        If ``asset_id`` is invalid.
    TelemetryError
        Kind ``"unreadable"``, naming the directory, if a ``date=`` directory name is not a
        valid ``YYYY-MM-DD`` date.
    """
    return [d for d, _ in partitions(root, asset_id)]


def partitions(root, asset_id: str) -> list[tuple[datetime.date, pathlib.Path]]:
    """Sorted (date, directory) of an asset's ``date=`` partitions (see :func:`list_dates`)."""
    validate_asset_id(asset_id)
    asset_dir = pathlib.Path(root) / f"{ASSET_PREFIX}{asset_id}"
    if not asset_dir.is_dir():
        return []
    found = []
    for entry in asset_dir.iterdir():
        if not entry.name.startswith(DATE_PREFIX) or not entry.is_dir():
            continue
        text = entry.name[len(DATE_PREFIX):]
        try:
            if _DATE_RE.fullmatch(text) is None:
                raise ValueError
            day = datetime.date.fromisoformat(text)
        except ValueError:
            raise TelemetryError(asset_id, "unreadable",
                                 f"partition directory name {entry.name!r} is not date=YYYY-MM-DD",
                                 file=str(entry)) from None
        found.append((day, entry))
    return sorted(found)


def parquet_files(directory: pathlib.Path) -> list[pathlib.Path]:
    """A partition's Parquet files by name, hidden and temporary files left out."""
    return sorted((p for p in directory.iterdir()
                   if p.name.endswith(".parquet") and not p.name.startswith(".") and p.is_file()),
                  key=lambda p: p.name)


def utc_ns(value, what: str) -> int:
    """A bound as int64 ns since the epoch, UTC (naive taken as UTC)."""
    try:
        when = pd.Timestamp(value)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{what} {value!r} is not a timestamp: {error}") from None
    if when is pd.NaT:
        raise ValueError(f"{what} must not be NaT")
    return int(utc(when).as_unit("ns").value)


def day_ns(day: datetime.date) -> int:
    """The start of a UTC date in ns since the epoch."""
    return (day - datetime.date(1970, 1, 1)).days * NS_PER_DAY


def stamp(ns: int) -> str:
    """ns since the epoch as an ISO 8601 UTC timestamp (for messages)."""
    return pd.Timestamp(int(ns), unit="ns", tz="UTC").isoformat()
