"""The MLflow side of the registry: one client bound to one store, and the look-ups that
:mod:`registry.write.recording` and :mod:`registry.review` share.

No global MLflow state is touched: every call goes through an ``MlflowClient`` created with
an explicit tracking and registry URI, wrapped in :class:`registry.store.retry.RetryingClient`.
"""
from __future__ import annotations

import getpass
import logging
import os
from typing import Any, Callable, Iterator

from mlflow import MlflowClient
from mlflow.entities import ViewType
from mlflow.exceptions import MlflowException
from mlflow.protos.databricks_pb2 import (INVALID_PARAMETER_VALUE, RESOURCE_ALREADY_EXISTS,
                                          RESOURCE_DOES_NOT_EXIST, ErrorCode)

from registry.store import naming
from registry.exceptions import NotFoundError, RegistryError
from registry.store.model_headers import ModelHeader, read_headers
from registry.store.retry import RetryingClient, RetryPolicy, call_with_retry
from registry.store.sql_writes import SqlWriter
from registry.store.tracking_store import Store, prepare_store, relax_commit_sync, resolve_store

logger = logging.getLogger(__name__)

PAGE_SIZE = 1000


def is_not_found(error: Exception) -> bool:
    """Whether an MLflow error means "no such resource"."""
    return (isinstance(error, MlflowException)
            and error.error_code == ErrorCode.Name(RESOURCE_DOES_NOT_EXIST))


def _is_missing_alias(error: MlflowException) -> bool:
    """MLflow's stores say an absent alias as a bad parameter, not a missing resource."""
    return (error.error_code == ErrorCode.Name(INVALID_PARAMETER_VALUE)
            and "alias" in str(error) and "not found" in str(error))


def is_already_exists(error: Exception) -> bool:
    return (isinstance(error, MlflowException)
            and error.error_code == ErrorCode.Name(RESOURCE_ALREADY_EXISTS))


def default_user() -> str:
    """Who is acting: ``FLEET_HEALTH_USER``, else the login name."""
    user = os.environ.get("FLEET_HEALTH_USER")
    if user:
        return user
    try:
        return getpass.getuser()
    except Exception:  # no login name in some containers
        return "unknown"


