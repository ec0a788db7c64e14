"""The nightly record read back: an asset's zeta history and the recorded alerts.

Both come from tag-filtered run searches (complete runs only, reanalyses left out, one run
per asset and window: the latest recorded). The history reads the runs' per-entry metrics
(one search, no download); the alerts are made from each alarmed run's ``drift.json`` by
:func:`graybox.alert.alerts_from_drift`, as the nightly run made them from the drift
itself, with the run's diagnosis (``diagnosis.json``, when its tag ``fleet_health.diagnosis``
says it has one), so both return the same :class:`graybox.alert.Alert` records.
"""
from __future__ import annotations

import json
import pathlib
import tempfile
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np
import pandas as pd
from mlflow.exceptions import MlflowException

from graybox.drift import Drift
from graybox.exceptions import ArtifactError
from graybox.tiers import tier_order
from registry.store import naming
from graybox.alert import NIGHTLY, Alert, alerts_from_drift
from graybox.severity import SeverityScale
from graybox.alert_diagnosis import entries_from_document, failure_entry
from registry.write.artifacts import DIAGNOSIS_FILE, DRIFT_FILE
from registry.store.backend import Backend, is_not_found
from registry.write.run_content import drift_from_document, entry_metric, parse_entry_metric
from registry.store.retry import call_with_retry

VERSION_QUERY_RUNS = 50         # run ids per model-version search (``run_id IN (...)``)
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
    ordered = latest_per_window(runs)
    return ordered if last is None else ordered[-last:]


def latest_per_window(runs: Iterable, tags_of: Callable[[Any], Mapping[str, str]] = None,
                      start_of: Callable[[Any], int] = None) -> list:
    """The last recorded of ``runs`` per (asset, window), reanalyses left out, by window end
    then asset (``tags_of``, ``start_of``: a run's tags and start time, by default an MLflow
    run's)."""
    tags_of = tags_of or (lambda run: run.data.tags)
    start_of = start_of or (lambda run: run.info.start_time)
    latest: dict[tuple, Any] = {}
    for run in runs:
        tags = tags_of(run)
        if tags.get(naming.TAG_REANALYSIS) == "true":
            continue  # ad-hoc reanalyses are not part of the nightly record
        key = (tags.get(naming.TAG_ASSET_ID), tags.get(naming.TAG_WINDOW_START),
               tags.get(naming.TAG_WINDOW_END))
        if key not in latest or start_of(run) > start_of(latest[key]):
            latest[key] = run
    return sorted(latest.values(), key=lambda r: (tags_of(r).get(naming.TAG_WINDOW_END, ""),
                                                  tags_of(r).get(naming.TAG_ASSET_ID, "")))


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
            entry = parse_entry_metric(metric)
            if entry is None or entry[0] != "zeta":
                continue
            _, channel, tier = entry
            epsilon = metrics.get(entry_metric("epsilon", channel, tier), np.nan)
            rows.append({"window_start": tags.get(naming.TAG_WINDOW_START),
                         "window_end": tags.get(naming.TAG_WINDOW_END), "channel": channel,
                         "tier": tier, "zeta": zeta, "epsilon": epsilon,
                         "ratio": metrics.get(entry_metric("ratio", channel, tier), np.nan),
                         "exceeded": bool(np.isfinite(epsilon) and zeta > epsilon),
                         "run_id": run.info.run_id,
                         "baseline_version": tags.get(naming.TAG_BASELINE_VERSION)})
    frame = pd.DataFrame(rows, columns=list(HISTORY_COLUMNS))
    if len(frame):
        frame = frame.assign(_t=frame["tier"].map(tier_order)).sort_values(
            ["window_end", "channel", "_t"]).drop(columns="_t").reset_index(drop=True)
    return frame


