"""Telemetry store: reading, validating and gridding an asset's sensor data.

The contract: docs/design.md section 3.2 (layout) and section 5.1 (validation).

Layout (hive-partitioned Parquet)::

    <root>/asset_id=<id>/date=<YYYY-MM-DD>/<any>.parquet

Each file has a ``timestamp`` column and one numeric column per channel. Timestamps are UTC:
tz-aware timestamps are converted to UTC and naive timestamps are *taken as* UTC. A file's
rows must lie in its partition's UTC date. Files whose name starts with ``.`` or does not end
in ``.parquet`` are ignored (temporary and hidden files).

The path from store to model input is::

    read_raw -> validate -> to_grid      (read_window does all three)

``read_raw`` returns the rows as stored, each tagged with its file and 0-based row, so that
``validate`` can name the file and row of the first bad sample (docs/design.md section 5.1).
``to_grid`` puts the validated rows on the uniform grid the tiers assume. The limits of
:class:`GridPolicy` are durations, so one policy holds at 1 s, 10 s or 60 s samples. A
window with pauses (an intermittent asset, ``GridPolicy.intermittent``, ``running``) or a
logger's outages longer than ``max_gap`` is made of operating periods, each on its own grid
(docs/design.md section 4.11).

Modules: :mod:`~graybox.telemetry.layout` (asset ids, partitions), ``reading``,
``policy`` (:class:`GridPolicy`), ``validation``, ``gridding``, ``window``
(:class:`TelemetryWindow`), ``writing`` and ``rows`` (the arrays passed between them);
importing a user's exports: ``exports`` (reading CSV/Parquet into UTC rows), ``merging``
(into the day partitions, idempotently) and ``changes`` (the days an import changed).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Collection, Sequence

from graybox.telemetry.gridding import grid_rows, to_grid
from graybox.telemetry.layout import (ASSET_ID_PATTERN, list_assets, list_dates,
                                      validate_asset_id)
from graybox.telemetry.policy import GridPolicy, duration_seconds
from graybox.telemetry.reading import newest_timestamp, read_raw, read_rows
from graybox.exceptions import TelemetryError
from graybox.telemetry.validation import (data_rows, longest_holds, period_starts, validate,
                                         validate_rows)
from graybox.telemetry.window import TelemetryWindow
from graybox.telemetry.writing import write_telemetry

__all__ = ["ASSET_ID_PATTERN", "validate_asset_id", "GridPolicy", "TelemetryWindow",
           "list_assets", "list_dates", "read_raw", "validate", "to_grid", "read_window",
           "write_telemetry", "duration_seconds", "newest_timestamp"]


def read_window(root, asset_id: str, columns: Sequence[str], start=None, end=None,
                policy: GridPolicy = GridPolicy(), inputs: Collection[str] = (),
                holds: bool = False) -> TelemetryWindow:
    """Read, validate and grid one asset's telemetry over ``[start, end)``.

    Parameters
    ----------
    root : str or path-like
        The telemetry root.
    asset_id : str
        The asset.
    columns : sequence of str
        Channel columns (``model.required_columns``).
    start, end : timestamp-like, optional
        Half-open range; naive values are UTC.
    policy : GridPolicy, optional
        Validation limits and grid step; with ``running``, the rows of a stopped machine are
        dropped first (its ``running`` channels are read too), and a window without a
        running row is ``"no_data"`` (skipped like a night without telemetry).
    inputs : collection of str, optional
        Columns exempt from the stuck check (``model.input_columns``: commands and setpoints
        may hold a value for hours). By default every column is checked.
    holds : bool, default False
        A new baseline's window: a channel may hold one value up to 6 h
        (:meth:`GridPolicy.for_baseline`), and each channel's longest hold that the plant
        does not explain is found (``TelemetryWindow.holds``), where long enough to widen
        ``policy``'s limit for the baseline's candidates (:meth:`GridPolicy.with_holds`).

    Returns
    -------
    TelemetryWindow

    Raises
    ------
    InvalidAssetIdError
        If ``asset_id`` is invalid (before any path is built).
    TelemetryError
        See :func:`read_raw`, :func:`validate` and :func:`to_grid`.
    """
    validate_asset_id(asset_id)
    extra = [name for name, _, _ in policy.running if name not in columns]
    logged = read_rows(root, asset_id, [*columns, *extra], start=start, end=end)
    rows = data_rows(logged, asset_id, policy, channels=logged.channels[:len(logged.channels)
                                                                           - len(extra)])
    if len(rows) == 0:
        raise TelemetryError(asset_id, "no_data", f"the machine did not run in [{start}, {end}) "
                             f"(grid running)")
    rows, dt_ns = validate_rows(rows, asset_id, policy.for_baseline() if holds else policy,
                                inputs, logged.ts)
    window = grid_rows(rows, asset_id, dt_ns, period_starts(rows, policy, dt_ns))
    if holds:
        window = replace(window, holds=longest_holds(rows, policy, dt_ns, inputs))
    return window
