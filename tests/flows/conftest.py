"""Fixtures of the flow tests: one small simulated fleet, one Prefect test harness and one
store with promoted baselines per session; a fresh copy of that store per test.

The fleet: 5 gas-turbine vehicles over 6 days at 30 s (2,880 samples a day); T-002 gets a
sensor-noise fault (x4) from the start of day 4 and T-004 blade flutter (nonlinear 0.5) from
the start of day 5. Baselines are fitted on days 1-3; the nights to process are days 4-6.

The fleet and the baselined store are made once per test run: with xdist, the first worker
to need them builds them in the run's shared temporary directory and the other reuses them.
"""
from __future__ import annotations

import atexit
import contextlib
import fcntl
import json
import os
import shutil
import sqlite3
import tempfile

# Prefect reads its settings on import: isolate its home before anything imports it
os.environ["PREFECT_HOME"] = tempfile.mkdtemp(prefix="fleet-health-test-prefect-")
atexit.register(shutil.rmtree, os.environ["PREFECT_HOME"], ignore_errors=True)
os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
os.environ.setdefault("PREFECT_LOGGING_HANDLERS_CONSOLE_LEVEL", "WARNING")
os.environ.setdefault("PREFECT_SERVER_LOGGING_LEVEL", "WARNING")

from types import SimpleNamespace  # noqa: E402

import pandas as pd  # noqa: E402
import pytest  # noqa: E402

pytest.register_assert_rewrite("flowtest_fleet")  # its shared assertions report as a test's

from flowtest_config import write_config  # noqa: E402
from flowtest_store import count_records  # noqa: E402
from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, FAULTY, day  # noqa: E402


@pytest.fixture(scope="session")
def harness():
    """One Prefect test server for the session (it takes seconds to start), its flow runs
    without heartbeats as Prefect's own test profile has them: at a flow's end Prefect joins
    its heartbeat thread, which sleeps in 1-s steps (half a second a flow run, some hundreds
    of runs); no test reads them."""
    from prefect.settings import PREFECT_FLOWS_HEARTBEAT_FREQUENCY, temporary_settings
    from prefect.testing.utilities import prefect_test_harness

    with prefect_test_harness(server_startup_timeout=120), \
            temporary_settings(updates={PREFECT_FLOWS_HEARTBEAT_FREQUENCY: None}):
        yield


@contextlib.contextmanager
def _built_once(tmp_path_factory, worker_id: str, name: str):
    """``with _built_once(...) as (directory, build):`` the directory ``name`` of the test
    run, shared by its xdist workers: ``build`` is True for the one worker that is to fill it
    (it holds a lock meanwhile; the directory counts as built once the block ends without an
    exception), False when another worker has built it. Without xdist, a directory of the
    session's own that is always built."""
    if worker_id == "master":
        yield tmp_path_factory.mktemp(name), True
        return
    root = tmp_path_factory.getbasetemp().parent          # shared by the run's workers
    directory, done = root / name, root / f"{name}.done"
    with open(root / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)                  # released when the file closes
        if done.exists():
            yield directory, False
            return
        shutil.rmtree(directory, ignore_errors=True)      # a failed build's leftovers
        directory.mkdir()
        yield directory, True
        done.write_text("")


@pytest.fixture(scope="session")
def fleet(tmp_path_factory, worker_id):
    """The simulated fleet's telemetry (read-only: copy it before corrupting it); simulated
    once per test run, not once per xdist worker."""
    with _built_once(tmp_path_factory, worker_id, "fleet") as (directory, build):
        root = directory / "telemetry"
        if build:
            from flows.demo import simulated_fleet, write_simulation
            from graybox.simulation import Fault

            faults = [(asset, Fault(kind, onset, magnitude))
                      for asset, (kind, onset, magnitude) in FAULTY.items()]
            spec = simulated_fleet(len(ASSETS), DAYS, seed=7, sample_interval=30.0,
                                   faults=faults)
            write_simulation(spec, root)
    return SimpleNamespace(root=root)


@pytest.fixture(scope="session")
def baselined(tmp_path_factory, worker_id, harness, fleet):
    """A store whose assets all have a promoted baseline of days 1-3 (via the baseline flow;
    run once per test run, not once per xdist worker: the workers share the fleet's
    telemetry, and the flow's summary is kept as JSON)."""
    with _built_once(tmp_path_factory, worker_id, "baselined") as (directory, build):
        db = directory / "mlflow.db"
        if build:
            from flows.baseline import baseline

            config = write_config(directory / "fleet.toml", fleet.root, db, plots="none")
            state = baseline(start=day(0).isoformat(), end=day(BASELINE_DAYS).isoformat(),
                             config_path=str(config), vehicle_class="turbine", promote=True,
                             reason="healthy days 1-3", return_state=True)
            assert state.is_completed(), state.message
            (directory / "summary.json").write_text(json.dumps(state.result()))
            connection = sqlite3.connect(db)
            connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
            connection.close()
    summary = json.loads((directory / "summary.json").read_text())
    return SimpleNamespace(db=db, summary=summary, directory=directory)


@pytest.fixture
def workspace(tmp_path, baselined, fleet):
    """A fresh copy of the baselined store, a fleet.toml and an alerts file for one test."""
    store = tmp_path / "store"
    store.mkdir()
    shutil.copy(baselined.db, store / "mlflow.db")
    config = write_config(tmp_path / "fleet.toml", fleet.root, store / "mlflow.db")

    def configure(**kwargs):
        return write_config(tmp_path / "fleet.toml", kwargs.pop("telemetry", fleet.root),
                            store / "mlflow.db", **kwargs)

    def registry():
        from registry import Registry

        return Registry(f"sqlite:///{store / 'mlflow.db'}")

    return SimpleNamespace(path=tmp_path, config=config, db=store / "mlflow.db",
                           uri=f"sqlite:///{store / 'mlflow.db'}", configure=configure,
                           registry=registry, alerts=tmp_path / "alerts.jsonl")


@pytest.fixture
def corrupt(tmp_path, fleet):
    """``corrupt(asset, day_index, how)``: a copy of the telemetry with one file broken
    (``"nan"``: a NaN shaft speed in row 100; ``"backward"``: row 200's timestamp before row
    199's). Returns (telemetry root, the broken file)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)

    def apply(asset: str, day_index: int, how: str = "inf"):
        path = (root / f"asset_id={asset}" / f"date={day(day_index):%Y-%m-%d}"
                / "part-0.parquet")
        frame = pq.read_table(path).to_pandas()
        if how == "inf":   # a corrupt value (a missing one, NaN, is interpolated)
            frame.loc[100, "shaft_speed"] = float("inf")
        elif how == "backward":
            frame.loc[200, "timestamp"] = frame.loc[199, "timestamp"] - pd.Timedelta(seconds=5)
        else:
            raise ValueError(how)
        pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), path)
        return root, path

    return apply


@pytest.fixture
def count():
    """``count(registry)``: active runs, model versions and registry alerts of a store."""
    return count_records


@pytest.fixture
def config_writer():
    """:func:`write_config`, for a test that needs several fleet.toml files."""
    return write_config
