"""The nightly record read back: an asset's zeta history and the recorded alerts.

Both come from tag-filtered run searches (complete runs only, reanalyses left out, one run
per asset and window: the latest recorded).
"""
from __future__ import annotations

from typing import Any, Iterable

import numpy as np
import pandas as pd

from graybox.signature import TIERS
from registry import naming
from registry.backend import Backend

HISTORY_COLUMNS = ("window_start", "window_end", "channel", "tier", "zeta", "epsilon", "ratio",
                   "exceeded", "run_id", "baseline_version")


def _asset_runs(backend: Backend, experiment_ids: list[str], filters: Iterable[str],
                last: int | None = None) -> list:
    """Complete runs matching ``filters``, one per (asset, window) (the last recorded), by
    window end; only the ``last`` latest windows when given (one page, newest first)."""
    clause = " and ".join([f"tags.`{naming.TAG_COMPLETE}` = 'true'", *filters])
    if last is None:
        runs = list(backend.paged(backend.client.search_runs, experiment_ids, clause))
    else:
        runs = list(backend.client.search_runs(
            experiment_ids, clause, max_results=2 * last,
            order_by=[f"tags.`{naming.TAG_WINDOW_END}` DESC", "attributes.start_time DESC"]))
    latest: dict[tuple, Any] = {}
    for run in runs:
        tags = run.data.tags
        if tags.get(naming.TAG_REANALYSIS) == "true":
            continue  # ad-hoc reanalyses are not part of the nightly record
        key = (tags.get(naming.TAG_ASSET_ID), tags.get(naming.TAG_WINDOW_START),
               tags.get(naming.TAG_WINDOW_END))
        if key not in latest or run.info.start_time > latest[key].info.start_time:
            latest[key] = run
    ordered = sorted(latest.values(), key=lambda r: (r.data.tags.get(naming.TAG_WINDOW_END, ""),
                                                     r.data.tags.get(naming.TAG_ASSET_ID, "")))
    return ordered if last is None else ordered[-last:]


def zeta_history(backend: Backend, asset_id: str, last: int | None = None) -> pd.DataFrame:
    """The asset's candidate zetas, one row per (window, channel, tier), oldest first.

    Parameters
    ----------
    last : int, optional
        Only the ``last`` most recent windows (one bounded query; the trend plot uses this).
    """
    model = backend.registered_model(asset_id)
    experiment_id = None if model is None else (model.tags or {}).get(naming.TAG_EXPERIMENT_ID)
    if experiment_id is None:
        return pd.DataFrame(columns=list(HISTORY_COLUMNS))
    runs = _asset_runs(backend, [experiment_id], [
        f"tags.`{naming.TAG_ASSET_ID}` = {naming.quote(asset_id)}",
        f"tags.`{naming.TAG_ROLE}` = '{naming.CANDIDATE}'"], last=last)
    rows = []
    for run in runs:
        metrics, tags = run.data.metrics, run.data.tags
        for metric, zeta in metrics.items():
            if not metric.startswith("zeta."):
                continue
            channel, tier = metric[len("zeta."):].rsplit(".", 1)
            epsilon = metrics.get(f"epsilon.{channel}.{tier}", np.nan)
            rows.append({"window_start": tags.get(naming.TAG_WINDOW_START),
                         "window_end": tags.get(naming.TAG_WINDOW_END), "channel": channel,
                         "tier": tier, "zeta": zeta, "epsilon": epsilon,
                         "ratio": metrics.get(f"ratio.{channel}.{tier}", np.nan),
                         "exceeded": bool(np.isfinite(epsilon) and zeta > epsilon),
                         "run_id": run.info.run_id,
                         "baseline_version": tags.get(naming.TAG_BASELINE_VERSION)})
    frame = pd.DataFrame(rows, columns=list(HISTORY_COLUMNS))
    order = {tier: i for i, tier in enumerate(TIERS)}
    if len(frame):
        frame = frame.assign(_t=frame["tier"].map(order)).sort_values(
            ["window_end", "channel", "_t"]).drop(columns="_t").reset_index(drop=True)
    return frame


def alerts(backend: Backend, since=None) -> list[dict]:
    """Recorded alarms (candidate runs with any zeta above epsilon), oldest window first."""
    experiment_ids = backend.experiment_ids()
    if not experiment_ids:
        return []
    since = None if since is None else naming.iso_utc(since)
    out = []
    for run in _asset_runs(backend, experiment_ids, [f"tags.`{naming.TAG_ALARM}` = 'true'"]):
        tags, metrics = run.data.tags, run.data.metrics
        if since is not None and pd.Timestamp(tags[naming.TAG_WINDOW_END]) < pd.Timestamp(since):
            continue
        exceeded = []
        for metric, zeta in metrics.items():
            if not metric.startswith("zeta."):
                continue
            channel, tier = metric[len("zeta."):].rsplit(".", 1)
            epsilon = metrics.get(f"epsilon.{channel}.{tier}")
            if epsilon is not None and zeta > epsilon:
                exceeded.append({"channel": channel, "tier": tier, "zeta": zeta,
                                 "epsilon": epsilon,
                                 "ratio": metrics.get(f"ratio.{channel}.{tier}")})
        exceeded.sort(key=lambda e: -(e["ratio"] or 0))
        baseline = tags.get(naming.TAG_BASELINE_VERSION)
        out.append({"asset_id": tags.get(naming.TAG_ASSET_ID),
                    "vehicle_class": tags.get(naming.TAG_VEHICLE_CLASS),
                    "window_start": tags.get(naming.TAG_WINDOW_START),
                    "window_end": tags.get(naming.TAG_WINDOW_END),
                    "baseline_version": int(baseline) if baseline else None,
                    "run_id": run.info.run_id, "max_ratio": metrics.get("max_ratio"),
                    "exceeded": exceeded})
    return out