def recorded_windows(backend: Backend, asset_id: str, last: int) -> list[tuple[str, str]]:
    """``(window_start, window_end)`` of the asset's candidates among its ``last`` newest
    versions (ISO strings as tagged): the windows the nightly record holds. One search of
    model versions by their tags, newest first, without the runs' metrics (a run search
    loads every metric of every run: 5-7 against 26-37 ms per asset on a store of 1,000
    assets); on an SQLAlchemy store two queries of the versions' tag rows
    (:func:`recorded_windows_of`, 0.5 against 5 ms)."""
    if backend.sql_writer() is not None:
        return recorded_windows_of(backend, [asset_id], last)[asset_id]
    model = naming.model_name(asset_id)
    clause = (f"name = {naming.quote(model)} and "
              f"tags.`{naming.TAG_ROLE}` = '{naming.CANDIDATE}'")
    versions = backend.client.search_model_versions(clause, max_results=max(1, last),
                                                    order_by=["version_number DESC"])
    return [(v.tags.get(naming.TAG_WINDOW_START), v.tags.get(naming.TAG_WINDOW_END))
            for v in versions]


def baseline_window_end(backend: Backend, asset_id: str) -> str | None:
    """``window_end`` of the version holding the asset's ``baseline`` alias (the ISO string
    as tagged; None without a baseline): one query of its tag's row on an SQLAlchemy store,
    without loading or verifying the version (:func:`registry.review.reference` does both)."""
    if backend.sql_writer() is not None:
        return baseline_window_ends(backend, [asset_id])[asset_id]
    version = backend.version_by_alias(asset_id, naming.BASELINE)
    return None if version is None else (version.tags or {}).get(naming.TAG_WINDOW_END)


def baseline_window_ends(backend: Backend, asset_ids: Sequence[str]) -> dict[str, str | None]:
    """:func:`baseline_window_end` of each asset: on an SQLAlchemy store one query (per 500
    assets), elsewhere one read each."""
    writer = backend.sql_writer()
    if writer is None:
        return {asset: baseline_window_end(backend, asset) for asset in asset_ids}
    names = {naming.model_name(asset): asset for asset in asset_ids}
    values = call_with_retry(writer.alias_version_tag_of, list(names), naming.BASELINE,
                             naming.TAG_WINDOW_END, policy=backend.retry,
                             what="read the baselines' windows")
    return {asset: values.get(name) for name, asset in names.items()}


def recorded_windows_of(backend: Backend, asset_ids: Sequence[str], last: int
                        ) -> dict[str, list[tuple[str, str]]]:
    """:func:`recorded_windows` of each asset: on an SQLAlchemy store two queries (per 500
    assets), the versions ranked in the database; elsewhere one search each."""
    writer = backend.sql_writer()
    if writer is None:
        return {asset: recorded_windows(backend, asset, last) for asset in asset_ids}
    names = {naming.model_name(asset): asset for asset in asset_ids}
    found = call_with_retry(writer.version_tag_values_of, list(names), naming.TAG_ROLE,
                            naming.CANDIDATE, (naming.TAG_WINDOW_START, naming.TAG_WINDOW_END),
                            last, policy=backend.retry, what="read the recorded windows")
    return {asset: [(t.get(naming.TAG_WINDOW_START), t.get(naming.TAG_WINDOW_END))
                    for t in found[name]] for name, asset in names.items()}


