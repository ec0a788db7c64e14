"""Which tracking-store errors are passing ones (registry.store.retry.is_transient_store_error):
the one place that reads MLflow's error codes; and that the registry raises them as its own
TransientStoreError (registry.store.boundary)."""
from __future__ import annotations

import sqlite3

import pytest
from mlflow.exceptions import MlflowException
from mlflow.protos import databricks_pb2

from registry.store.retry import is_transient_store_error


def test_a_locked_store_and_a_temporarily_unavailable_server_are_passing():
    assert is_transient_store_error(sqlite3.OperationalError("database is locked"))
    for code in (databricks_pb2.TEMPORARILY_UNAVAILABLE, databricks_pb2.INTERNAL_ERROR,
                 databricks_pb2.REQUEST_LIMIT_EXCEEDED, databricks_pb2.IO_ERROR):
        assert is_transient_store_error(MlflowException("busy", error_code=code))


def test_a_missing_model_or_a_bad_request_is_not():
    for code in (databricks_pb2.RESOURCE_DOES_NOT_EXIST, databricks_pb2.INVALID_PARAMETER_VALUE):
        assert not is_transient_store_error(MlflowException("no", error_code=code))
    assert not is_transient_store_error(sqlite3.OperationalError("no such table: runs"))
    assert not is_transient_store_error(ValueError("database is fine"))


def test_a_store_briefly_away_raises_the_registrys_transient_error(tmp_path, monkeypatch):
    """Known answer on a real SQLite store: its directory is away (an unmounted share), MLflow
    answers TEMPORARILY_UNAVAILABLE, and the registry raises its own TransientStoreError
    (MLflow's error its cause); with the directory back, the same registry answers again."""
    from registry.exceptions import RegistryError, TransientStoreError
    from registry.registry import Registry
    from registry.store.retry import RetryPolicy

    monkeypatch.setenv("MLFLOW_SQLALCHEMYSTORE_POOLCLASS", "NullPool")  # a connection a call
    store, away = tmp_path / "store", tmp_path / "away"
    registry = Registry(f"sqlite:///{store / 'mlflow.db'}", workdir=tmp_path,
                        retry=RetryPolicy(attempts=2, base_delay=0.01))
    assert registry.watermark("T-001") is None
    store.rename(away)
    with pytest.raises(TransientStoreError, match="unable to open database file") as caught:
        registry.watermark("T-001")
    assert isinstance(caught.value, RegistryError)
    assert not isinstance(caught.value, MlflowException)
    cause = caught.value.__cause__
    assert isinstance(cause, MlflowException)
    assert cause.error_code == databricks_pb2.ErrorCode.Name(databricks_pb2.TEMPORARILY_UNAVAILABLE)
    away.rename(store)
    assert registry.watermark("T-001") is None


def test_the_registry_raises_its_own_errors_for_the_stores():
    from graybox.exceptions import ArtifactError
    from registry.store.boundary import registry_error
    from registry.exceptions import NotFoundError, StoreError, TransientStoreError

    locked = sqlite3.OperationalError("database is locked")
    assert type(registry_error(locked)) is TransientStoreError
    assert str(registry_error(locked)) == "database is locked"
    refused = MlflowException("bad name", error_code=databricks_pb2.INVALID_PARAMETER_VALUE)
    assert type(registry_error(refused)) is StoreError
    assert str(registry_error(refused)) == "bad name"
    # the registry's and the caller's own errors say what is wrong themselves: kept
    for own in (NotFoundError("no T-9"), ArtifactError("tampered"), ValueError("no date"),
                OSError("disk full")):
        assert registry_error(own) is own
