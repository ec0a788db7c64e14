"""Registered models read without their versions: name, tags and aliases.

MLflow's ``get_registered_model`` also returns the newest version of each stage, and its
SQLAlchemy store finds them by loading every version of the model: its cost grows with the
asset's history (a year of nightly candidates). What the nightly path reads of a registered
model is its tags (the watermark, the vehicle class and experiment) and its aliases, so
:func:`read_headers` reads those alone:

* on an SQLAlchemy store (embedded SQLite, PostgreSQL): one query of the registered-model
  rows with their tags and aliases (MLflow's own query and entity conversion, given no
  versions), whatever the number of versions;
* on any other store (an ``mlflow server``): ``search_registered_models`` by name, which
  MLflow's server answers with the newest versions found in SQL, not by loading them all.

The tags and aliases are MLflow's own entities' (:class:`ModelHeader` copies them from a
``RegisteredModel``), so they read exactly as ``get_registered_model`` gives them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping

from registry.store import naming
from registry.store.retry import RetryPolicy, call_with_retry

NAMES_PER_SEARCH = 200      # registered models per search (MLflow's page limit is 1,000)


@dataclass(frozen=True)
class ModelHeader:
    """A registered model without its versions.

    Attributes
    ----------
    name : str
        The registered model's name.
    tags : mapping of str to str
        Its tags, as ``RegisteredModel.tags``.
    aliases : mapping of str to int
        Alias to version number, as ``RegisteredModel.aliases``.
    """

    name: str
    tags: Mapping[str, str] = field(default_factory=dict)
    aliases: Mapping[str, int] = field(default_factory=dict)

    @classmethod
    def from_registered_model(cls, model) -> "ModelHeader":
        """The header of an MLflow ``RegisteredModel``."""
        return cls(model.name, dict(model.tags or {}), dict(model.aliases or {}))


def _sql_headers(store, names: list[str]) -> dict[str, ModelHeader] | None:
    """Headers read straight from an MLflow SQLAlchemy registry store (None if ``store`` is
    not one, or not laid out as this MLflow version's)."""
    try:
        from mlflow.store.model_registry.dbmodels.models import SqlRegisteredModel

        session_maker = store.ManagedSessionMaker
        query_of = store._get_query
        eager = store._get_eager_registered_model_query_options
    except (ImportError, AttributeError):
        return None
    with session_maker() as session:
        rows = (query_of(session, SqlRegisteredModel).options(*eager())
                .filter(SqlRegisteredModel.name.in_(names)).all())
        # no versions given: MLflow then reads none (its latest_versions stays empty)
        return {row.name: ModelHeader.from_registered_model(
                    row.to_mlflow_entity(preloaded_latest_versions=[])) for row in rows}


def _searched_headers(search: Callable[..., Any], names: list[str]) -> dict[str, ModelHeader]:
    """Headers found by ``search_registered_models`` by name, a page of names at a time."""
    found: dict[str, ModelHeader] = {}
    for first in range(0, len(names), NAMES_PER_SEARCH):
        chunk = names[first:first + NAMES_PER_SEARCH]
        clause = ("name IN (" + ", ".join(naming.quote(n) for n in chunk) + ")"
                  if len(chunk) > 1 else f"name = {naming.quote(chunk[0])}")
        for model in search(clause, max_results=len(chunk)):
            if model.name in chunk:
                found[model.name] = ModelHeader.from_registered_model(model)
    return found


def read_headers(registry_client, names: Iterable[str],
                 policy: RetryPolicy = RetryPolicy()) -> dict[str, ModelHeader]:
    """The headers of the registered models named ``names`` (absent ones left out).

    Parameters
    ----------
    registry_client : mlflow.tracking._model_registry.client.ModelRegistryClient
        MLflow's registry client (``MlflowClient._get_registry_client()``); its ``store``
        is read directly when it is an SQLAlchemy store.
    names : iterable of str
        Registered model names.
    policy : RetryPolicy, optional
        Retries of "database is locked".

    Returns
    -------
    dict of str to ModelHeader
        By name.

    Raises
    ------
    mlflow.exceptions.MlflowException
        If the store cannot be read (after the retries of a locked database).
    """
    wanted = sorted(set(names))
    if not wanted:
        return {}
    store = getattr(registry_client, "store", None)
    headers = call_with_retry(_sql_headers, store, wanted, policy=policy,
                              what="read registered models")
    if headers is not None:
        return headers
    return call_with_retry(_searched_headers, registry_client.search_registered_models, wanted,
                           policy=policy, what="search registered models")


__all__ = ["ModelHeader", "read_headers"]
