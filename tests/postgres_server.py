"""A throw-away PostgreSQL server for the tests: ``initdb`` + ``pg_ctl`` in a temporary directory.

``initdb`` refuses to run as root, and the tests run as root in CI: then the data directory is
handed to the ``postgres`` system user and every server command runs as that user
(``runuser -u postgres --``). The server listens on 127.0.0.1 on a free port with ``trust``
authentication and keeps its socket in its own directory, so it never meets a system server.
"""
from __future__ import annotations

import os
import pathlib
import shutil
import socket
import subprocess
import tempfile

REPO = pathlib.Path(__file__).resolve().parents[1]
SEARCH_PATHS = ("/usr/lib/postgresql/17/bin", "/usr/lib/postgresql/16/bin",
                "/usr/lib/postgresql/15/bin", "/usr/local/bin", "/usr/bin")
SERVER_USER = "postgres"


def find_initdb() -> pathlib.Path | None:
    """The directory holding ``initdb`` and ``pg_ctl``, or None when PostgreSQL is absent."""
    for directory in SEARCH_PATHS:
        if all(os.access(pathlib.Path(directory, name), os.X_OK) for name in ("initdb", "pg_ctl")):
            return pathlib.Path(directory)
    found = shutil.which("initdb")
    return None if found is None else pathlib.Path(found).parent


def subprocess_env() -> dict:
    """The environment of a child Python that imports this tree."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), env.get("PYTHONPATH")) if p)
    return env


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


class PostgresServer:
    """One PostgreSQL cluster in a temporary directory (start it with :meth:`start`).

    Parameters
    ----------
    bin_dir : pathlib.Path
        Directory of ``initdb`` and ``pg_ctl``.
    """

    def __init__(self, bin_dir: pathlib.Path):
        self.bin_dir = bin_dir
        self.as_root = os.geteuid() == 0
        # under /tmp itself: pytest's own temp dirs are private to root
        self.base = pathlib.Path(tempfile.mkdtemp(prefix="fleet-health-test-pg-"))
        self.data = self.base / "data"
        self.socket_dir = self.base / "socket"
        self.port = free_port()
        self.started = False

    def _run(self, *command: str) -> None:
        prefix = ["runuser", "-u", SERVER_USER, "--"] if self.as_root else []
        done = subprocess.run(prefix + list(command), capture_output=True, text=True, timeout=120)
        if done.returncode != 0:
            log = self.base / "server.log"
            tail = log.read_text()[-3000:] if log.exists() else ""
            raise RuntimeError(f"{' '.join(command)} failed ({done.returncode}):\n"
                               f"{done.stdout}{done.stderr}{tail}")

    def start(self) -> "PostgresServer":
        """Start the server, creating its cluster first unless ``data`` holds one (a
        cluster stopped earlier starts again with its databases)."""
        self.base.mkdir(parents=True, exist_ok=True)
        self.socket_dir.mkdir(exist_ok=True)
        if self.as_root:
            shutil.chown(self.base, SERVER_USER)
            shutil.chown(self.socket_dir, SERVER_USER)
        if not (self.data / "PG_VERSION").exists():
            self._run(str(self.bin_dir / "initdb"), "-D", str(self.data), "-U", SERVER_USER,
                      "--auth=trust", "-E", "UTF8", "--locale=C", "--no-sync")
        options = (f"-p {self.port} -k {self.socket_dir} -c listen_addresses=127.0.0.1 "
                   f"-c fsync=off -c synchronous_commit=off -c full_page_writes=off "
                   f"-c max_connections=200")
        self._run(str(self.bin_dir / "pg_ctl"), "-D", str(self.data), "-o", options,
                  "-l", str(self.base / "server.log"), "-w", "-t", "60", "start")
        self.started = True
        return self

    def uri(self, database: str = "postgres") -> str:
        """``postgresql://postgres@127.0.0.1:<port>/<database>`` (the form users write)."""
        return f"postgresql://{SERVER_USER}@127.0.0.1:{self.port}/{database}"

    def create_database(self, name: str, template: str | None = None) -> str:
        """Create a database (a copy of ``template`` if given); returns its URI."""
        import psycopg
        from psycopg import sql

        statement = sql.SQL("CREATE DATABASE {}").format(sql.Identifier(name))
        if template is not None:
            statement += sql.SQL(" TEMPLATE {}").format(sql.Identifier(template))
        with psycopg.connect(self.uri(), autocommit=True) as connection:
            if template is not None:
                # a template must have no other session (e.g. a pooled MLflow connection)
                connection.execute("SELECT pg_terminate_backend(pid) FROM pg_stat_activity "
                                   "WHERE datname = %s AND pid <> pg_backend_pid()",
                                   (template,))
            connection.execute(statement)
        return self.uri(name)

    def stop(self) -> None:
        """Stop the server (immediately) and remove its directory."""
        try:
            if self.started:
                self._run(str(self.bin_dir / "pg_ctl"), "-D", str(self.data), "-m", "immediate",
                          "-w", "stop")
                self.started = False
        finally:
            shutil.rmtree(self.base, ignore_errors=True)