class Backend:
    """An MLflow client bound to one store, with retries and the registry's look-ups.

    Parameters
    ----------
    tracking_uri : str, optional
        See :func:`registry.store.tracking_store.resolve_store`; None is the embedded SQLite
        default.
    workdir : path-like, optional
        Base of the default and of relative SQLite paths.
    user : str, optional
        Recorded on promotions and rejections; defaults to :func:`default_user`.
    retry : RetryPolicy, optional

    Notes
    -----
    A backend remembers, for its own lifetime, the id of each vehicle class's experiment and
    which assets' registered models it has seen with their class and experiment (neither
    changes in normal operation): recording a fit then needs no look-up of either. An
    experiment or registered model deleted by hand while a backend is in use makes its
    next recording for that class or asset fail once (it is forgotten, and found or
    created again on the next attempt); a new backend starts afresh.
    """

    def __init__(self, tracking_uri: str | None = None, workdir=None, user: str | None = None,
                 retry: RetryPolicy = RetryPolicy()):
        self.store: Store = resolve_store(tracking_uri, workdir)
        self.retry = retry
        self.user = user or default_user()
        prepare_store(self.store, retry)
        self.client = RetryingClient(MlflowClient(tracking_uri=self.store.tracking_uri,
                                                  registry_uri=self.store.tracking_uri), retry)
        self._registry = None
        if self.store.is_local:
            self._relax_commit_sync()
        self._experiments: dict[str, str] = {}          # vehicle class -> experiment id
        self._models: dict[str, tuple[str, str]] = {}   # asset -> (vehicle class, experiment id)
        #: record candidates in one SQL transaction when the store allows it
        #: (:mod:`registry.store.sql_writes`); False keeps MlflowClient's calls
        self.sql_writes = True
        self._writer: SqlWriter | None | bool = False   # False: not looked for yet

    @property
    def tracking_uri(self) -> str:
        return self.store.tracking_uri

    def _relax_commit_sync(self) -> None:
        wrapped = self.client.wrapped
        try:
            engines = {id(e): e for e in (wrapped._tracking_client.store.engine,
                                          wrapped._get_registry_client().store.engine)}
        except AttributeError:    # another MLflow layout: keep its defaults
            logger.debug("MLflow's SQLAlchemy engines not found; commit sync left as is")
            return
        for engine in engines.values():
            relax_commit_sync(engine)

    def sql_writer(self) -> SqlWriter | None:
        """The one-transaction writer of this store, or None (an ``mlflow server``, or
        :attr:`sql_writes` off)."""
        if not self.sql_writes:
            return None
        if self._writer is False:
            self._writer = SqlWriter.of(self.client.wrapped)
        return self._writer

    # -- writes that skip MlflowClient's prompt check -------------------------------------------
    def _registry_client(self):
        # MlflowClient checks before every alias or registered-model tag write that the name
        # is not a prompt, with a get_registered_model whose cost grows with the number of
        # versions (~15 ms at 1,000); our models are never prompts, so write through its
        # registry client (still retried on "database is locked")
        if self._registry is None:
            inner = getattr(self.client.wrapped, "_get_registry_client", None)
            self._registry = self.client if inner is None else RetryingClient(inner(),
                                                                               self.retry)
        return self._registry

    def set_alias(self, asset_id: str, alias: str, version: int | str) -> None:
        """Point ``alias`` of the asset's registered model at ``version``."""
        self._registry_client().set_registered_model_alias(naming.model_name(asset_id), alias,
                                                           str(version))

    def set_model_tag(self, asset_id: str, key: str, value: str) -> None:
        """Set a tag of the asset's registered model."""
        self._registry_client().set_registered_model_tag(naming.model_name(asset_id), key,
                                                         value)

    def log_artifacts(self, artifact_uri: str, local_dir: str) -> None:
        """Upload a directory's contents to a run's (or logged model's) artifact root, given
        by its URI (saves the ``get_run`` that ``MlflowClient.log_artifacts`` makes to find
        it); the URI as recorded, rebased if the store was moved."""
        call_with_retry(self.artifact_repository(artifact_uri).log_artifacts, local_dir,
                        policy=self.retry, what="log artifacts")

    def artifact_repository(self, artifact_uri: str):
        """MLflow's artifact repository of a recorded artifact URI, where it is now (see
        :meth:`registry.store.tracking_store.Store.local_artifact_uri`)."""
        from mlflow.store.artifact.artifact_repository_registry import get_artifact_repository

        return get_artifact_repository(self.store.local_artifact_uri(artifact_uri),
                                       tracking_uri=self.tracking_uri)

    # -- experiments ---------------------------------------------------------------------------
    def experiment_id(self, vehicle_class: str, create: bool = False) -> str | None:
        """Id of the vehicle class's experiment (created on request, else None if absent)."""
        name = naming.experiment_name(vehicle_class)
        if vehicle_class in self._experiments:
            return self._experiments[vehicle_class]
        experiment = self.client.get_experiment_by_name(name)
        if experiment is not None:
            self._experiments[vehicle_class] = experiment.experiment_id
            return experiment.experiment_id
        if not create:
            return None
        tags = {naming.TAG_VEHICLE_CLASS: vehicle_class,
                "mlflow.note.content": f"Gray-box fits of the {vehicle_class!r} vehicle class: one "
                                       f"run per asset and window (fleet-health)."}
        try:
            created = self.client.create_experiment(
                name, artifact_location=self.store.experiment_artifact_location(name), tags=tags)
        except MlflowException as error:
            if not is_already_exists(error):
                raise
            created = self.client.get_experiment_by_name(name).experiment_id
        self._experiments[vehicle_class] = created
        return created

    def forget(self, asset_id: str | None = None, vehicle_class: str | None = None) -> None:
        """Drop what this backend remembers of an asset's model and of a class's experiment."""
        self._models.pop(asset_id, None)
        self._experiments.pop(vehicle_class, None)

    def experiment_ids(self) -> list[str]:
        """Ids of every fleet-health experiment (one per vehicle class; not the fleet-level
        experiment of the nights' heat maps)."""
        ids: list[str] = []
        for experiment in self.paged(self.client.search_experiments,
                                     filter_string=f"name LIKE '{naming.EXPERIMENT_PREFIX}%' and "
                                                   f"name != '{naming.FLEET_EXPERIMENT}'",
                                     view_type=ViewType.ACTIVE_ONLY):
            ids.append(experiment.experiment_id)
        return ids

    # -- registered models -------------------------------------------------------------------
    def _read_headers(self, names) -> dict[str, ModelHeader]:
        inner = getattr(self.client.wrapped, "_get_registry_client", None)
        registry_client = self.client.wrapped if inner is None else inner()
        return read_headers(registry_client, names, self.retry)

    def registered_model(self, asset_id: str) -> ModelHeader | None:
        """The asset's registered model (its name, tags and aliases, read without its
        versions: see :mod:`registry.store.model_headers`), or None."""
        return self.registered_models([asset_id]).get(asset_id)

    def _remember(self, asset_id: str, model) -> None:
        tags = model.tags or {}
        vehicle_class, experiment_id = (tags.get(naming.TAG_VEHICLE_CLASS),
                                        tags.get(naming.TAG_EXPERIMENT_ID))
        if vehicle_class and experiment_id:
            self._models[asset_id] = (vehicle_class, experiment_id)

    def registered_models(self, asset_ids: list[str]) -> dict[str, ModelHeader]:
        """The registered models of several assets (as :meth:`registered_model`), read
        together (absent ones left out)."""
        names = {naming.model_name(a): a for a in asset_ids}
        found = {}
        for name, header in self._read_headers(names).items():
            found[names[name]] = header
            self._remember(names[name], header)
        for asset in set(names.values()) - set(found):
            self._models.pop(asset, None)
        return found

    def require_registered_model(self, asset_id: str):
        model = self.registered_model(asset_id)
        if model is None:
            raise NotFoundError(f"asset {asset_id!r} has nothing recorded in the registry "
                                f"({self.tracking_uri})")
        return model

    def ensure_registered_models(self, classes: dict[str, str]) -> None:
        """Make sure each asset (``{asset_id: vehicle_class}``) has its registered model, of
        that class and pointing at that class's experiment; one search for those this
        backend has not seen yet.

        Raises
        ------
        RegistryError
            If an asset is recorded with another vehicle class.
        """
        experiments = {c: self.experiment_id(c, create=True) for c in set(classes.values())}
        unseen = [a for a, c in classes.items() if self._models.get(a) != (c, experiments[c])]
        if not unseen:
            return
        models = self.registered_models(unseen)
        for asset in unseen:
            self.ensure_registered_model(asset, classes[asset], experiments[classes[asset]],
                                         model=models.get(asset))

    def ensure_registered_model(self, asset_id: str, vehicle_class: str, experiment_id: str,
                                model=None):
        """The asset's registered model, created (tagged with its class) if needed.

        ``model``, the asset's registered model if the caller has just read it, saves the
        look-up.
        """
        name = naming.model_name(asset_id)
        model = model if model is not None else self.registered_model(asset_id)
        if model is None:
            tags = {naming.TAG_ASSET_ID: asset_id, naming.TAG_VEHICLE_CLASS: vehicle_class,
                    naming.TAG_EXPERIMENT_ID: experiment_id}
            try:
                self.client.create_registered_model(
                    name, tags=tags,
                    description=f"Gray-box signatures of asset {asset_id} ({vehicle_class}). "
                                f"Alias 'baseline' marks the healthy version, 'candidate' "
                                f"the newest fit.")
            except MlflowException as error:
                if not is_already_exists(error):
                    raise
            model = self.require_registered_model(asset_id)
        recorded = (model.tags or {}).get(naming.TAG_VEHICLE_CLASS)
        if recorded is not None and recorded != vehicle_class:
            raise RegistryError(f"asset {asset_id!r} is recorded as vehicle class {recorded!r}, "
                                f"not {vehicle_class!r}")
        if (model.tags or {}).get(naming.TAG_EXPERIMENT_ID) != experiment_id:
            self.set_model_tag(asset_id, naming.TAG_EXPERIMENT_ID, experiment_id)
            self.set_model_tag(asset_id, naming.TAG_VEHICLE_CLASS, vehicle_class)
            self.set_model_tag(asset_id, naming.TAG_ASSET_ID, asset_id)
        self._models[asset_id] = (vehicle_class, experiment_id)
        return model

    def model_version(self, asset_id: str, version: int | str):
        """A version of the asset's registered model (NotFoundError if absent)."""
        name = naming.model_name(asset_id)
        try:
            return self.client.get_model_version(name, str(int(version)))
        except MlflowException as error:
            if is_not_found(error):
                raise NotFoundError(f"asset {asset_id!r} has no version {version}") from None
            raise
        except ValueError:
            raise NotFoundError(f"asset {asset_id!r}: {version!r} is not a version number") from None

    def version_by_alias(self, asset_id: str, alias: str):
        """The version holding ``alias``, or None."""
        writer = self.sql_writer()
        if writer is not None:
            return call_with_retry(writer.version_by_alias, naming.model_name(asset_id), alias,
                                   policy=self.retry, what="read a version by its alias")
        try:
            return self.client.get_model_version_by_alias(naming.model_name(asset_id), alias)
        except MlflowException as error:
            if is_not_found(error) or _is_missing_alias(error):
                return None
            raise

    # -- paging --------------------------------------------------------------------------------
    def paged(self, search: Callable[..., Any], *args, max_results: int = PAGE_SIZE,
              **kwargs) -> Iterator[Any]:
        """Every item of a paged MLflow search."""
        token = None
        while True:
            page = search(*args, max_results=max_results, page_token=token, **kwargs)
            yield from page
            token = getattr(page, "token", None)
            if not token:
                return
