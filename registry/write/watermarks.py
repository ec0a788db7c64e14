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

import pandas as pd
from mlflow.exceptions import MlflowException

from registry.store import naming
from registry.store.backend import Backend, is_not_found
from registry.store.retry import call_with_retry


def watermark(backend: Backend, asset_id: str) -> pd.Timestamp | None:
    """End (exclusive, UTC) of the asset's last committed window, or None if none yet."""
    writer = backend.sql_writer()
    if writer is not None:      # the tag's row alone
        value = call_with_retry(writer.model_tag, naming.model_name(asset_id),
                                naming.TAG_WATERMARK, policy=backend.retry,
                                what="read the watermark")
        return None if not value else pd.Timestamp(value)
    model = backend.registered_model(asset_id)
    if model is None:
        return None
    value = (model.tags or {}).get(naming.TAG_WATERMARK)
    return None if not value else pd.Timestamp(value)


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
    writer = backend.sql_writer()
    with backend.store.asset_lock(asset_id):
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