def alerts(backend: Backend, since=None, *, scale: SeverityScale = SeverityScale()
           ) -> list[Alert]:
    """The recorded nightly alerts, oldest window first.

    Parameters
    ----------
    since : timestamp-like, optional
        Only windows ending at or after this instant (naive is UTC).
    scale : SeverityScale
        Grades the alerts' severity (``[alerts]`` of fleet.toml).

    Returns
    -------
    list of Alert
        Per window (by window end, then asset), its alerts largest ratio first: the records
        :func:`graybox.alert.alerts_from_drift` made of the run's drift when it was
        recorded (source ``nightly``; reanalyses are left out).

    Raises
    ------
    graybox.exceptions.ArtifactError
        If an alarmed run's ``drift.json`` is missing or unreadable.
    """
    experiment_ids = backend.experiment_ids()
    if not experiment_ids:
        return []
    since = None if since is None else pd.Timestamp(naming.iso_utc(since))
    runs = [run for run in _asset_runs(backend, experiment_ids,
                                       [f"tags.`{naming.TAG_ALARM}` = 'true'"])
            if since is None or pd.Timestamp(run.data.tags[naming.TAG_WINDOW_END]) >= since]
    versions = _versions_of(backend, [run.info.run_id for run in runs])
    out: list[Alert] = []
    with tempfile.TemporaryDirectory(prefix="fleet-health-alerts-") as scratch:
        for run in runs:
            tags = run.data.tags
            baseline = tags.get(naming.TAG_BASELINE_VERSION)
            out += alerts_from_drift(
                _recorded_drift(backend, run, pathlib.Path(scratch)),
                diagnosis=_recorded_diagnosis(backend, run, pathlib.Path(scratch)),
                asset_id=tags.get(naming.TAG_ASSET_ID),
                vehicle_class=tags.get(naming.TAG_VEHICLE_CLASS),
                window_start=tags.get(naming.TAG_WINDOW_START),
                window_end=tags.get(naming.TAG_WINDOW_END),
                version=versions.get(run.info.run_id),
                baseline_version=int(baseline) if baseline else None, run_id=run.info.run_id,
                scale=scale, source=NIGHTLY)
    return out


def _versions_of(backend: Backend, run_ids: list[str]) -> dict[str, int]:
    """The model version of each run (one search per :data:`VERSION_QUERY_RUNS` runs)."""
    out: dict[str, int] = {}
    for first in range(0, len(run_ids), VERSION_QUERY_RUNS):
        chunk = run_ids[first:first + VERSION_QUERY_RUNS]
        clause = "run_id IN (" + ", ".join(naming.quote(r) for r in chunk) + ")"
        for mv in backend.paged(backend.client.search_model_versions, clause):
            version = int(mv.version)
            out[mv.run_id] = min(version, out.get(mv.run_id, version))
    return out


def _download(backend: Backend, run, name: str, scratch: pathlib.Path) -> dict:
    """The run's JSON artifact ``name``, parsed."""
    repository = backend.artifact_repository(run.info.artifact_uri)
    destination = scratch / run.info.run_id
    destination.mkdir(parents=True, exist_ok=True)
    local = call_with_retry(repository.download_artifacts, name, str(destination),
                            policy=backend.retry, what=f"download {name}")
    return json.loads(pathlib.Path(local).read_text(encoding="utf-8"))


def _recorded_diagnosis(backend: Backend, run, scratch: pathlib.Path) -> tuple[dict, ...]:
    """The alerts' ``diagnosis`` of the run, from its ``diagnosis.json`` when its tag says it
    has one (``()`` otherwise: recorded before diagnoses). A missing or unreadable file is
    said in a ``failed`` entry, not raised: the alerts stay readable (other errors, e.g. an
    unreachable server, are raised as they are)."""
    if naming.TAG_DIAGNOSIS not in run.data.tags:
        return ()
    try:
        return entries_from_document(_download(backend, run, DIAGNOSIS_FILE, scratch))
    except (FileNotFoundError, ValueError, KeyError, TypeError, MlflowException) as error:
        if isinstance(error, MlflowException) and not is_not_found(error):
            raise
        return (failure_entry(f"{DIAGNOSIS_FILE} of run {run.info.run_id} missing or "
                              f"unreadable: {type(error).__name__}: {error}"),)


def _recorded_drift(backend: Backend, run, scratch: pathlib.Path) -> Drift:
    """The run's drift, from its ``drift.json`` (other errors, e.g. an unreachable server,
    are raised as they are)."""
    run_id = run.info.run_id
    try:
        return drift_from_document(_download(backend, run, DRIFT_FILE, scratch))
    except (FileNotFoundError, ValueError, KeyError, TypeError, MlflowException) as error:
        if isinstance(error, MlflowException) and not is_not_found(error):
            raise
        raise ArtifactError(f"run {run_id}: {DRIFT_FILE} missing or unreadable: "
                            f"{type(error).__name__}: {error}") from None
