"""Which tracking-store errors are passing ones (registry.retry.is_transient_store_error): the
one place that reads MLflow's error codes."""
from __future__ import annotations

import sqlite3

from mlflow.exceptions import MlflowException
from mlflow.protos import databricks_pb2

from registry.retry import is_transient_store_error


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
