"""A recorded fit written in one transaction of MLflow's SQLAlchemy stores.

Through ``MlflowClient``, a new candidate costs five store calls (``create_run``,
``log_batch``, ``set_terminated``, ``create_model_version``, the alias), each its own session,
look-ups and commit: about 127 SQL statements per asset-night. On an SQLAlchemy store
(embedded SQLite, PostgreSQL) :class:`SqlWriter` writes the same rows with MLflow's own ORM
classes in one session instead: the run (finished), its tags, params, metrics and latest
metrics, then the model version with its tags, the registered model's update time and the
alias. What MLflow reads back (``get_run``, ``search_runs``, ``get_model_version_by_alias``,
the UI) is what the client path writes (tests/registry/test_sql_writes.py compares them).

One transaction is also safer than five: the run, its version and the alias appear together or
not at all, so no half-recorded fit is ever left behind by this path.

Any other store (an ``mlflow server``) has no writer (:meth:`SqlWriter.of` is None) and keeps
the client path. Like :mod:`registry.store.model_headers`, this reads MLflow's store
internals; a layout it does not know gives no writer either.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Mapping

#: attempts when another writer took the same version number first (MLflow's own retry count)
VERSION_ATTEMPTS = 3


def now_ms() -> int:
    return int(time.time() * 1000)


@dataclass(frozen=True)
class RunRows:
    """A complete, finished run to write.

    Attributes
    ----------
    run_id, experiment_id, name, artifact_uri : str
    start_time : int
        Milliseconds since the epoch.
    tags, params : mapping of str to str
        Everything but ``mlflow.runName``, which is added as ``create_run`` adds it.
    metrics : mapping of str to float
        Logged at step 0 with the transaction's time.
    """

    run_id: str
    experiment_id: str
    name: str
    artifact_uri: str
    start_time: int
    tags: Mapping[str, str] = field(default_factory=dict)
    params: Mapping[str, str] = field(default_factory=dict)
    metrics: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class VersionRows:
    """A model version to create with the run, and the alias it takes (None: no alias)."""

    name: str
    source: str
    tags: Mapping[str, str] = field(default_factory=dict)
    description: str | None = None
    alias: str | None = None


class SqlWriter:
    """Writes and finds recorded fits directly in an MLflow SQLAlchemy store (see the module
    docstring). Build it with :meth:`of`."""

    def __init__(self, tracking_store, registry_store):
        from mlflow.store.model_registry.dbmodels import models as registry_models
        from mlflow.store.tracking.dbmodels import models as tracking_models

        self.tracking, self.registry = tracking_store, registry_store
        self.t, self.r = tracking_models, registry_models

    @classmethod
    def of(cls, client) -> "SqlWriter | None":
        """The writer of an ``MlflowClient``'s stores, or None when they are not MLflow's
        SQLAlchemy stores of one database (an ``mlflow server``, another layout)."""
        try:
            from mlflow.store.model_registry.sqlalchemy_store import \
                SqlAlchemyStore as RegistryStore
            from mlflow.store.tracking.sqlalchemy_store import SqlAlchemyStore as TrackingStore

            tracking = client._tracking_client.store
            registry = client._get_registry_client().store
        except (ImportError, AttributeError):
            return None
        if not (isinstance(tracking, TrackingStore) and isinstance(registry, RegistryStore)):
            return None
        if tracking.engine.url != registry.engine.url:
            return None
        if not (all(hasattr(tracking, n) for n in ("sanitize_metric_value", "get_experiment",
                                                   "_check_experiment_is_active",
                                                   "_get_eager_run_query_options"))
                and all(hasattr(registry, n) for n in ("_get_registered_model",
                                                       "_with_workspace_field",
                                                       "_get_workspace_clauses"))):
            return None
        return cls(tracking, registry)

    # -- reads ---------------------------------------------------------------------------------
    def artifact_location(self, experiment_id: str) -> str:
        """The artifact location of an active experiment (MLflow's error if it is absent or
        deleted, as ``create_run`` raises)."""
        experiment = self.tracking.get_experiment(experiment_id)
        self.tracking._check_experiment_is_active(experiment)
        return experiment.artifact_location

    def runs_with_tag(self, experiment_id: str, key: str, value: str, limit: int = 50) -> list:
        """The runs of an experiment (deleted ones included) whose tag ``key`` is ``value``,
        as MLflow's ``Run`` entities (what ``search_runs`` returns for that filter)."""
        SqlRun, SqlTag = self.t.SqlRun, self.t.SqlTag
        with self.tracking.ManagedSessionMaker() as session:
            rows = (session.query(SqlRun)
                    .options(*self.tracking._get_eager_run_query_options())
                    .join(SqlTag, SqlTag.run_uuid == SqlRun.run_uuid)
                    .filter(SqlRun.experiment_id == int(experiment_id), SqlTag.key == key,
                            SqlTag.value == value)
                    .order_by(SqlRun.start_time.desc(), SqlRun.run_uuid)
                    .limit(limit).all())
            return [row.to_mlflow_entity() for row in rows]

    # -- the write -----------------------------------------------------------------------------
    def write(self, run: RunRows, version: VersionRows | None = None) -> int | None:
        """Write the run and (given) its model version and alias, in one transaction.

        Returns
        -------
        int or None
            The new version's number.

        Raises
        ------
        mlflow.exceptions.MlflowException
            MLflow's validation errors, ``RESOURCE_DOES_NOT_EXIST`` when the registered model
            is absent, or the store's error; nothing is written then.
        """
        import sqlalchemy

        from mlflow.entities import Metric, Param, RunTag
        from mlflow.utils.validation import _validate_batch_log_data

        tags = {**run.tags, "mlflow.runName": run.name}
        metrics, params, tag_items = _validate_batch_log_data(
            [Metric(k, v, 0, 0) for k, v in run.metrics.items()],
            [Param(k, v) for k, v in run.params.items()],
            [RunTag(k, v) for k, v in tags.items()])
        if version is not None:
            from mlflow.utils.validation import _validate_model_version_tag

            for key, value in version.tags.items():
                _validate_model_version_tag(key, value)
        last = None
        for _ in range(VERSION_ATTEMPTS):
            try:
                return self._write(run, metrics, params, tag_items, version)
            except sqlalchemy.exc.IntegrityError as error:   # a version number taken meanwhile
                last = error
        from mlflow.exceptions import MlflowException

        raise MlflowException(f"could not create a version of {version.name if version else '?'}"
                              f" after {VERSION_ATTEMPTS} attempts: {last}")

    def _write(self, run: RunRows, metrics, params, tags, version: VersionRows | None):
        from sqlalchemy import func, insert

        t, r = self.t, self.r
        now = now_ms()
        with self.tracking.ManagedSessionMaker(read_only=False) as session:
            session.add(t.SqlRun(
                name=run.name, artifact_uri=run.artifact_uri, run_uuid=run.run_id,
                experiment_id=int(run.experiment_id), source_type="UNKNOWN", source_name="",
                entry_point_name="", user_id="unknown", status="FINISHED",
                start_time=run.start_time, end_time=now, deleted_time=None, source_version="",
                lifecycle_stage="active"))
            session.flush()
            rows = []
            for metric in metrics:
                is_nan, value = self.tracking.sanitize_metric_value(metric.value)
                rows.append({"run_uuid": run.run_id, "key": metric.key, "value": value,
                             "timestamp": now, "step": 0, "is_nan": is_nan})
            if rows:
                session.execute(insert(t.SqlMetric), rows)
                session.execute(insert(t.SqlLatestMetric), rows)
            if params:
                session.execute(insert(t.SqlParam), [{"run_uuid": run.run_id, "key": p.key,
                                                       "value": p.value} for p in params])
            session.execute(insert(t.SqlTag), [{"run_uuid": run.run_id, "key": tag.key,
                                                 "value": tag.value} for tag in tags])
            if version is None:
                return None
            model = self.registry._get_registered_model(session, version.name)
            model.last_updated_time = now
            newest = (session.query(func.max(r.SqlModelVersion.version))
                      .filter(r.SqlModelVersion.name == version.name,
                              *self.registry._get_workspace_clauses(r.SqlModelVersion))
                      .scalar())
            number = (newest or 0) + 1
            sql_version = self.registry._with_workspace_field(r.SqlModelVersion(
                name=version.name, version=number, creation_time=now, last_updated_time=now,
                source=version.source, storage_location=version.source, run_id=run.run_id,
                run_link=None, description=version.description))
            sql_version.model_version_tags = [
                self.registry._with_workspace_field(r.SqlModelVersionTag(
                    name=version.name, version=number, key=key, value=value))
                for key, value in version.tags.items()]
            session.add_all([model, sql_version])
            session.flush()
            if version.alias is not None:
                session.merge(r.SqlRegisteredModelAlias(
                    workspace=sql_version.workspace, name=version.name, alias=version.alias,
                    version=number))
            return number


__all__ = ["RunRows", "VersionRows", "SqlWriter", "now_ms"]
