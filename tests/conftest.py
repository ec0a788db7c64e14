"""Fixtures shared by every test package: a real PostgreSQL server for the session, and a
fresh database with MLflow's schema per test."""
from __future__ import annotations

import itertools
import os
import subprocess
import sys

import pytest

from postgres_server import REPO, PostgresServer, find_initdb, subprocess_env

MLFLOW_TEMPLATE = "mlflow_template"
_databases = itertools.count()


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
