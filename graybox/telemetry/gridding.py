"""Putting validated raw rows on the uniform time grid the tiers assume."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from graybox.exceptions import TelemetryError
from graybox.telemetry.layout import NS_PER_SECOND
from graybox.telemetry.policy import GridPolicy
from graybox.telemetry.rows import Rows
from graybox.telemetry.validation import (check_duration, check_order, fill_missing,
                                          grid_points, logged_interval_ns, operating_points,
                                          period_starts, data_rows)
from graybox.telemetry.window import TelemetryWindow


def to_grid(raw: pd.DataFrame, asset_id: str, policy: GridPolicy = GridPolicy()) -> TelemetryWindow:
    """Put validated raw rows on a uniform time grid.

    The grid is ``t0 + k * dt`` for the first raw timestamp ``t0`` and ``k = 0, 1, ...`` up
    to the last raw timestamp (no extrapolation). Values at grid points are interpolated
    linearly in time between the raw samples around them, which also absorbs timestamp
    jitter. Grid points with no raw sample within ``dt / 2`` lie in a (short) gap and are
    counted in ``filled_samples``. Each operating period (rows between times longer than
    ``max_gap`` without one: pauses, outages) gets its own grid, from its first row to its
    last.

    Parameters
    ----------
    raw : pandas.DataFrame
        Rows as returned by :func:`read_raw`, which should have passed :func:`validate`.
    asset_id : str
        The asset.
    policy : GridPolicy, optional
        ``sample_interval`` (``None``: median raw step), ``min_duration``, and with
        ``max_gap``, are used.

    Returns
    -------
    TelemetryWindow

    Raises
    ------
    TelemetryError
        ``"no_data"`` if ``raw`` is empty; ``"duplicate_timestamp"``/``"backward_timestamp"``
        if timestamps are not increasing; ``"too_few_samples"`` if the interval cannot be
        inferred (one row) or the grid covers less than ``policy.min_duration``.
    """
    logged = Rows.from_frame(raw)
    rows = data_rows(logged, asset_id, policy)
    if len(rows) == 0:
        raise TelemetryError(asset_id, "no_data", "no telemetry rows to put on a grid")
    check_order(rows, asset_id)  # interpolation needs increasing times
    if len(rows) < 2 and policy.sample_interval is None:
        raise TelemetryError(asset_id, "too_few_samples",
                             "1 sample(s) in the window: two are needed to infer the "
                             "sample interval")
    dt_ns = logged_interval_ns(rows.ts, logged.ts, policy)
    rows = fill_missing(rows, asset_id, policy, dt_ns)
    check_duration(asset_id, operating_points(rows, dt_ns, policy), dt_ns, policy)
    return grid_rows(rows, asset_id, dt_ns, period_starts(rows, policy, dt_ns))


def grid_rows(rows: Rows, asset_id: str, dt_ns: int, starts: np.ndarray | None = None
              ) -> TelemetryWindow:
    """:func:`to_grid` on validated, increasing :class:`Rows` at a step of ``dt_ns``; each
    operating period (rows from ``starts[i]`` on; default: one period) on its own grid;
    ``rows.unread`` and ``rows.resent`` are the window's."""
    window = _grid_rows(rows, asset_id, dt_ns, starts)
    if rows.unread or rows.resent:
        return replace(window, unread=rows.unread, resent=rows.resent)
    return window


def _grid_rows(rows: Rows, asset_id: str, dt_ns: int, starts: np.ndarray | None
               ) -> TelemetryWindow:
    if starts is None or len(starts) < 2:
        return _grid_period(rows, asset_id, dt_ns)
    bounds = np.append(starts, len(rows))
    parts = [_grid_period(rows.slice(a, b), asset_id, dt_ns)
             for a, b in zip(bounds[:-1], bounds[1:])]
    sizes = [part.n_samples for part in parts]
    span = None
    if rows.file_index is not None:
        span = np.concatenate([part._file_span for part in parts])
    return TelemetryWindow(
        asset_id=asset_id, frame=pd.concat([part.frame for part in parts]),
        sample_interval=dt_ns / NS_PER_SECOND,
        filled_samples=sum(part.filled_samples for part in parts),
        files=rows.files if rows.file_index is not None else (),
        _filled_mask=np.concatenate([part._filled_mask for part in parts]), _file_span=span,
        _period_starts=np.cumsum([0] + sizes[:-1]))


def _grid_period(rows: Rows, asset_id: str, dt_ns: int) -> TelemetryWindow:
    """Rows without a pause on one grid (file spans index ``rows.files``)."""
    ts = rows.ts
    n = len(ts)
    n_grid = grid_points(ts, dt_ns)
    rel = ts - ts[0]
    grid = np.arange(n_grid, dtype=np.int64) * dt_ns
    if n == n_grid and np.array_equal(rel, grid):
        # every row on the grid already (the common, unjittered case): nothing to compute
        out = rows.values
        filled = np.zeros(n_grid, dtype=bool) if rows.missing is None else rows.missing.copy()
        left = right = np.arange(n_grid)
    else:
        # left[g]: last row at or before grid point g (rel >= 0, so row 0 is always there);
        # counting rows per grid point is O(n), unlike a binary search per point
        first_point = -(-rel // dt_ns)  # ceil: the first grid point at or after each row
        per_point = np.bincount(first_point, minlength=n_grid + 1)[:n_grid]
        left = np.cumsum(per_point) - 1
        at_left = rel.take(left)
        right = np.minimum(left + (at_left != grid), n - 1)
        at_right = rel.take(right)
        filled = 2 * np.minimum(at_right - grid, grid - at_left) > dt_ns  # none within dt/2
        if rows.missing is not None:   # or a value interpolated at a row it comes from
            filled |= rows.missing[left] | rows.missing[right]
        # linear interpolation between rows left and right (np.interp would search again)
        width = at_right - at_left
        width[width == 0] = 1  # a grid point on a row: weight 0
        weight = (grid - at_left) / width
        out = np.empty((len(rows.channels), n_grid), dtype=np.float64)
        for j, v in enumerate(rows.values):
            before = v.take(left)
            out[j] = before + weight * (v.take(right) - before)

    if rows.file_index is None:
        files, span = (), None
    elif len(rows.files) == 1:
        files, span = rows.files, np.zeros((n_grid, 2), dtype=np.intp)
    else:
        files, span = rows.files, np.stack([rows.file_index[left], rows.file_index[right]],
                                           axis=1)
    index = pd.DatetimeIndex((ts[0] + grid).view("M8[ns]"), name="timestamp").tz_localize("UTC")
    # out is (channels, points), so its transpose is the frame's block as is: no copy
    frame = pd.DataFrame(out.T, index=index, columns=list(rows.channels), copy=False)
    return TelemetryWindow(asset_id=asset_id, frame=frame, sample_interval=dt_ns / NS_PER_SECOND,
                           filled_samples=int(filled.sum()), files=files,
                           _filled_mask=filled, _file_span=span)
