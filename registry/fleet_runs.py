"""The fleet-level run of a night: one MLflow run per night in ``fleet-health/fleet``.

It holds what the nightly run publishes about the whole fleet (the heat map, the view it
was drawn from and the night's asset statuses) as artifacts. Publishing a night again
reuses its run and replaces the artifacts: a rerun never adds a second run for the same
night. The run is found by its ``fleet_health.night`` tag (``YYYY-MM-DD``).
"""
from __future__ import annotations

import json
import pathlib
import tempfile
from typing import Mapping

from mlflow.entities import RunStatus
from mlflow.exceptions import MlflowException

from registry import naming
from registry.backend import Backend, is_already_exists, is_not_found
from registry.boundary import raises_registry_errors

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
