"""Where telemetry lives: asset ids, the partition layout, and UTC time in integer ns.

Layout (hive-partitioned Parquet)::

    <root>/asset_id=<id>/date=<YYYY-MM-DD>/<any>.parquet

Files whose name starts with ``.`` or does not end in ``.parquet`` are ignored (temporary and
hidden files). Symbolic links are followed only when they resolve inside the telemetry root;
a link out of it is skipped (:func:`scan` and :func:`outside_links` name it).
"""
from __future__ import annotations

import datetime
import os
import pathlib
import re
from dataclasses import dataclass, field

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



@dataclass(frozen=True)
class Skipped:
    """An entry of the telemetry root that is not read, and why."""

    path: str
    reason: str

    def to_dict(self) -> dict:
        return {"path": self.path, "reason": self.reason}


@dataclass(frozen=True)
class Scan:
    """What the telemetry root holds.

    Attributes
    ----------
    assets : list of str
        Sorted ids of the valid ``asset_id=<id>`` directories.
    skipped : list of Skipped
        Entries not read: an invalid id, a symbolic link out of the root, a directory or
        Parquet file outside the layout (in the root or in an asset's directory).
    stray_parquet : list of str
        Without any asset: up to a few Parquet files found anywhere under the root (the
        telemetry is there, in another layout).
    """

    assets: list[str]
    skipped: list[Skipped] = field(default_factory=list)
    stray_parquet: list[str] = field(default_factory=list)


EXPECTED_LAYOUT = f"<root>/{ASSET_PREFIX}<ID>/{DATE_PREFIX}<YYYY-MM-DD>/<file>.parquet"


def is_outside(path: pathlib.Path, root: pathlib.Path) -> bool:
    """Whether ``path`` (a symbolic link, or under one) resolves outside ``root``."""
    try:
        path.resolve().relative_to(pathlib.Path(root).resolve())
    except ValueError:
        return True
    return False


def scan(root, stray_limit: int = 5) -> Scan:
    """The assets of the store and every entry skipped, with why (nothing skipped silently).

    Parameters
    ----------
    root : str or path-like
        The telemetry root.
    stray_limit : int, default 5
        Parquet files to name when the root holds no asset.

    Raises
    ------
    FileNotFoundError
        If ``root`` is not a directory (a misconfigured root should not look like an empty
        fleet).
    """
    root = pathlib.Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"telemetry root {str(root)!r} is not a directory")
    ids, skipped = [], []
    for entry in sorted(root.iterdir()):
        name = entry.name
        if name.startswith("."):
            continue
        if entry.is_symlink() and is_outside(entry, root):
            skipped.append(Skipped(str(entry), f"symbolic link to {os.readlink(entry)} outside "
                                               f"the telemetry root: not followed"))
            continue
        if not name.startswith(ASSET_PREFIX):
            if entry.is_dir() or name.endswith(".parquet"):
                skipped.append(Skipped(str(entry), f"not in the layout {EXPECTED_LAYOUT}"))
            continue
        asset_id = name[len(ASSET_PREFIX):]
        try:
            validate_asset_id(asset_id)
        except InvalidAssetIdError as error:
            skipped.append(Skipped(str(entry), str(error)))
            continue
        if not entry.is_dir():
            skipped.append(Skipped(str(entry), "not a directory"))
            continue
        ids.append(asset_id)
        skipped += _asset_entries(root, entry)
    stray = [] if ids else _parquet_under(root, stray_limit)
    return Scan(sorted(ids), skipped, stray)


def _asset_entries(root: pathlib.Path, asset_dir: pathlib.Path) -> list[Skipped]:
    """What an asset's directory holds besides ``date=`` partitions (not read)."""
    out = []
    for entry in sorted(asset_dir.iterdir()):
        if entry.name.startswith("."):
            continue
        if entry.is_symlink() and is_outside(entry, root):
            out.append(Skipped(str(entry), f"symbolic link to {os.readlink(entry)} outside "
                                           f"the telemetry root: not followed"))
        elif not entry.name.startswith(DATE_PREFIX) and (entry.is_dir()
                                                         or entry.name.endswith(".parquet")):
            out.append(Skipped(str(entry), f"not in the layout {EXPECTED_LAYOUT}"))
    return out


def _parquet_under(root: pathlib.Path, limit: int) -> list[str]:
    found = []
    for directory, subdirs, files in os.walk(root):
        subdirs[:] = sorted(d for d in subdirs if not d.startswith("."))
        for name in sorted(files):
            if name.endswith(".parquet") and not name.startswith("."):
                found.append(str(pathlib.Path(directory, name).relative_to(root)))
                if len(found) >= limit:
                    return found
    return found


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
        asset id, and links out of the root, are skipped (:func:`scan` says which and why).

    Raises
    ------
    FileNotFoundError
        If ``root`` is not a directory (a misconfigured root should not look like an empty
        fleet).
    """
    return scan(root).assets


def list_dates(root, asset_id: str) -> list[datetime.date]:
    """Partition dates present for the asset ``asset_id`` under the telemetry root ``root``
    (a path).

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
    if not asset_dir.is_dir() or is_outside(asset_dir, root):
        return []
    found = []
    for entry in asset_dir.iterdir():
        if not entry.name.startswith(DATE_PREFIX) or not entry.is_dir():
            continue
        if entry.is_symlink() and is_outside(entry, root):
            continue  # a link out of the root (scan names it)
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


def parquet_files(directory: pathlib.Path, root=None) -> list[pathlib.Path]:
    """A partition's Parquet files by name, hidden and temporary files left out, and links
    resolving outside ``root`` when it is given (see :func:`outside_links`)."""
    return sorted((p for p in directory.iterdir()
                   if p.name.endswith(".parquet") and not p.name.startswith(".") and p.is_file()
                   and not (root is not None and p.is_symlink() and is_outside(p, root))),
                  key=lambda p: p.name)


def outside_links(root, asset_id: str, dates) -> list[str]:
    """The Parquet files of the asset's partitions ``dates`` that are symbolic links out of
    the telemetry root (skipped by the reading)."""
    wanted = set(dates)
    out = []
    for day, directory in partitions(root, asset_id):
        if day in wanted:
            out += [str(p) for p in sorted(directory.iterdir())
                    if p.name.endswith(".parquet") and p.is_symlink() and is_outside(p, root)]
    return out


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
