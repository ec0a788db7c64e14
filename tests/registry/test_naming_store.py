"""Names, tag keys, tracking-URI handling, retries and locks (no MLflow store needed)."""
from __future__ import annotations

import sqlite3
import threading
import time

import pandas as pd
import pytest

from graybox.exceptions import InvalidAssetIdError
from registry.store import naming
from registry.exceptions import RegistryError
from registry.store.locks import file_lock
from registry.store.retry import RetryPolicy, call_with_retry, is_locked_error
from registry.store.tracking_store import resolve_store


def test_names_follow_the_design():
    assert naming.model_name("T-01") == "fleet-health.T-01"
    assert naming.experiment_name("turbine") == "fleet-health/turbine"
    assert naming.asset_from_model_name("fleet-health.T-01") == "T-01"
    assert naming.asset_from_model_name("other-model") is None


@pytest.mark.parametrize("bad", ["", "a/b", "..", ".", "x" * 65, "T 1", "T'1", None])
def test_invalid_asset_ids_are_refused_before_any_name(bad):
    with pytest.raises(InvalidAssetIdError):
        naming.model_name(bad)
    with pytest.raises(InvalidAssetIdError):
        naming.fit_key(bad, "2026-01-01", "2026-01-02", "candidate", "h")


def test_invalid_vehicle_class_is_refused():
    with pytest.raises(ValueError, match="vehicle class"):
        naming.experiment_name("tur/bine")


def test_fit_key_is_deterministic_and_normalizes_timestamps():
    a = naming.fit_key("T-01", "2026-01-01", "2026-01-02T00:00:00Z", "candidate", "h")
    b = naming.fit_key("T-01", pd.Timestamp("2026-01-01", tz="UTC"),
                       pd.Timestamp("2026-01-02 01:00", tz="Europe/Paris"), "candidate", "h")
    assert a == b and len(a) == 40
    assert a != naming.fit_key("T-01", "2026-01-01", "2026-01-02", "baseline", "h")
    assert a != naming.fit_key("T-01", "2026-01-01", "2026-01-02", "candidate", "other")
    with pytest.raises(ValueError):
        naming.fit_key("T-01", "2026-01-01", "2026-01-02", "nightly", "h")


def test_filter_literals_refuse_quotes():
    assert naming.quote("abc") == "'abc'"
    with pytest.raises(ValueError):
        naming.quote("a' or '1'='1")


def test_resolve_store_sqlite_relative_absolute_and_server(tmp_path):
    store = resolve_store("sqlite:///sub/m.db", workdir=tmp_path)
    assert store.tracking_uri == f"sqlite:///{tmp_path.resolve()}/sub/m.db"
    assert store.db_path == tmp_path.resolve() / "sub" / "m.db"
    assert store.artifact_root == (tmp_path.resolve() / "sub" / "mlartifacts").as_uri()
    assert store.lock_dir.parent == tmp_path.resolve() / "sub"
    default = resolve_store(None, workdir=tmp_path)
    assert default.tracking_uri == f"sqlite:///{tmp_path.resolve()}/mlflow.db"
    server = resolve_store("http://127.0.0.1:5000/")
    assert server.tracking_uri == "http://127.0.0.1:5000" and server.db_path is None
    assert server.experiment_artifact_location("fleet-health/turbine") is None
    for bad in ("mlruns", "sqlite:///:memory:", "sqlite://"):
        with pytest.raises(ValueError):
            resolve_store(bad)


def test_only_locked_errors_are_retried(caplog):
    calls = []

    def flaky():
        calls.append(1)
        if len(calls) < 3:
            try:
                raise sqlite3.OperationalError("database is locked")
            except sqlite3.OperationalError as error:
                raise RuntimeError("(sqlite3.OperationalError) wrapped") from error
        return "done"

    fast = RetryPolicy(attempts=5, base_delay=0.001, max_delay=0.002)
    assert call_with_retry(flaky, policy=fast) == "done"
    assert len(calls) == 3
    assert "database is locked" in caplog.text

    def broken():
        calls.append(1)
        raise ValueError("something else")

    calls.clear()
    with pytest.raises(ValueError):
        call_with_retry(broken, policy=fast)
    assert len(calls) == 1
    assert is_locked_error(sqlite3.OperationalError("database is busy"))
    assert not is_locked_error(sqlite3.OperationalError("no such table: runs"))

    def always_locked():
        raise sqlite3.OperationalError("database is locked")

    with pytest.raises(sqlite3.OperationalError):
        call_with_retry(always_locked, policy=fast)


def test_file_lock_excludes_threads_and_times_out(tmp_path):
    path = tmp_path / "locks" / "a.lock"
    inside, overlaps = [], []

    def worker():
        with file_lock(path):
            inside.append(1)
            if len(inside) > 1:
                overlaps.append(1)
            time.sleep(0.02)
            inside.pop()

    threads = [threading.Thread(target=worker) for _ in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not overlaps
    with file_lock(path):
        with pytest.raises(RegistryError, match="could not lock"):
            with file_lock(path, timeout=0.05):
                pass


def test_retry_outlasts_a_real_sqlite_write_lock(tmp_path):
    path = tmp_path / "db.sqlite"
    setup = sqlite3.connect(path)
    setup.execute("PRAGMA journal_mode=WAL")
    setup.execute("CREATE TABLE t (x INTEGER)")
    setup.commit()
    holder = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    holder.execute("BEGIN IMMEDIATE")             # another writer holds the write lock
    holder.execute("INSERT INTO t VALUES (1)")
    attempts = []

    def write():
        attempts.append(1)
        connection = sqlite3.connect(path, timeout=0)   # no busy wait: fails at once
        try:
            connection.execute("INSERT INTO t VALUES (2)")
            connection.commit()
        finally:
            connection.close()

    release = threading.Timer(0.3, holder.execute, args=("COMMIT",))
    release.start()
    call_with_retry(write, policy=RetryPolicy(attempts=20, base_delay=0.02, max_delay=0.1))
    release.join()
    assert len(attempts) > 1
    assert sorted(x for (x,) in setup.execute("SELECT x FROM t")) == [1, 2]
