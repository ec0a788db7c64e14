"""Rows a logger held: a historian that repeats its last good row while the link is down.

A SCADA historian or a data logger that misses a reading writes the last row again at the
next timestamp: every channel, inputs included, equal to the row before. Such a row is not a
measurement, and read as one it freezes every channel at once (a stuck sensor on each) and
flattens the plant's motion through the outage. Each is dropped, so that the hold reads as
the missing rows it is: a short one is bridged by interpolation (``max_gap``), a longer one
separates two operating periods, as a pause does for an intermittent asset
(:func:`graybox.telemetry.validation.period_starts`). A single sensor that freezes while the
others move is untouched (its rows are not whole repeats) and stays a ``"stuck_channel"``.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from graybox.telemetry.rows import Rows


def held_rows(rows: Rows) -> np.ndarray:
    """Per row, True where every channel equals the previous row's at a later timestamp,
    two of them channels that move, at readings other than 0.

    A channel moves when it changes in at least half of the steps between rows that are not
    whole repeats. Where one moving channel is all that repeats, the rest holding as they do
    (a setpoint, a stopped pump's zero), the repeat is that channel's, and the stuck check
    judges it; two or more independent sensors freezing on the same rows are the logger's.
    Sensors at exactly 0 are a machine at rest, not a held reading: a stopped machine whose
    every sensor reads 0 stays the stuck check's (its ``running`` channel makes it a pause).
    A row with a missing value (NaN) is never held, nor one at the previous row's timestamp
    (a duplicate, which validation reports).
    """
    held = np.zeros(len(rows), dtype=bool)
    if len(rows) < 3:
        return held
    values = rows.values
    same = values[:, 1:] == values[:, :-1]
    repeat = same.all(axis=0) & (rows.ts[1:] > rows.ts[:-1])
    others = ~repeat
    if not repeat.any() or not others.any():
        return held
    moving = (~same[:, others]).mean(axis=1) >= 0.5
    if moving.sum() < 2:
        return held
    readings = (values[moving, 1:] != 0.0).sum(axis=0)  # a sensor at exactly 0 is at rest
    held[1:] = repeat & (readings >= 2)
    return held


def drop_held_rows(rows: Rows) -> Rows:
    """The rows without the held ones (:func:`held_rows`), each row after a hold marked in
    ``Rows.after_hold``; ``rows`` itself when none is held."""
    held = held_rows(rows)
    if not held.any():
        return rows
    kept_at = np.flatnonzero(~held)
    after_hold = np.zeros(len(kept_at), dtype=bool)
    after_hold[1:] = np.diff(kept_at) > 1
    return replace(rows.take(kept_at), after_hold=after_hold)
