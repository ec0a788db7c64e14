"""Recording fits, idempotently: one run and one registered model version per submission.

A recorded fit is

* a **run** in the vehicle class's experiment, tagged with asset id, window start/end, role,
  data hash, code version and the idempotence key; its params hold the frozen structure, its
  metrics the noise moments, fit errors and (when known) zeta, epsilon and their ratio per
  tier and channel; its artifacts the signature bundle (``signature/``: JSON, safetensors,
  manifest), ``drift.json`` for a candidate and PNG plots (``plots/``) (see
  :mod:`registry.write.runs`);
* its **pyfunc model** (loader module :mod:`registry.pyfunc`, no pickle): a logged model for
  a baseline, the run's own ``model/`` artifacts for a candidate
  (:mod:`registry.write.model_files`);
* a **model version** of the asset's registered model, which takes the ``candidate`` alias.

Recording is idempotent on ``(asset_id, window_start, window_end, role, data_hash)``: the key
is a tag on the run and on the version. One filtered run search finds it (the version is
looked for only when a complete run with the key exists), and a second recording returns
the first one. A recording interrupted half-way is finished or replaced on the next attempt:
an incomplete run (no ``fleet_health.complete`` tag) is deleted and logged again; a complete
run without a version gets its version; a version without the alias gets the alias.

On an SQLAlchemy store (embedded SQLite, PostgreSQL) a new candidate is written at once
(:mod:`registry.write.at_once`): its artifacts, then one transaction for the run (already
complete), its version and the alias, so an interruption leaves either nothing or the whole
record; the key's runs are found by one direct query. Behind an ``mlflow server`` the
client calls below do it, and the repairs above apply.

A **reanalysis** records only the run, tagged ``fleet_health.reanalysis``: no model, no
version, no alias move. Its key also names the baseline version it was compared with.

:func:`record_fits` records many submissions with the look-ups shared: the experiments and
registered models of the whole batch are found once, and an asset with several windows
moves its ``candidate`` alias once.
"""
from __future__ import annotations

import logging
from typing import Sequence

from mlflow.entities import ViewType
from mlflow.exceptions import MlflowException

from registry.store import naming
from registry.store.backend import Backend, is_not_found
from registry.store.retry import call_with_retry
from registry.records import FitRecord
from registry.write.at_once import record_at_once, write_restoring_model
from registry.write.model_files import PyfuncTemplate, model_source
from registry.write.run_content import describe, version_tags
from registry.write.runs import log_run
from registry.write.submission import FitSubmission, ResolvedFit

logger = logging.getLogger(__name__)


def record_fit(backend: Backend, submission: FitSubmission,
               template: PyfuncTemplate | None = None) -> FitRecord:
    """Record one fit (see :meth:`registry.Registry.record_fit`)."""
    return record_fits(backend, [submission], template)[0]


def record_fits(backend: Backend, submissions: Sequence[FitSubmission],
                template: PyfuncTemplate | None = None) -> list[FitRecord]:
    """Record several fits, in order; the same records as one :func:`record_fit` each.

    Every submission is resolved (and so checked) before anything is written. If recording
    one fails, the error is raised: those recorded before it stay recorded, and recording
    the batch again finds them.
    """
    fits = [s.resolve() for s in submissions]
    template = template if template is not None else PyfuncTemplate()
    backend.ensure_registered_models({f.asset_id: f.submission.vehicle_class for f in fits})
    out: list[FitRecord | None] = [None] * len(fits)
    by_asset: dict[str, list[int]] = {}
    for i, fit in enumerate(fits):
        by_asset.setdefault(fit.asset_id, []).append(i)
    for asset_id, indices in by_asset.items():
        with backend.store.asset_lock(asset_id):
            alias = _Alias(backend, asset_id)
            for i in indices:
                out[i] = _record(backend, fits[i], template, alias)
            alias.flush()
    return out


class _Alias:
    """The ``candidate`` alias of one asset, moved once for consecutive new versions."""

    def __init__(self, backend: Backend, asset_id: str):
        self.backend, self.asset_id, self.pending = backend, asset_id, None
        self.name = naming.model_name(asset_id)

    def new_version(self, version: int) -> None:
        self.pending = version

    def moved(self, version: int) -> None:
        """The alias was moved to ``version`` (the newest) with its version's transaction."""
        self.pending = None

    def flush(self) -> None:
        if self.pending is not None:
            self.backend.set_alias(self.asset_id, naming.CANDIDATE, self.pending)
            self.pending = None

    def repair(self, version: int) -> None:
        """A recording interrupted after its version was created but before the alias moved."""
        self.flush()
        model = self.backend.require_registered_model(self.asset_id)
        current = (model.aliases or {}).get(naming.CANDIDATE)
        if current is None or int(current) < version:
            mv = self.backend.client.get_model_version(self.name, str(version))
            if (mv.tags or {}).get(naming.TAG_REJECTED) != "true":
                self.backend.set_alias(self.asset_id, naming.CANDIDATE, version)


