"""The registry on a real PostgreSQL server (tests/postgres_server.py): URI handling, advisory
locks across processes, concurrent schema creation and concurrent writer processes."""
from __future__ import annotations

import subprocess
import sys
import time

import pandas as pd
import pytest

from postgres_server import subprocess_env
from registry.exceptions import RegistryError
from registry.store.locks import advisory_key
from registry.store.tracking_store import resolve_store
from test_parallel_writers import WORKER, _check_store, record_from_threads

DAY0 = pd.Timestamp("2026-01-01", tz="UTC")


def test_postgres_uris_are_normalized_for_psycopg(tmp_path):
    store = resolve_store("postgresql://fleet@db.example:5433/mlflow", workdir=tmp_path)
    assert store.tracking_uri == "postgresql+psycopg://fleet@db.example:5433/mlflow"
    assert store.postgres_conninfo == "postgresql://fleet@db.example:5433/mlflow"
    assert store.db_path is None and not store.is_local
    assert store.artifact_root == (tmp_path.resolve() / "mlartifacts").as_uri()
    assert resolve_store("postgres://fleet@db/mlflow").tracking_uri == \
        "postgresql+psycopg://fleet@db/mlflow"
    assert resolve_store("postgresql+psycopg2://fleet@db/mlflow?sslmode=require").tracking_uri \
        == "postgresql+psycopg2://fleet@db/mlflow?sslmode=require"     # a named driver is kept
    # a shared store's artifact paths are never rebased (they must mean the same everywhere)
    gone = "file:///nowhere/mlartifacts/fleet-health_turbine-0/run/artifacts"
    assert store.local_artifact_uri(gone) == gone
    with pytest.raises(ValueError, match="must name a database"):
        resolve_store("postgresql://fleet@db.example:5433")
    assert advisory_key("fleet-health/asset/T-01") == advisory_key("fleet-health/asset/T-01")
    # every host and every version must take the same lock for a name: a known answer (a
    # process-salted hash, or another digest, would fail here)
    assert advisory_key("fleet-health/asset/T-01") == -5065187905286029355
    assert advisory_key("fleet-health/asset/T-01") != advisory_key("fleet-health/asset/T-02")


HOLD = """
import sys, time
from registry.store.tracking_store import resolve_store
with resolve_store(sys.argv[1]).asset_lock("T-01"):
    print("held", flush=True)
    time.sleep(60)
"""


def test_asset_lock_is_an_advisory_lock_across_processes(postgres_uri):
    store = resolve_store(postgres_uri)
    holder = subprocess.Popen([sys.executable, "-c", HOLD, postgres_uri], stdout=subprocess.PIPE,
                              text=True, env=subprocess_env())
    try:
        assert holder.stdout.readline().strip() == "held"
        started = time.monotonic()
        with pytest.raises(RegistryError, match=r"could not lock asset 'T-01' within 0\.5 s"):
            with store.asset_lock("T-01", timeout=0.5):
                pass
        assert 0.4 < time.monotonic() - started < 5
        with store.asset_lock("T-02", timeout=0.5):      # another asset is free
            pass
    finally:
        holder.kill()
        holder.wait()
    with store.asset_lock("T-01", timeout=10):          # a dead holder's lock is released
        pass


def test_record_promote_load_and_watermark_on_postgres(postgres_uri, fits, tmp_path):
    from registry import Registry

    registry = Registry(postgres_uri, workdir=tmp_path, user="tester")
    assert registry.tracking_uri.startswith("postgresql+psycopg://")
    first = registry.record_fit("T-01", "turbine", fits.baseline, role="baseline",
                                calibration=fits.calibration, window_start=DAY0,
                                window_end=DAY0 + pd.Timedelta(days=4), data_hash="b", plots=False)
    registry.promote("T-01", first.version, reason="healthy")
    night = DAY0 + pd.Timedelta(days=5)
    candidate = registry.record_fit("T-01", "turbine", fits.candidate, role="candidate",
                                    drift=fits.alarmed, window_start=night,
                                    window_end=night + pd.Timedelta(days=1), data_hash="n",
                                    plots=False)
    again = registry.record_fit("T-01", "turbine", fits.candidate, role="candidate",
                                drift=fits.alarmed, window_start=night,
                                window_end=night + pd.Timedelta(days=1), data_hash="n",
                                plots=False)
    assert (first.version, candidate.version) == (1, 2)
    assert not again.created and again.version == 2
    registry.commit_watermark("T-01", night + pd.Timedelta(days=1))
    registry.commit_watermark("T-01", night)                  # never backwards
    assert registry.watermark("T-01") == night + pd.Timedelta(days=1)
    loaded = registry.baseline("T-01")
    assert loaded.version == 1 and loaded.signature == fits.baseline
    alerts = registry.alerts()
    assert alerts and {(a.asset_id, a.version) for a in alerts} == {("T-01", 2)}
    assert len({a.key for a in alerts}) == len(alerts)
    # the artifacts are under the working directory's mlartifacts
    assert (tmp_path / "mlartifacts").is_dir() and any((tmp_path / "mlartifacts").rglob("drift.json"))


