"""Watermarks: per asset, the end of the last committed telemetry window.

The watermark is a tag (``fleet_health.watermark``, ISO UTC) on the asset's registered
model, so reading it is one read of that tag's row (on an SQLAlchemy store, through
:class:`registry.store.sql_writes.SqlWriter`; elsewhere of the registered model's tags and
aliases), whatever the number of runs and versions (not MLflow's ``get_registered_model``,
which loads every version of the model: see :mod:`registry.store.model_headers`).
It only moves forward, and only when the flow says its results are committed
(:func:`commit_watermark`, under the asset's lock).
"""
from __future__ import annotations

from typing import Mapping, Sequence

import pandas as pd
from mlflow.exceptions import MlflowException

from registry.store import naming
from registry.store.backend import Backend, is_not_found
from registry.store.boundary import registry_error
from registry.store.retry import call_with_retry, is_passing_failure


def watermark(backend: Backend, asset_id: str) -> pd.Timestamp | None:
    """End (exclusive, UTC) of the asset's last committed window, or None if none yet."""
    if backend.sql_writer() is not None:      # the tag's row alone
        return watermarks(backend, [asset_id])[asset_id]
    model = backend.registered_model(asset_id)
    if model is None:
        return None
    value = (model.tags or {}).get(naming.TAG_WATERMARK)
    return None if not value else pd.Timestamp(value)


def watermarks(backend: Backend, asset_ids: Sequence[str]) -> dict[str, pd.Timestamp | None]:
    """:func:`watermark` of each asset: on an SQLAlchemy store the tags' rows of all of them
    in one query (per 500), elsewhere one read each."""
    writer = backend.sql_writer()
    if writer is None:
        return {asset: watermark(backend, asset) for asset in asset_ids}
    names = {naming.model_name(asset): asset for asset in asset_ids}
    values = call_with_retry(writer.model_tag_of, list(names), naming.TAG_WATERMARK,
                             policy=backend.retry, what="read the watermarks")
    return {asset: (pd.Timestamp(values[name]) if values.get(name) else None)
            for name, asset in names.items()}


def commit_watermark(backend: Backend, asset_id: str, end) -> pd.Timestamp:
    """Advance the asset's watermark to ``end`` (never moves it backwards).

    Returns
    -------
    pandas.Timestamp
        The watermark now in place (``end``, or the later one already there).

    Raises
    ------
    registry.exceptions.NotFoundError
        If nothing was ever recorded for the asset (record its fit first).
    """
    naming.model_name(asset_id)         # validates the id before the lock file is named
    end = pd.Timestamp(naming.iso_utc(end))
    with backend.store.asset_lock(asset_id):
        return _advance(backend, asset_id, end)


def _advance(backend: Backend, asset_id: str, end: pd.Timestamp) -> pd.Timestamp:
    """:func:`commit_watermark` under the asset's lock (held by the caller)."""
    writer = backend.sql_writer()
    if writer is not None:      # read and written in one transaction
        try:
            value = call_with_retry(
                writer.advance_model_tag, naming.model_name(asset_id), naming.TAG_WATERMARK,
                end.isoformat(), lambda now: not now or pd.Timestamp(now) < end,
                policy=backend.retry, what="commit the watermark")
        except MlflowException as error:
            if is_not_found(error):
                backend.require_registered_model(asset_id)   # raises NotFoundError
            raise
        return pd.Timestamp(value)
    model = backend.require_registered_model(asset_id)
    value = (model.tags or {}).get(naming.TAG_WATERMARK)
    current = None if not value else pd.Timestamp(value)
    if current is not None and current >= end:
        return current
    backend.set_model_tag(asset_id, naming.TAG_WATERMARK, end.isoformat())
    return end


def commit_watermarks(backend: Backend, ends: Mapping[str, object]
                      ) -> dict[str, pd.Timestamp | BaseException]:
    """:func:`commit_watermark` of several assets (a group's), each on its own: under the
    assets' locks taken together and, on an SQLAlchemy store, in one transaction.

    Returns
    -------
    dict
        Asset id -> the watermark in place, or the error that kept it (as the registry
        raises it; e.g. ``NotFoundError`` when nothing was recorded for the asset). When the
        shared transaction fails, each asset is advanced in its own.

    Raises
    ------
    Exception
        A passing failure of the store (locked after the retries, unreachable), for all.
    """
    out: dict[str, pd.Timestamp | BaseException] = {}
    wanted: dict[str, pd.Timestamp] = {}
    for asset_id, end in ends.items():
        try:
            naming.model_name(asset_id)
            wanted[asset_id] = pd.Timestamp(naming.iso_utc(end))
        except Exception as error:  # noqa: BLE001 - this asset's own
            out[asset_id] = registry_error(error)
    writer = backend.sql_writer()
    with backend.store.asset_locks(wanted) as refused:
        out.update(refused)
        held = {a: end for a, end in wanted.items() if a not in refused}
        values = None
        if writer is not None and held:
            names = {naming.model_name(a): a for a in held}
            try:
                values = call_with_retry(
                    writer.advance_model_tags, naming.TAG_WATERMARK,
                    {name: held[a].isoformat() for name, a in names.items()},
                    lambda now, new: not now or pd.Timestamp(now) < pd.Timestamp(new),
                    policy=backend.retry, what="commit the watermarks")
            except Exception as error:  # noqa: BLE001
                if is_passing_failure(error):
                    raise
                values = None
        for asset_id, end in held.items():
            value = None if values is None else values[naming.model_name(asset_id)]
            try:
                if values is None:
                    out[asset_id] = _advance(backend, asset_id, end)
                elif value is None:
                    backend.require_registered_model(asset_id)    # raises NotFoundError
                    out[asset_id] = _advance(backend, asset_id, end)   # made meanwhile
                else:
                    out[asset_id] = pd.Timestamp(value)
            except Exception as error:  # noqa: BLE001 - this asset's own
                if is_passing_failure(error):
                    raise
                out[asset_id] = registry_error(error)
    return {asset_id: out[asset_id] for asset_id in ends}
