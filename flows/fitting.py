"""Telemetry windows in, signatures out: the reading and batched fitting the flows share.

All fits of a batch of assets go to :func:`graybox.estimator.fit_signatures` (candidates)
or :func:`graybox.estimator.fit_baselines` (baselines) together, so that their networks
train in batched computations. Requests are grouped by method settings, since one call
fits with one :class:`~graybox.estimator.GrayBoxSettings` (a candidate always uses its
baseline's own settings).
"""
from __future__ import annotations

import dataclasses
import json
import logging
from typing import Hashable, Sequence

import pandas as pd

logger = logging.getLogger(__name__)


@dataclasses.dataclass
class ReadResult:
    """Windows read for one asset, in time order, and what stopped the reading."""

    windows: list[tuple[pd.Timestamp, pd.Timestamp, object]]  # (start, end, TelemetryWindow)
    empty: list[tuple[pd.Timestamp, pd.Timestamp]]            # no rows at all (asset idle)
    error: BaseException | None = None
    error_start: pd.Timestamp | None = None


def baseline_model(signature):
    """The white box a baseline was fitted with (its candidates must use the same)."""
    from graybox.models import load_model

    spec = signature.model
    return load_model(spec["spec"], spec.get("parameters"), spec.get("columns"))


def read_windows(root, asset_id: str, columns: Sequence[str], grid,
                 windows: Sequence[tuple[pd.Timestamp, pd.Timestamp]],
                 stop_at_error: bool = True) -> ReadResult:
    """Read, validate and grid each window of one asset.

    A window without any row (kind ``no_data``) is listed in ``empty`` and skipped. Any
    other :class:`graybox.exceptions.TelemetryError` stops the reading (``stop_at_error``)
    and is returned with the window it happened in; the windows before it are kept.
    """
    from graybox.exceptions import TelemetryError
    from graybox.telemetry import read_window

    out = ReadResult([], [])
    for start, end in windows:
        try:
            tw = read_window(root, asset_id, columns, start=start, end=end, policy=grid)
        except TelemetryError as error:
            if error.kind == "no_data":
                out.empty.append((start, end))
                continue
            out.error, out.error_start = error, start
            if stop_at_error:
                break
            continue
        out.windows.append((start, end, tw))
    return out


def grid_for(grid, signature):
    """The grid policy with the baseline's sample interval (candidates share its grid)."""
    return dataclasses.replace(grid, sample_interval=signature.sample_interval)


def fit_candidates(items: Sequence[tuple[Hashable, object]], chunk_size: int = 32) -> dict:
    """Fit candidate requests together (each with its own baseline's settings).

    Parameters
    ----------
    items : sequence of (key, FitRequest)
        Each request has a ``baseline``.

    Returns
    -------
    dict
        key -> Signature or GrayBoxError.
    """
    from graybox.estimator import fit_signatures

    # each candidate is fitted with its own baseline's settings (graybox groups them)
    results = fit_signatures([request for _, request in items], chunk_size=chunk_size)
    return {key: result for (key, _), result in zip(items, results)}


def fit_baseline_requests(items: Sequence[tuple[Hashable, object, object]],
                          false_alarm_rate: float, chunk_size: int = 32) -> dict:
    """Fit baselines (with calibration) in batches grouped by settings.

    Parameters
    ----------
    items : sequence of (key, FitRequest, GrayBoxSettings)

    Returns
    -------
    dict
        key -> (Signature, Calibration) or GrayBoxError.
    """
    from graybox.estimator import fit_baselines

    groups: dict[str, list] = {}
    for key, request, settings in items:
        groups.setdefault(json.dumps(settings.to_dict(), sort_keys=True, default=str),
                          []).append((key, request, settings))
    out = {}
    for members in groups.values():
        settings = members[0][2]
        results = fit_baselines([r for _, r, _ in members], settings, false_alarm_rate,
                                chunk_size=chunk_size)
        for (key, _, _), result in zip(members, results):
            out[key] = result
    return out


def max_ratio(drift) -> float | None:
    ratios = [e.ratio for e in drift.entries if e.ratio is not None]
    return max(ratios) if ratios else None
