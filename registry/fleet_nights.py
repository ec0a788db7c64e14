"""The fleet's nights: the worst ratio per asset and night, read from the candidates, and
the fleet-level run of each night, published by the nightly run and read back.

Worst ratios
    A night is the UTC date of a candidate window's last instant (the date its window starts
    on, unless ``[nightly] candidate_nights`` > 1 spans it over earlier nights: its night is the
    last one, :func:`night_of_window`); its ratio is the run's
    ``max_ratio`` metric (the largest zeta/epsilon over the tiers and channels of the window;
    the largest over the windows when a night has several). Runs are read with one (paged)
    ``search_runs`` over every vehicle class's experiment per date a window may end on
    (``window_end LIKE 'YYYY-MM-DD%'``: MLflow compares tags only with ``=`` and ``LIKE``;
    the nights and the day after the last), so exactly the runs of those nights are read,
    never one call per asset. Only complete nightly candidates count, one per asset and window
    (the latest recorded); reanalyses are left out.

Fleet-level runs
    One MLflow run per night in ``fleet-health/fleet``. It holds what the nightly run
    publishes about the whole fleet (the heat map, the view it was drawn from and the
    night's asset statuses) as artifacts. Publishing a night again reuses its run and
    replaces the artifacts: a rerun never adds a second run for the same night. The run is
    found by its ``fleet_health.night`` tag (``YYYY-MM-DD``).
"""
from __future__ import annotations

import json
import math
import pathlib
import re
import tempfile
from dataclasses import dataclass
from typing import Mapping, Sequence

import pandas as pd
from mlflow.entities import RunStatus
from mlflow.exceptions import MlflowException

from registry.read.history import _asset_runs, latest_per_window
from registry.store.retry import call_with_retry
from registry.store import naming
from registry.store.backend import Backend, is_already_exists, is_not_found
from registry.store.boundary import raises_registry_errors

_DATE = re.compile(r"\d{4}-\d{2}-\d{2}")


@dataclass(frozen=True)
class NightRatio:
    """One asset's worst ratio of one night (None: recorded without a threshold)."""

    asset_id: str
    vehicle_class: str
    night: str
    ratio: float | None


@raises_registry_errors
def night_ratios(backend: Backend, nights: Sequence[str]) -> list[NightRatio]:
    """The worst ratio per asset and night, for the nights given (``YYYY-MM-DD``).

    Returns
    -------
    list of NightRatio
        One per asset and night with at least one recorded candidate window, by asset then
        night.
    """
    wanted = set(nights)
    experiment_ids = backend.experiment_ids()
    if not wanted or not experiment_ids:
        return []
    worst: dict[tuple[str, str], NightRatio] = {}
    for day in sorted(wanted):
        if _DATE.fullmatch(day) is None:
            raise ValueError(f"a night is a date YYYY-MM-DD, not {day!r}")
    # a window of night d ends on d (a window shorter than a day) or at midnight after d
    ends = wanted | {(pd.Timestamp(d) + pd.Timedelta(days=1)).strftime("%Y-%m-%d")
                     for d in wanted}
    for day in sorted(ends):
        for tags, ratio in _night_runs(backend, experiment_ids, day):
            night = night_of_window(tags[naming.TAG_WINDOW_END])
            if night not in wanted:
                continue
            ratio = None if ratio is None or not math.isfinite(ratio) else float(ratio)
            key = (tags[naming.TAG_ASSET_ID], night)
            before = worst.get(key)
            if before is None or (ratio is not None and (before.ratio is None
                                                         or ratio > before.ratio)):
                worst[key] = NightRatio(key[0], tags.get(naming.TAG_VEHICLE_CLASS, ""), night,
                                        ratio)
    return [worst[key] for key in sorted(worst)]


def _night_runs(backend: Backend, experiment_ids: list[str], day: str
                ) -> list[tuple[Mapping[str, str], float | None]]:
    """The tags and ``max_ratio`` of the complete candidates whose window ends on ``day``,
    the last recorded per asset and window (:func:`registry.read.history.latest_per_window`):
    on an SQLAlchemy store only those tags and that metric are read
    (:meth:`registry.store.sql_writes.SqlWriter.tagged_runs`), else MLflow's run search."""
    writer = backend.sql_writer()
    if writer is None:
        runs = _asset_runs(backend, experiment_ids, [
            f"tags.`{naming.TAG_ROLE}` = '{naming.CANDIDATE}'",
            f"tags.`{naming.TAG_WINDOW_END}` LIKE '{day}%'"])
        return [(run.data.tags, run.data.metrics.get("max_ratio")) for run in runs]
    runs = call_with_retry(
        writer.tagged_runs, experiment_ids,
        {naming.TAG_COMPLETE: "true", naming.TAG_ROLE: naming.CANDIDATE},
        {naming.TAG_WINDOW_END: f"{day}%"},
        (naming.TAG_ASSET_ID, naming.TAG_VEHICLE_CLASS, naming.TAG_WINDOW_START,
         naming.TAG_WINDOW_END, naming.TAG_REANALYSIS), "max_ratio",
        policy=backend.retry, what="read the night's candidates")
    return [(run.tags, run.metric) for run in latest_per_window(
        runs, lambda run: run.tags, lambda run: run.start_time)]


