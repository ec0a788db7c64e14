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

The same class answers the nightly path's other look-ups in one query or session each, with
MLflow's entities where MLflow returns entities: a fit key's runs (:meth:`SqlWriter.runs_with_tag`),
the version holding an alias (:meth:`SqlWriter.version_by_alias`), the windows tagged on an
asset's newest candidates (:meth:`SqlWriter.version_tag_values_of`), the baseline's window
(:meth:`SqlWriter.alias_version_tag_of`), and the watermark, a registered model's tag, read
and advanced (:meth:`SqlWriter.model_tag_of`, :meth:`SqlWriter.advance_model_tag`); the reads
take many models at once (a batch's planning), one model being a list of one.

Any other store (an ``mlflow server``) has no writer (:meth:`SqlWriter.of` is None) and keeps
the client path. Like :mod:`registry.store.model_headers`, this reads MLflow's store
internals; a layout it does not know gives no writer either.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

#: attempts when another writer took the same version number first (MLflow's own retry count)
VERSION_ATTEMPTS = 3


def now_ms() -> int:
    return int(time.time() * 1000)


#: model names per ``IN (...)`` of the reads of many models (SQLite allows 32,766 bound
#: values a statement, PostgreSQL 65,535)
NAMES_PER_QUERY = 500


def _chunks(names: Sequence[str]) -> list[list[str]]:
    names = list(names)
    return [names[i:i + NAMES_PER_QUERY] for i in range(0, len(names), NAMES_PER_QUERY)]


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


@dataclass(frozen=True)
class TaggedRun:
    """What :meth:`SqlWriter.tagged_runs` reads of a run: its id, start time, the tags asked
    for (those it has) and one metric's latest value (None when it has none; NaN as MLflow
    gives it)."""

    run_id: str
    start_time: int
    tags: Mapping[str, str]
    metric: float | None


class SqlWriter:
    """Writes and finds recorded fits directly in an MLflow SQLAlchemy store (see the module
    docstring). Build it with :meth:`of`."""

    def __init__(self, tracking_store, registry_store):
        from mlflow.store.model_registry.dbmodels import models as registry_models
        from mlflow.store.tracking.dbmodels import models as tracking_models

        self.tracking, self.registry = tracking_store, registry_store
        self.t, self.r = tracking_models, registry_models
        self._locations: dict[str, str] = {}     # experiment id -> artifact location

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
                                                       "_get_active_workspace",
                                                       "_get_workspace_clauses"))):
            return None
        return cls(tracking, registry)

    # -- reads ---------------------------------------------------------------------------------
    def artifact_location(self, experiment_id: str) -> str:
        """The artifact location of an active experiment (MLflow's error if it is absent or
        deleted, as ``create_run`` raises); read once per experiment (it never changes), and
        the experiment's state checked again by :meth:`write`."""
        if experiment_id not in self._locations:
            experiment = self.tracking.get_experiment(experiment_id)
            self.tracking._check_experiment_is_active(experiment)
            self._locations[experiment_id] = experiment.artifact_location
        return self._locations[experiment_id]

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

    def runs_with_tags(self, experiment_id: str, key: str, values) -> dict[str, list]:
        """:meth:`runs_with_tag` of several values in one query: value -> its runs (newest
        first, at most 50 each; values without runs left out)."""
        values = sorted(set(values))
        if not values:
            return {}
        SqlRun, SqlTag = self.t.SqlRun, self.t.SqlTag
        out: dict[str, list] = {}
        with self.tracking.ManagedSessionMaker() as session:
            rows = (session.query(SqlRun, SqlTag.value)
                    .options(*self.tracking._get_eager_run_query_options())
                    .join(SqlTag, SqlTag.run_uuid == SqlRun.run_uuid)
                    .filter(SqlRun.experiment_id == int(experiment_id), SqlTag.key == key,
                            SqlTag.value.in_(values))
                    .order_by(SqlRun.start_time.desc(), SqlRun.run_uuid).all())
            for row, value in rows:
                found = out.setdefault(value, [])
                if len(found) < 50:
                    found.append(row.to_mlflow_entity())
        return out

    def tagged_runs(self, experiment_ids: Sequence[str], equal: Mapping[str, str],
                    like: Mapping[str, str], keys: Sequence[str], metric: str
                    ) -> list[TaggedRun]:
        """The active runs of the experiments whose tags are ``equal`` and match the ``like``
        patterns (SQL ``LIKE``), as ``search_runs`` orders them (newest start first, then by
        id), with only the tags ``keys`` and the latest value of ``metric``: a query of the
        runs and two of their rows, instead of every tag, parameter and metric of each."""
        from sqlalchemy.orm import aliased

        SqlRun, SqlTag, SqlLatest = self.t.SqlRun, self.t.SqlTag, self.t.SqlLatestMetric
        with self.tracking.ManagedSessionMaker() as session:
            query = session.query(SqlRun.run_uuid, SqlRun.start_time).filter(
                SqlRun.experiment_id.in_([int(e) for e in experiment_ids]),
                SqlRun.lifecycle_stage == "active")
            for key, value in equal.items():
                tag = aliased(SqlTag)
                query = query.join(tag, tag.run_uuid == SqlRun.run_uuid).filter(
                    tag.key == key, tag.value == value)
            for key, pattern in like.items():
                tag = aliased(SqlTag)
                query = query.join(tag, tag.run_uuid == SqlRun.run_uuid).filter(
                    tag.key == key, tag.value.like(pattern))
            found = query.order_by(SqlRun.start_time.desc(), SqlRun.run_uuid).all()
            tags: dict[str, dict[str, str]] = {run_id: {} for run_id, _ in found}
            metrics: dict[str, float] = {}
            ids = list(tags)
            for first in range(0, len(ids), 500):    # within SQLite's bound variables
                chunk = ids[first:first + 500]
                for run_id, key, value in session.query(SqlTag.run_uuid, SqlTag.key,
                                                        SqlTag.value).filter(
                        SqlTag.run_uuid.in_(chunk), SqlTag.key.in_(list(keys))):
                    tags[run_id][key] = value
                for run_id, value, is_nan in session.query(
                        SqlLatest.run_uuid, SqlLatest.value, SqlLatest.is_nan).filter(
                        SqlLatest.run_uuid.in_(chunk), SqlLatest.key == metric):
                    metrics[run_id] = float("nan") if is_nan else value
        return [TaggedRun(run_id, start, tags[run_id], metrics.get(run_id))
                for run_id, start in found]

    def run_exists(self, run_id: str) -> bool:
        """Whether a run with this id is in the store (deleted or not)."""
        runs = self.t.SqlRun.__table__
        from sqlalchemy import select

        with self.tracking.ManagedSessionMaker() as session:
            return session.connection().execute(
                select(runs.c.run_uuid).where(runs.c.run_uuid == run_id)).first() is not None

    def version_by_alias(self, name: str, alias: str):
        """The version holding ``alias`` as MLflow's ``ModelVersion`` entity (what
        ``get_model_version_by_alias`` returns, its aliases included), or None when the
        model, the alias or the version is absent: three queries in one session."""
        from sqlalchemy.orm import selectinload

        SqlModelVersion, SqlAlias = self.r.SqlModelVersion, self.r.SqlRegisteredModelAlias
        with self.registry.ManagedSessionMaker() as session:
            row = (session.query(SqlModelVersion)
                   .options(selectinload(SqlModelVersion.model_version_tags))
                   .join(SqlAlias, (SqlAlias.name == SqlModelVersion.name)
                         & (SqlAlias.version == SqlModelVersion.version)
                         & (SqlAlias.workspace == SqlModelVersion.workspace))
                   .filter(SqlAlias.name == name, SqlAlias.alias == alias,
                           SqlModelVersion.current_stage != "Deleted_Internal",
                           *self.registry._get_workspace_clauses(SqlModelVersion))
                   .one_or_none())
            if row is None:
                return None
            version = row.to_mlflow_entity()
            version.aliases = [a for (a,) in session.query(SqlAlias.alias).filter(
                SqlAlias.name == name, SqlAlias.version == row.version,
                SqlAlias.workspace == row.workspace)]
            return version

    # -- reads of many models at once (a night's planning of a batch; one model: a list of one)
    def model_tag_of(self, names: Sequence[str], key: str) -> dict[str, str]:
        """The value of each registered model's tag ``key`` (a model or tag that is absent is
        not in the result): the tags' rows alone, whatever the models' history, one query per
        :data:`NAMES_PER_QUERY` names."""
        T = self.r.SqlRegisteredModelTag
        found: dict[str, str] = {}
        with self.registry.ManagedSessionMaker() as session:
            for chunk in _chunks(names):
                found.update(session.query(T.name, T.value).filter(
                    T.name.in_(chunk), T.key == key, *self.registry._get_workspace_clauses(T)))
        return found

    def alias_version_tag_of(self, names: Sequence[str], alias: str, key: str
                             ) -> dict[str, str]:
        """Per model, the tag ``key`` of the version holding ``alias`` (absent from the result
        when the model, the alias, the version or the tag is): the tag's row, without the
        version's entity (:meth:`version_by_alias` reads it whole: three queries), one query
        per :data:`NAMES_PER_QUERY` names."""
        SqlModelVersion, SqlAlias = self.r.SqlModelVersion, self.r.SqlRegisteredModelAlias
        SqlTag = self.r.SqlModelVersionTag
        found: dict[str, str] = {}
        with self.registry.ManagedSessionMaker() as session:
            for chunk in _chunks(names):
                found.update(
                    session.query(SqlTag.name, SqlTag.value)
                    .join(SqlAlias, (SqlAlias.name == SqlTag.name)
                          & (SqlAlias.version == SqlTag.version)
                          & (SqlAlias.workspace == SqlTag.workspace))
                    .join(SqlModelVersion, (SqlModelVersion.name == SqlTag.name)
                          & (SqlModelVersion.version == SqlTag.version)
                          & (SqlModelVersion.workspace == SqlTag.workspace))
                    .filter(SqlAlias.name.in_(chunk), SqlAlias.alias == alias, SqlTag.key == key,
                            SqlModelVersion.current_stage != "Deleted_Internal",
                            *self.registry._get_workspace_clauses(SqlModelVersion)))
        return found

    def version_tag_values_of(self, names: Sequence[str], key: str, value: str,
                              keys: Sequence[str], last: int) -> dict[str, list[dict[str, str]]]:
        """Per model, the tags ``keys`` of its ``last`` newest versions (by version number,
        deleted ones left out) whose tag ``key`` is ``value``, newest first (a model without
        such versions: an empty list): what ``search_model_versions`` with that name and tag,
        ordered by ``version_number DESC``, returns of them. The versions are ranked in the
        database (``row_number`` over each model's versions), then their tags read: two
        queries of the tags' rows per :data:`NAMES_PER_QUERY` names instead of every
        version's entity."""
        from sqlalchemy import func

        SqlModelVersion, SqlTag = self.r.SqlModelVersion, self.r.SqlModelVersionTag
        found: dict[str, dict[int, dict[str, str]]] = {name: {} for name in names}
        with self.registry.ManagedSessionMaker() as session:
            for chunk in _chunks(names):
                ranked = (
                    session.query(SqlModelVersion.name.label("name"),
                                  SqlModelVersion.version.label("version"),
                                  SqlModelVersion.workspace.label("workspace"),
                                  func.row_number().over(
                                      partition_by=SqlModelVersion.name,
                                      order_by=SqlModelVersion.version.desc()).label("rank"))
                    .join(SqlTag, (SqlTag.name == SqlModelVersion.name)
                          & (SqlTag.version == SqlModelVersion.version)
                          & (SqlTag.workspace == SqlModelVersion.workspace))
                    .filter(SqlModelVersion.name.in_(chunk), SqlTag.key == key,
                            SqlTag.value == value,
                            SqlModelVersion.current_stage != "Deleted_Internal",
                            *self.registry._get_workspace_clauses(SqlModelVersion))
                    .subquery())
                chosen = session.query(ranked.c.name, ranked.c.version).filter(
                    ranked.c.rank <= max(1, last))
                for name, number in chosen:
                    found[name][number] = {}
                for name, number, tag, text in (
                        session.query(ranked.c.name, ranked.c.version, SqlTag.key, SqlTag.value)
                        .join(SqlTag, (SqlTag.name == ranked.c.name)
                              & (SqlTag.version == ranked.c.version)
                              & (SqlTag.workspace == ranked.c.workspace))
                        .filter(ranked.c.rank <= max(1, last), SqlTag.key.in_(list(keys)))):
                    found[name][number][tag] = text
        return {name: [versions[n] for n in sorted(versions, reverse=True)]
                for name, versions in found.items()}

    def advance_model_tag(self, name: str, key: str, value: str,
                          newer: Callable[[str | None], bool]) -> str | None:
        """Set a registered model's tag to ``value`` when ``newer(current value)``, in one
        transaction; returns the value in place.

        Raises
        ------
        mlflow.exceptions.MlflowException
            ``RESOURCE_DOES_NOT_EXIST`` when the registered model is absent.
        """
        from mlflow.utils.validation import _validate_registered_model_tag

        _validate_registered_model_tag(key, value)
        SqlRegisteredModelTag = self.r.SqlRegisteredModelTag
        with self.registry.ManagedSessionMaker(read_only=False) as session:
            model = self.registry._get_registered_model(session, name)
            row = (session.query(SqlRegisteredModelTag)
                   .filter(SqlRegisteredModelTag.name == name, SqlRegisteredModelTag.key == key,
                           SqlRegisteredModelTag.workspace == model.workspace)
                   .one_or_none())
            current = None if row is None else row.value
            if not newer(current):
                return current
            if row is None:
                session.add(SqlRegisteredModelTag(workspace=model.workspace, name=name, key=key,
                                                  value=value))
            else:
                row.value = value
            return value

    def advance_model_tags(self, key: str, values: Mapping[str, str],
                           newer: Callable[[str | None, str], bool]) -> dict[str, str | None]:
        """:meth:`advance_model_tag` of several registered models in one transaction: each
        model's tag ``key`` is set to its value in ``values`` (model name -> value) when
        ``newer(current value, value)``.

        Returns
        -------
        dict
            Model name -> the value in place; None for a model that is absent (nothing is
            written for it).
        """
        from sqlalchemy import bindparam, insert, select, update

        from mlflow.utils.validation import _validate_registered_model_tag

        for value in values.values():
            _validate_registered_model_tag(key, value)
        names = sorted(values)
        models = self.r.SqlRegisteredModel.__table__
        tags = self.r.SqlRegisteredModelTag.__table__
        with self.registry.ManagedSessionMaker(read_only=False) as session:
            connection = session.connection()
            workspace = self.registry._get_active_workspace()
            present = {n for (n,) in connection.execute(select(models.c.name).where(
                models.c.name.in_(names), models.c.workspace == workspace))}
            current = dict(connection.execute(select(tags.c.name, tags.c.value).where(
                tags.c.name.in_(names), tags.c.key == key, tags.c.workspace == workspace)).all())
            out: dict[str, str | None] = {}
            inserts, updates = [], []
            for name in names:
                if name not in present:
                    out[name] = None
                elif newer(current.get(name), values[name]):
                    row = {"w": workspace, "n": name, "k": key, "v": values[name]}
                    (updates if name in current else inserts).append(row)
                    out[name] = values[name]
                else:
                    out[name] = current[name]
            if inserts:
                connection.execute(insert(tags), [{"workspace": r["w"], "name": r["n"],
                                                   "key": r["k"], "value": r["v"]}
                                                  for r in inserts])
            if updates:
                connection.execute(update(tags).where(
                    tags.c.workspace == bindparam("w"), tags.c.name == bindparam("n"),
                    tags.c.key == bindparam("k")).values(value=bindparam("v")), updates)
            return out

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
        return self.write_many([(run, version)])[0]

    def write_many(self, items: Sequence[tuple[RunRows, VersionRows | None]]
                   ) -> list[int | None]:
        """Write several runs (each with its version and alias, given) in one transaction,
        in order: all of them or none.

        The rows are those :meth:`write` writes for each; a model's versions are numbered in
        the order given, and an alias given by several of them ends on the last. The rows of
        the whole group go in a dozen statements, whatever its size.

        Returns
        -------
        list of int or None
            Each new version's number (None where no version was given).

        Raises
        ------
        mlflow.exceptions.MlflowException
            As :meth:`write`, for any of them: nothing of the group is written then.
        """
        import sqlalchemy

        from mlflow.entities import Metric, Param, RunTag
        from mlflow.utils.validation import (_validate_batch_log_data,
                                             _validate_model_version_tag)

        checked = []
        for run, version in items:
            tags = {**run.tags, "mlflow.runName": run.name}
            metrics, params, tag_items = _validate_batch_log_data(
                [Metric(k, v, 0, 0) for k, v in run.metrics.items()],
                [Param(k, v) for k, v in run.params.items()],
                [RunTag(k, v) for k, v in tags.items()])
            if version is not None:
                for key, value in version.tags.items():
                    _validate_model_version_tag(key, value)
            checked.append((run, metrics, params, tag_items, version))
        if not checked:
            return []
        last = None
        for _ in range(VERSION_ATTEMPTS):
            try:
                return self._write(checked)
            except sqlalchemy.exc.IntegrityError as error:   # a version number taken meanwhile
                last = error
        from mlflow.exceptions import MlflowException

        names = sorted({v.name for *_, v in checked if v is not None}) or ["?"]
        raise MlflowException(f"could not create a version of {', '.join(names)} after "
                              f"{VERSION_ATTEMPTS} attempts: {last}")

    def _write(self, checked) -> list[int | None]:
        # Core statements on the session's connection: the rows MLflow's ORM would write,
        # without its unit of work (a third of the time of the same rows as ORM objects);
        # one statement per table for the whole group
        from sqlalchemy import and_, delete, func, insert, or_, select, update

        t, r = self.t, self.r
        now = now_ms()
        with self.tracking.ManagedSessionMaker(read_only=False) as session:
            connection = session.connection()
            experiment = t.SqlExperiment.__table__
            wanted = {int(run.experiment_id) for run, *_ in checked}
            stages = dict(connection.execute(
                select(experiment.c.experiment_id, experiment.c.lifecycle_stage).where(
                    experiment.c.experiment_id.in_(wanted))).all())
            for experiment_id in sorted(wanted):
                stage = stages.get(experiment_id)
                if stage != "active":
                    self._locations.pop(str(experiment_id), None)
                    self.tracking._check_experiment_is_active(
                        _Experiment(str(experiment_id), stage))
            run_rows, metric_rows, param_rows, tag_rows = [], [], [], []
            for run, metrics, params, tags, _ in checked:
                run_rows.append(dict(
                    name=run.name, artifact_uri=run.artifact_uri, run_uuid=run.run_id,
                    experiment_id=int(run.experiment_id), source_type="UNKNOWN",
                    source_name="", entry_point_name="", user_id="unknown", status="FINISHED",
                    start_time=run.start_time, end_time=now, deleted_time=None,
                    source_version="", lifecycle_stage="active"))
                for metric in metrics:
                    is_nan, value = self.tracking.sanitize_metric_value(metric.value)
                    metric_rows.append({"run_uuid": run.run_id, "key": metric.key,
                                        "value": value, "timestamp": now, "step": 0,
                                        "is_nan": is_nan})
                param_rows += [{"run_uuid": run.run_id, "key": p.key, "value": p.value}
                               for p in params]
                tag_rows += [{"run_uuid": run.run_id, "key": tag.key, "value": tag.value}
                             for tag in tags]
            connection.execute(insert(t.SqlRun.__table__), run_rows)
            if metric_rows:
                connection.execute(insert(t.SqlMetric.__table__), metric_rows)
                connection.execute(insert(t.SqlLatestMetric.__table__), metric_rows)
            if param_rows:
                connection.execute(insert(t.SqlParam.__table__), param_rows)
            connection.execute(insert(t.SqlTag.__table__), tag_rows)
            versioned = [(run, version) for run, *_, version in checked if version is not None]
            if not versioned:
                return [None] * len(checked)
            models, versions = r.SqlRegisteredModel.__table__, r.SqlModelVersion.__table__
            workspace = self.registry._get_active_workspace()
            names = sorted({version.name for _, version in versioned})
            found = connection.execute(update(models).where(
                models.c.name.in_(names), models.c.workspace == workspace).values(
                last_updated_time=now))
            if found.rowcount != len(names):
                present = {n for (n,) in connection.execute(select(models.c.name).where(
                    models.c.name.in_(names), models.c.workspace == workspace))}
                from mlflow.exceptions import MlflowException
                from mlflow.protos.databricks_pb2 import RESOURCE_DOES_NOT_EXIST

                missing = next(n for n in names if n not in present)
                raise MlflowException(f"Registered Model with name={missing} not found",
                                      RESOURCE_DOES_NOT_EXIST)
            newest = dict(connection.execute(
                select(versions.c.name, func.max(versions.c.version)).where(
                    versions.c.name.in_(names), versions.c.workspace == workspace).group_by(
                    versions.c.name)).all())
            numbers, version_rows, version_tag_rows, aliases_to = {}, [], [], {}
            for run, version in versioned:
                number = newest[version.name] = (newest.get(version.name) or 0) + 1
                numbers[run.run_id] = number
                version_rows.append(dict(
                    workspace=workspace, name=version.name, version=number, creation_time=now,
                    last_updated_time=now, description=version.description,
                    source=version.source, storage_location=version.source, run_id=run.run_id,
                    run_link=None))
                version_tag_rows += [{"workspace": workspace, "name": version.name,
                                      "version": number, "key": key, "value": value}
                                     for key, value in version.tags.items()]
                if version.alias is not None:
                    aliases_to[version.name, version.alias] = number    # the last one wins
            connection.execute(insert(versions), version_rows)
            if version_tag_rows:
                connection.execute(insert(r.SqlModelVersionTag.__table__), version_tag_rows)
            if aliases_to:
                aliases = r.SqlRegisteredModelAlias.__table__
                connection.execute(delete(aliases).where(
                    aliases.c.workspace == workspace,
                    or_(*(and_(aliases.c.name == name, aliases.c.alias == alias)
                          for name, alias in aliases_to))))
                connection.execute(insert(aliases), [dict(
                    workspace=workspace, name=name, alias=alias, version=number)
                    for (name, alias), number in aliases_to.items()])
            return [numbers.get(run.run_id) if version is not None else None
                    for run, *_, version in checked]


@dataclass(frozen=True)
class _Experiment:
    """What ``_check_experiment_is_active`` reads of an experiment."""

    experiment_id: str
    lifecycle_stage: str | None


__all__ = ["RunRows", "VersionRows", "SqlWriter", "now_ms"]