@pytest.mark.slow
def test_writer_processes_on_a_new_postgres_database(tmp_path, postgres_server, fits):
    """Four processes open one empty database at once (the schema is created once, under the
    advisory lock) and record fits of three assets together."""
    from registry import Registry

    uri = postgres_server.create_database("writers_from_empty")     # no schema yet
    processes, fits_each, assets = 4, 2, 3
    signature = tmp_path / "signature.json"
    signature.write_text(fits.baseline.to_json())
    calibration = tmp_path / "calibration.json"
    calibration.write_text(fits.calibration.to_json())
    done = subprocess.run([sys.executable, str(WORKER), uri, str(signature), str(calibration),
                           str(processes), str(fits_each), str(assets)], capture_output=True,
                          text=True, timeout=600, env=subprocess_env(), cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr[-5000:]
    assert "Traceback" not in done.stderr, done.stderr[-5000:]
    assert len([line for line in done.stdout.splitlines() if "retries=" in line]) == processes
    registry = Registry(uri, workdir=tmp_path)
    asset_ids = [f"P-{a:02d}" for a in range(assets)]
    _check_store(registry, processes * fits_each, asset_ids)
    # each asset's watermark is the end of the latest window any process committed for it
    latest = {}
    for worker in range(processes):
        for k in range(fits_each):
            asset = f"P-{(worker + k) % assets:02d}"
            end = pd.Timestamp("2026-02-01", tz="UTC") + pd.Timedelta(days=worker * fits_each + k + 1)
            latest[asset] = max(latest.get(asset, end), end)
    assert {a: registry.watermark(a) for a in asset_ids} == latest
    import psycopg

    with psycopg.connect(registry.backend.store.postgres_conninfo) as connection:
        assert connection.execute("SELECT count(*) FROM alembic_version").fetchone()[0] == 1


def test_writer_threads_on_postgres(postgres_uri, fits, tmp_path):
    from registry import Registry

    record_from_threads(Registry(postgres_uri, workdir=tmp_path), fits, threads_n=6,
                        fits_each=2)


def test_server_clients_share_advisory_locks_through_the_lock_uri(postgres_uri, monkeypatch):
    """Clients of an ``mlflow server`` lock in the database FLEET_HEALTH_LOCK_URI names."""
    monkeypatch.delenv("FLEET_HEALTH_LOCK_URI", raising=False)
    assert resolve_store("http://mlflow.example:5000").postgres_conninfo is None   # file locks
    monkeypatch.setenv("FLEET_HEALTH_LOCK_URI", postgres_uri.replace("postgresql://",
                                                                      "postgresql+psycopg://"))
    server = resolve_store("http://mlflow.example:5000")
    assert server.postgres_conninfo == postgres_uri and not server.is_postgres
    with resolve_store(postgres_uri).asset_lock("T-01"):
        with pytest.raises(RegistryError, match="could not lock asset 'T-01'"):
            with server.asset_lock("T-01", timeout=0.3):
                pass
    with server.asset_lock("T-01", timeout=5):
        pass
    monkeypatch.setenv("FLEET_HEALTH_LOCK_URI", "mysql://db/locks")
    with pytest.raises(ValueError, match="FLEET_HEALTH_LOCK_URI"):
        resolve_store("http://mlflow.example:5000")


def test_asset_locks_keep_one_connection_and_replace_a_broken_one(postgres_uri):
    """The asset locks of a store are taken on a connection it keeps (one per thread), not a
    new server process per lock; a kept connection that broke while idle is replaced."""
    import threading

    import psycopg

    store = resolve_store(postgres_uri)
    with store.asset_lock("T-01"):
        first = store.advisory._local.connection.info.backend_pid
    with store.asset_locks(["T-02", "T-01"]) as refused:
        assert refused == {}
        assert store.advisory._local.connection.info.backend_pid == first
        other = resolve_store(postgres_uri)       # another holder still waits for both
        with other.asset_locks(["T-01", "T-03"], timeout=0.3) as refused_there:
            assert list(refused_there) == ["T-01"]
        seen = []

        def elsewhere():       # another thread of the same store is another holder too
            try:
                with store.asset_lock("T-02", timeout=0.3):
                    seen.append("held")
            except RegistryError:
                seen.append("refused")

        thread = threading.Thread(target=elsewhere)
        thread.start()
        thread.join()
        assert seen == ["refused"]
    with psycopg.connect(postgres_uri, autocommit=True) as admin:
        admin.execute("SELECT pg_terminate_backend(%s)", (first,))
    with store.asset_lock("T-01", timeout=5):
        assert store.advisory._local.connection.info.backend_pid != first
    with other.asset_lock("T-01", timeout=5):      # released
        pass