@raises_registry_errors
def latest_candidate_night(backend: Backend) -> str | None:
    """The night of the most recent recorded candidate window (None if there is none)."""
    experiment_ids = backend.experiment_ids()
    if not experiment_ids:
        return None
    runs = backend.client.search_runs(
        experiment_ids, f"tags.`{naming.TAG_COMPLETE}` = 'true' and "
                        f"tags.`{naming.TAG_ROLE}` = '{naming.CANDIDATE}'",
        order_by=[f"tags.`{naming.TAG_WINDOW_END}` DESC"], max_results=50)
    for run in runs:
        if run.data.tags.get(naming.TAG_REANALYSIS) != "true":
            return night_of_window(run.data.tags[naming.TAG_WINDOW_END])
    return None


@raises_registry_errors
def latest_night(backend: Backend) -> str | None:
    """The latest night with a recorded candidate window or a published fleet-level run
    (None if there is neither)."""
    known = [night for night in (latest_candidate_night(backend),
                                 max(published_nights(backend), default=None)) if night]
    return max(known, default=None)


def night_of_window(window_end) -> str:
    """The night (``YYYY-MM-DD``) of a window ending at ``window_end`` (exclusive): the date
    of its last instant, so a multi-night window counts on its last night."""
    return (pd.Timestamp(window_end) - pd.Timedelta(microseconds=1)).strftime("%Y-%m-%d")


# -- the fleet-level runs -------------------------------------------------------------------

STATUSES_FILE = "night_statuses.json"    #: the night's per-asset statuses and counts


def fleet_experiment_id(backend: Backend, create: bool = False) -> str | None:
    """Id of the ``fleet-health/fleet`` experiment (created on request, else None if absent)."""
    name = naming.FLEET_EXPERIMENT
    experiment = backend.client.get_experiment_by_name(name)
    if experiment is not None:
        return experiment.experiment_id
    if not create:
        return None
    try:
        return backend.client.create_experiment(
            name, artifact_location=backend.store.experiment_artifact_location(name),
            tags={"mlflow.note.content": "The fleet at a glance: one run per night with the "
                                         "heat map of assets x nights (fleet-health)."})
    except MlflowException as error:
        if not is_already_exists(error):
            raise
        return backend.client.get_experiment_by_name(name).experiment_id


@raises_registry_errors
def published_nights(backend: Backend) -> dict[str, str]:
    """Every published night and the id of its fleet-level run (night ``YYYY-MM-DD`` ->
    run id), one search.

    When two runs hold the same night (two reruns racing), the first created is the night's.
    """
    experiment_id = fleet_experiment_id(backend)
    if experiment_id is None:
        return {}
    first: dict[str, object] = {}
    for run in backend.paged(backend.client.search_runs, [experiment_id],
                             f"tags.`{naming.TAG_NIGHT}` LIKE '%'"):
        night = run.data.tags[naming.TAG_NIGHT]
        if night not in first or run.info.start_time < first[night].info.start_time:
            first[night] = run
    return {night: run.info.run_id for night, run in first.items()}


@raises_registry_errors
def publish_night(backend: Backend, night: str, statuses: Mapping, files: Mapping[str, bytes],
                  metrics: Mapping[str, float] | None = None) -> str:
    """Write the night's ``statuses`` (as :data:`STATUSES_FILE`, read back by
    :func:`night_statuses`) and ``files`` (name -> content) as artifacts of the night's fleet
    run; return its id.

    The night's run is created once (tagged with the night) and reused by later calls,
    whose files replace those of the same name.
    """
    files = {**files, STATUSES_FILE: json.dumps(statuses, indent=1).encode()}
    experiment_id = fleet_experiment_id(backend, create=True)
    found = backend.client.search_runs(
        [experiment_id], f"tags.`{naming.TAG_NIGHT}` = {naming.quote(night)}",
        order_by=["attributes.start_time ASC"], max_results=1)
    if found:
        run_id = found[0].info.run_id
    else:
        run = backend.client.create_run(experiment_id, run_name=f"fleet {night}",
                                        tags={naming.TAG_NIGHT: night})
        run_id = run.info.run_id
    with tempfile.TemporaryDirectory(prefix="fleet-health-night-") as scratch:
        for name, content in files.items():
            (pathlib.Path(scratch) / name).write_bytes(content)
        backend.client.log_artifacts(run_id, scratch)
    for key, value in (metrics or {}).items():
        backend.client.log_metric(run_id, key, float(value), step=0)
    backend.client.set_terminated(run_id, RunStatus.to_string(RunStatus.FINISHED))
    return run_id


@raises_registry_errors
def night_statuses(backend: Backend, run_ids: Mapping[str, str]) -> dict[str, dict]:
    """The :data:`STATUSES_FILE` document of each night's fleet run given (night -> run id,
    as :func:`published_nights`; night -> document); nights whose run has none (published by
    an older version, or half-way) are left out."""
    out = {}
    for night, run_id in run_ids.items():
        document = run_document(backend, run_id, STATUSES_FILE)
        if document is not None:
            out[night] = document
    return out


@raises_registry_errors
def run_document(backend: Backend, run_id: str, name: str) -> dict | None:
    """The JSON artifact ``name`` of a fleet-level run (None if the run has none)."""
    with tempfile.TemporaryDirectory(prefix="fleet-health-night-") as scratch:
        try:
            local = backend.client.download_artifacts(run_id, name, scratch)
        except (FileNotFoundError, OSError):
            return None
        except MlflowException as error:
            if not is_not_found(error):
                raise
            return None
        return json.loads(pathlib.Path(local).read_text(encoding="utf-8"))
