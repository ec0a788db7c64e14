"""UTC normalisation of timestamps: naive values are taken as UTC, aware ones converted."""
from __future__ import annotations

import pandas as pd


def utc(value):
    """``value`` in UTC; naive values are taken as UTC, aware ones are converted.

    Parameters
    ----------
    value : timestamp-like or pandas.DatetimeIndex
        Anything :class:`pandas.Timestamp` accepts (an ISO string, a datetime, a Timestamp,
        nanoseconds since the epoch), or a DatetimeIndex.

    Returns
    -------
    pandas.Timestamp or pandas.DatetimeIndex
        A DatetimeIndex for a DatetimeIndex (its NaT entries stay NaT), else a Timestamp.

    Raises
    ------
    ValueError
        When ``value`` is not a timestamp or is NaT (``pd.Timestamp`` may raise TypeError for
        objects it cannot read at all).
    """
    if isinstance(value, pd.DatetimeIndex):
        stamp = value
    else:
        stamp = pd.Timestamp(value)
        if stamp is pd.NaT:
            raise ValueError(f"not a timestamp: {value!r}")
    return stamp.tz_localize("UTC") if stamp.tz is None else stamp.tz_convert("UTC")
