"""A new candidate recorded at once: its artifacts, then one transaction for the run, its
version and the ``candidate`` alias (:class:`registry.store.sql_writes.SqlWriter`).

The records are those of the client path (:func:`registry.write.runs.log_run` then
``create_model_version`` and the alias), with the same tags, params, metrics, artifacts and
version. The run id is chosen here, so the artifacts are written straight into the run's
artifact directory when it is a local one (no scratch copy) before the transaction.

Crash safety: until the transaction commits nothing of the fit is in the store, and a
recording interrupted before it leaves only an artifact directory no run points at (removed
when the transaction fails in this process and the run is then surely absent); the next
attempt writes a new run. After it, the
fit is complete with its version and alias, and a second recording finds it by its key.
"""
from __future__ import annotations

import pathlib
import shutil
import tempfile
import uuid
from dataclasses import dataclass

from mlflow.exceptions import MlflowException

from registry.store import naming
from registry.store.backend import Backend, is_not_found
from registry.store.retry import call_with_retry
from registry.store.sql_writes import RunRows, SqlWriter, VersionRows, now_ms
from registry.write.model_files import MODEL_DIR, PyfuncTemplate
from registry.write.run_content import (describe, fit_metrics, run_tags, structure_params,
                                        version_tags)
from registry.write.runs import write_artifacts
from registry.write.submission import ResolvedFit

ARTIFACTS_FOLDER = "artifacts"      # MLflow's: <experiment location>/<run id>/artifacts


@dataclass(frozen=True)
class PreparedFit:
    """A new candidate whose artifacts are written and whose rows are ready for the
    transaction (:func:`prepare`).

    Attributes
    ----------
    fit : ResolvedFit
    run : RunRows
    version : VersionRows or None
        None for a reanalysis.
    manifest_sha : str
    local : pathlib.Path or None
        The run's own directory (holding ``artifacts/``) when the artifact store is local.
    """

    fit: ResolvedFit
    run: RunRows
    version: VersionRows | None
    manifest_sha: str
    local: pathlib.Path | None


def prepare(backend: Backend, writer: SqlWriter, experiment_id: str, fit: ResolvedFit,
            baseline_version: int | None, template: PyfuncTemplate) -> PreparedFit:
    """Choose the run id, write the fit's artifacts and build its rows (nothing in the
    store yet: :meth:`SqlWriter.write` or :meth:`SqlWriter.write_many` writes them, and
    :func:`discard` removes the artifacts if that fails)."""
    from mlflow.utils.uri import append_to_uri_path

    s = fit.submission
    run_id = uuid.uuid4().hex
    started = now_ms()
    location = call_with_retry(writer.artifact_location, experiment_id, policy=backend.retry,
                               what="read the experiment")
    artifact_uri = append_to_uri_path(location, run_id, ARTIFACTS_FOLDER)
    local = _local_root(backend, artifact_uri)
    if local is not None:
        local.mkdir(parents=True)
        manifest_sha = _write_here(backend, fit, baseline_version, template, local, run_id)
    else:
        with tempfile.TemporaryDirectory(prefix="fleet-health-") as scratch:
            root = pathlib.Path(scratch) / ARTIFACTS_FOLDER
            manifest_sha = write_artifacts(backend, fit, baseline_version, template, root,
                                           run_id)
            backend.log_artifacts(artifact_uri, str(root))
    tags = dict(run_tags(fit, baseline_version))
    tags[naming.TAG_MANIFEST_SHA256] = manifest_sha
    tags[naming.TAG_COMPLETE] = "true"
    run = RunRows(run_id, experiment_id, fit.run_name, artifact_uri, started, tags,
                  structure_params(s.signature),
                  fit_metrics(s.signature, s.calibration, s.drift))
    version = None if s.reanalysis else VersionRows(
        naming.model_name(s.asset_id), f"{artifact_uri.rstrip('/')}/{MODEL_DIR}",
        version_tags(fit, run_id, "", manifest_sha, baseline_version),
        describe(fit, baseline_version), alias=naming.CANDIDATE)
    return PreparedFit(fit, run, version, manifest_sha,
                       None if local is None else local.parent)


def discard(writer: SqlWriter, prepared: PreparedFit) -> None:
    """Remove a prepared fit's artifacts after its transaction failed, when its run is
    surely absent from the store."""
    if prepared.local is not None and _surely_absent(writer, prepared.run.run_id):
        shutil.rmtree(prepared.local, ignore_errors=True)


def record_at_once(backend: Backend, writer: SqlWriter, experiment_id: str, fit: ResolvedFit,
                   baseline_version: int | None, template: PyfuncTemplate
                   ) -> tuple[str, int | None, str]:
    """Record a new candidate (or reanalysis) fit; returns its run id, its version (None for
    a reanalysis) and its manifest digest.

    Raises
    ------
    mlflow.exceptions.MlflowException
        From the store; ``RESOURCE_DOES_NOT_EXIST`` when the registered model is gone.
    """
    prepared = prepare(backend, writer, experiment_id, fit, baseline_version, template)
    try:
        number = call_with_retry(writer.write, prepared.run, prepared.version,
                                 policy=backend.retry, what="record the fit")
    except BaseException:
        discard(writer, prepared)
        raise
    return prepared.run.run_id, number, prepared.manifest_sha


def write_restoring_model(backend: Backend, submission, experiment_id: str, write):
    """``write()``, and once more after re-creating the asset's registered model when the
    store says it is gone (deleted since this backend saw it); after another store error the
    backend looks the asset's experiment up again next time (perhaps it was deleted)."""
    try:
        return write()
    except MlflowException as error:
        if not is_not_found(error):
            backend.forget(submission.asset_id, submission.vehicle_class)
            raise
        backend.forget(submission.asset_id)
        backend.ensure_registered_model(submission.asset_id, submission.vehicle_class,
                                        experiment_id)
        return write()


def _surely_absent(writer: SqlWriter, run_id: str) -> bool:
    """Whether the run is known not to be in the store (a commit whose answer was lost may
    have written it: then its artifacts stay)."""
    try:
        return not writer.run_exists(run_id)
    except Exception:  # noqa: BLE001 - unknown: keep the artifacts
        return False


def _local_root(backend: Backend, artifact_uri: str) -> pathlib.Path | None:
    """The run's artifact directory when the artifact store is local, else None."""
    from mlflow.utils.file_utils import local_file_uri_to_path

    local = backend.store.local_artifact_uri(artifact_uri)
    return pathlib.Path(local_file_uri_to_path(local)) if local.startswith("file:") else None


def _write_here(backend: Backend, fit: ResolvedFit, baseline_version, template, root, run_id):
    try:
        return write_artifacts(backend, fit, baseline_version, template, root, run_id)
    except BaseException:
        shutil.rmtree(root.parent, ignore_errors=True)
        raise


__all__ = ["PreparedFit", "prepare", "discard", "record_at_once"]
