"""Rows a logger sent twice: a gateway that reconnects sends its last batch again.

A logger or a gateway that loses its link and reconnects often sends again the rows it is not
sure were received: the same timestamps with the same readings, after rows it already sent
(times going back) or in the next file (a day's file and a re-sent tail). Such a row carries
nothing new, and read as data it is an error at its row (``"duplicate_timestamp"``,
``"backward_timestamp"``) that costs the asset its night. Each row equal in its timestamp and
every channel to a row read before it is dropped and counted (:attr:`Rows.resent`); the
window says how many. A row at a timestamp already read with other readings is not a
re-sent row: which reading is true is unknown, and validation still reports it at its row.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from graybox.telemetry.rows import Rows


def resent_rows(rows: Rows) -> np.ndarray:
    """Per row, True where an earlier row has the same timestamp and the same value in every
    channel (a missing value, NaN, equal to a missing one)."""
    resent = np.zeros(len(rows), dtype=bool)
    if len(rows) < 2 or np.all(rows.ts[1:] > rows.ts[:-1]):
        return resent            # times only increase: no row can repeat one before it
    # one record of bytes per row (its timestamp and readings); its first occurrence is kept
    readings = rows.values.T.copy()
    # -0.0 and 0.0 are the same reading; NaNs compare by their bits, which a reading's
    # missing value shares
    readings[readings == 0.0] = 0.0
    table = np.ascontiguousarray(np.column_stack([rows.ts.view(np.float64), readings]))
    records = table.view(np.dtype((np.void, table.dtype.itemsize * table.shape[1]))).ravel()
    _, first = np.unique(records, return_index=True)
    resent[:] = True
    resent[first] = False
    return resent


def drop_resent_rows(rows: Rows) -> Rows:
    """The rows without the re-sent ones (:func:`resent_rows`), their number added to
    ``Rows.resent``; ``rows`` itself when none was re-sent."""
    resent = resent_rows(rows)
    if not resent.any():
        return rows
    return replace(rows.take(~resent), resent=rows.resent + int(resent.sum()))