def _record(backend: Backend, fit: ResolvedFit, template: PyfuncTemplate,
            alias: _Alias) -> FitRecord:
    s = fit.submission
    experiment_id = backend.experiment_id(s.vehicle_class, create=True)
    run, seen_complete = _find_runs(backend, experiment_id, fit.key)
    alarm = None if s.drift is None else s.drift.alarmed
    if s.reanalysis and not (run is None and backend.sql_writer() is not None):
        created = run is None
        run_id = _log(backend, experiment_id, fit, s.baseline_version, template).run_id \
            if created else run.info.run_id
        return FitRecord(s.asset_id, s.vehicle_class, s.role, None, run_id, "", fit.key,
                         fit.start, fit.end, fit.data_hash, created=created, alarm=alarm)
    name = naming.model_name(s.asset_id)
    if seen_complete:
        existing = _find_version(backend, name, fit.key)
        if existing is not None:
            alias.repair(int(existing.version))
            tags = existing.tags or {}
            recorded = tags.get(naming.TAG_ALARM)
            return FitRecord(s.asset_id, s.vehicle_class, s.role, int(existing.version),
                             existing.run_id, tags.get(naming.TAG_MODEL_ID, ""), fit.key,
                             fit.start, fit.end, fit.data_hash, created=False,
                             alarm=None if recorded is None else recorded == "true")
    baseline_version = baseline_version_of(backend, s)
    writer = backend.sql_writer()
    if run is None and writer is not None and s.role == naming.CANDIDATE:
        run_id, version, _ = write_restoring_model(
            backend, s, experiment_id, lambda: record_at_once(
                backend, writer, experiment_id, fit, baseline_version, template))
        if version is not None:
            alias.moved(version)
        return created_record(fit, run_id, version)
    if run is None:
        logged = _log(backend, experiment_id, fit, baseline_version, template)
        run_id, model_id, manifest_sha, source = (logged.run_id, logged.model_id,
                                                  logged.manifest_sha256, logged.source)
    else:
        run_id = run.info.run_id
        model_id = run.data.tags.get(naming.TAG_MODEL_ID, "")
        manifest_sha = run.data.tags[naming.TAG_MANIFEST_SHA256]
        recorded = run.data.tags.get(naming.TAG_BASELINE_VERSION)
        baseline_version = int(recorded) if recorded else baseline_version
        source = model_source(backend, run, model_id)
        logger.info("asset %s: completing the registration of run %s", s.asset_id, run_id)
    version = _create_version(backend, fit, name, source, run_id, model_id,
                              version_tags(fit, run_id, model_id, manifest_sha, baseline_version),
                              describe(fit, baseline_version))
    alias.new_version(version)
    return created_record(fit, run_id, version, model_id)


def baseline_version_of(backend: Backend, submission: FitSubmission) -> int | None:
    """The baseline version a fit is recorded against: the submission's, or for a candidate
    with a drift and none given, the asset's current ``baseline`` alias."""
    if submission.drift is None or submission.baseline_version is not None:
        return submission.baseline_version
    model = backend.registered_model(submission.asset_id)
    return (model.aliases or {}).get(naming.BASELINE) if model else None


def created_record(fit: ResolvedFit, run_id: str, version: int | None,
                   model_id: str = "") -> FitRecord:
    """The record of a fit recorded now (``created=True``)."""
    s = fit.submission
    return FitRecord(s.asset_id, s.vehicle_class, s.role, version, run_id, model_id, fit.key,
                     fit.start, fit.end, fit.data_hash, created=True,
                     alarm=None if s.drift is None else s.drift.alarmed)


def _log(backend: Backend, experiment_id: str, fit: ResolvedFit, baseline_version,
         template: PyfuncTemplate):
    try:
        return log_run(backend, experiment_id, fit, baseline_version, template)
    except MlflowException:
        # perhaps the experiment was deleted since this backend saw it: look it up next time
        backend.forget(fit.asset_id, fit.submission.vehicle_class)
        raise


def _find_runs(backend: Backend, experiment_id: str, key: str):
    """The active complete run of ``key`` (or None), and whether any complete run of it,
    deleted ones included, exists; incomplete active runs are deleted on the way."""
    writer = backend.sql_writer()
    if writer is not None:
        runs = call_with_retry(writer.runs_with_tag, experiment_id, naming.TAG_FIT_KEY, key,
                               policy=backend.retry, what="find the fit's runs")
    else:
        runs = backend.client.search_runs([experiment_id],
                                          f"tags.`{naming.TAG_FIT_KEY}` = {naming.quote(key)}",
                                          run_view_type=ViewType.ALL, max_results=50)
    complete, seen_complete = None, False
    for run in runs:
        done = run.data.tags.get(naming.TAG_COMPLETE) == "true"
        active = run.info.lifecycle_stage == "active"
        seen_complete = seen_complete or done
        if done and active and complete is None:
            complete = run
        elif not done and active:
            logger.warning("deleting incomplete run %s of an interrupted recording",
                           run.info.run_id)
            backend.client.delete_run(run.info.run_id)
    return complete, seen_complete


def _find_version(backend: Backend, name: str, key: str):
    versions = backend.client.search_model_versions(
        f"name = {naming.quote(name)} and tags.`{naming.TAG_FIT_KEY}` = {naming.quote(key)}",
        max_results=10)
    return min(versions, key=lambda v: int(v.version)) if versions else None


def _create_version(backend: Backend, fit: ResolvedFit, name: str, source: str, run_id: str,
                    model_id: str, tags: dict[str, str], description: str) -> int:
    def create():
        return backend.client.create_model_version(
            name, source=source, run_id=run_id, model_id=model_id or None, tags=tags,
            description=description)

    try:
        version = create()
    except Exception as error:
        if not is_not_found(error):
            raise
        # the registered model was deleted since this backend saw it
        s = fit.submission
        backend.forget(s.asset_id)
        backend.ensure_registered_model(s.asset_id, s.vehicle_class,
                                        backend.experiment_id(s.vehicle_class, create=True))
        version = create()
    return int(version.version)
