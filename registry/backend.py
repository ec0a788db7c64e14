"""The MLflow side of the registry: one client bound to one store, and the look-ups that
:mod:`registry.records` and :mod:`registry.baselines` share.

No global MLflow state is touched: every call goes through an ``MlflowClient`` created with
an explicit tracking and registry URI, wrapped in :class:`registry.store.RetryingClient`.
"""
from __future__ import annotations

import getpass
import os
from typing import Any, Callable, Iterator

from mlflow import MlflowClient
from mlflow.entities import ViewType
from mlflow.exceptions import MlflowException
from mlflow.protos.databricks_pb2 import (RESOURCE_ALREADY_EXISTS, RESOURCE_DOES_NOT_EXIST,
                                          ErrorCode)

from registry import naming
from registry.exceptions import NotFoundError, RegistryError
from registry.store import RetryingClient, RetryPolicy, Store, prepare_sqlite, resolve_store

PAGE_SIZE = 1000


def is_not_found(error: Exception) -> bool:
    """Whether an MLflow error means "no such resource"."""
    return (isinstance(error, MlflowException)
            and error.error_code == ErrorCode.Name(RESOURCE_DOES_NOT_EXIST))


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
        See :func:`registry.store.resolve_store`; None is the embedded SQLite default.
    workdir : path-like, optional
        Base of the default and of relative SQLite paths.
    user : str, optional
        Recorded on promotions and rejections; defaults to :func:`default_user`.
    retry : RetryPolicy, optional
    """

    def __init__(self, tracking_uri: str | None = None, workdir=None, user: str | None = None,
                 retry: RetryPolicy = RetryPolicy()):
        self.store: Store = resolve_store(tracking_uri, workdir)
        self.retry = retry
        self.user = user or default_user()
        prepare_sqlite(self.store, retry)
        self.client = RetryingClient(MlflowClient(tracking_uri=self.store.tracking_uri,
                                                  registry_uri=self.store.tracking_uri), retry)

    @property
    def tracking_uri(self) -> str:
        return self.store.tracking_uri

    # -- experiments ---------------------------------------------------------------------------
    def experiment_id(self, vehicle_class: str, create: bool = False) -> str | None:
        """Id of the vehicle class's experiment (created on request, else None if absent)."""
        name = naming.experiment_name(vehicle_class)
        experiment = self.client.get_experiment_by_name(name)
        if experiment is not None:
            return experiment.experiment_id
        if not create:
            return None
        tags = {naming.TAG_VEHICLE_CLASS: vehicle_class,
                "mlflow.note.content": f"Gray-box fits of the {vehicle_class!r} vehicle class: one "
                                       f"run per asset and window (fleet-health)."}
        try:
            return self.client.create_experiment(
                name, artifact_location=self.store.experiment_artifact_location(name), tags=tags)
        except MlflowException as error:
            if not is_already_exists(error):
                raise
            return self.client.get_experiment_by_name(name).experiment_id

    def experiment_ids(self) -> list[str]:
        """Ids of every fleet-health experiment (one per vehicle class)."""
        ids: list[str] = []
        for experiment in self.paged(self.client.search_experiments,
                                     filter_string=f"name LIKE '{naming.EXPERIMENT_PREFIX}%'",
                                     view_type=ViewType.ACTIVE_ONLY):
            ids.append(experiment.experiment_id)
        return ids

    # -- registered models -------------------------------------------------------------------
    def registered_model(self, asset_id: str):
        """The asset's registered model, or None."""
        try:
            return self.client.get_registered_model(naming.model_name(asset_id))
        except MlflowException as error:
            if is_not_found(error):
                return None
            raise

    def require_registered_model(self, asset_id: str):
        model = self.registered_model(asset_id)
        if model is None:
            raise NotFoundError(f"asset {asset_id!r} has nothing recorded in the registry "
                                f"({self.tracking_uri})")
        return model

    def ensure_registered_model(self, asset_id: str, vehicle_class: str, experiment_id: str):
        """The asset's registered model, created (tagged with its class) if needed."""
        name = naming.model_name(asset_id)
        model = self.registered_model(asset_id)
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
            model = self.client.get_registered_model(name)
        recorded = (model.tags or {}).get(naming.TAG_VEHICLE_CLASS)
        if recorded is not None and recorded != vehicle_class:
            raise RegistryError(f"asset {asset_id!r} is recorded as vehicle class {recorded!r}, "
                                f"not {vehicle_class!r}")
        if (model.tags or {}).get(naming.TAG_EXPERIMENT_ID) != experiment_id:
            self.client.set_registered_model_tag(name, naming.TAG_EXPERIMENT_ID, experiment_id)
            self.client.set_registered_model_tag(name, naming.TAG_VEHICLE_CLASS, vehicle_class)
            self.client.set_registered_model_tag(name, naming.TAG_ASSET_ID, asset_id)
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
        try:
            return self.client.get_model_version_by_alias(naming.model_name(asset_id), alias)
        except MlflowException as error:
            if is_not_found(error):
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
