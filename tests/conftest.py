"""Fixtures shared by every test package: a real PostgreSQL server for the session, and a
fresh database with MLflow's schema per test; and the order in which the two xdist workers
take the test files."""
from __future__ import annotations

import itertools
import os
import subprocess
import sys
import warnings

import pytest

from postgres_server import REPO, PostgresServer, find_initdb, subprocess_env

MLFLOW_TEMPLATE = "mlflow_template"
_databases = itertools.count()

#: the test files that take longest (each 10-180 s of one worker on 2 cores, measured with
#: ``pytest -n 2 --dist loadfile --durations=0``, longest first): ``make test`` runs with
#: ``--no-loadscope-reorder``, so that xdist hands out whole files in collection order and
#: these go first (longest-first scheduling), the many short files filling both workers up
#: at the end instead of one of these keeping one worker busy after the other has finished
#: (xdist's own order is by number of tests, which put the one-test benchmarks last)
LONGEST_FIRST = (
    "tests/benchmarks/test_zoo.py",
    "tests/flows/test_fault_matrix.py",
    "tests/benchmarks/test_dask_scale.py",
    "tests/flows/test_postgres_flows.py",
    "tests/benchmarks/test_nightly_scale.py",
    "tests/flows/test_fault_telemetry.py",
    "tests/flows/test_cli.py",
    "tests/flows/test_memory.py",
    "tests/benchmarks/test_skab_benchmark.py",
    "tests/flows/test_dask.py",
    "tests/benchmarks/test_progpy_false_alarms.py",
    "tests/flows/test_demo.py",
    "tests/flows/test_progpy_fleet.py",
    "tests/flows/test_nightly.py",
    "tests/benchmarks/test_detection_benchmark.py",
    "tests/registry/test_mlflow_server.py",
    "tests/registry/test_postgres_store.py",
    "tests/graybox/test_simulator_rates.py",
    "tests/flows/test_calm_nights.py",
    "tests/graybox/models/test_progpy.py",
)


#: the test files that use the session's PostgreSQL server: ``--dist loadfile`` gives them
#: to one worker as one unit (:func:`pytest_xdist_make_scheduler`), so that the server
#: (initdb, and MLflow's migrations in a child) starts once per test run, not on both
#: workers
POSTGRES_FILES = (
    "tests/flows/test_postgres_flows.py",
    "tests/registry/test_postgres_store.py",
    "tests/registry/test_sql_writes.py",
)


def pytest_collection_modifyitems(config, items):
    """The files of :data:`LONGEST_FIRST` first, in its order; the others after them in
    collection order (a stable sort: the tests of a file keep their order). A warning names
    a file that uses the PostgreSQL server but is missing from :data:`POSTGRES_FILES`."""
    rank = {path: i for i, path in enumerate(LONGEST_FIRST)}
    root = config.rootpath

    def relative(item):
        try:
            return item.path.relative_to(root).as_posix()
        except ValueError:
            return str(item.path)

    items.sort(key=lambda item: rank.get(relative(item), len(rank)))
    unlisted = sorted({relative(item) for item in items if "postgres_server" in
                       item.fixturenames} - set(POSTGRES_FILES))
    if unlisted:
        warnings.warn(pytest.PytestWarning(
            f"add {unlisted} to POSTGRES_FILES (tests/conftest.py): with xdist, each worker "
            "that runs one starts a PostgreSQL server of its own"))


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile`` with the files of :data:`POSTGRES_FILES` as one unit."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class Scheduling(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            path = super()._split_scope(nodeid)
            return POSTGRES_FILES[0] if path in POSTGRES_FILES else path

    return Scheduling(config, log)


@pytest.fixture(scope="session")
def postgres_server():
    """A PostgreSQL server of our own for the session (stopped and removed at the end)."""
    bin_dir = find_initdb()
    if bin_dir is None:
        pytest.fail("PostgreSQL's initdb/pg_ctl not found: install it (apt-get install -y "
                    "postgresql; .ci/run does so on CI)")
    server = PostgresServer(bin_dir)
    try:
        server.start()
        # MLflow's schema, created once (its migrations take seconds) by a child process, so
        # no connection of ours stays open on the template database
        template = server.create_database(MLFLOW_TEMPLATE)
        subprocess.run([sys.executable, "-c", "import sys; from registry import Registry; "
                        "Registry(sys.argv[1])", template], check=True, env=subprocess_env(),
                       cwd=REPO, timeout=300)
        yield server
    finally:
        server.stop()


@pytest.fixture
def postgres_uri(postgres_server) -> str:
    """A new database with MLflow's schema, for one test (``postgresql://...``)."""
    name = f"test_{os.getpid()}_{next(_databases)}"
    return postgres_server.create_database(name, template=MLFLOW_TEMPLATE)
