"""A Prefect server for a benchmark's runs, and the CPU of a process tree.

Production runs its flows on a running Prefect server (the ``serve`` deployment); the
command line starts a temporary one per command unless ``PREFECT_API_URL`` names one. The
benchmarks that measure either way start the server here (:class:`PrefectServer`) and count
its CPU (:func:`tree_cpu`), which no measured child process includes.
"""
from __future__ import annotations

import os
import pathlib
import signal
import socket
import subprocess
import sys
import time
import urllib.request


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def process_cpu(pid: int) -> float:
    """CPU seconds of a process and its reaped children (0 when it is gone)."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            fields = stat.read().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    # after "pid (comm)": fields 11-14 of the rest are utime, stime, cutime, cstime
    return sum(int(x) for x in fields[11:15]) / os.sysconf("SC_CLK_TCK")


def tree_cpu(pid: int) -> float:
    """CPU seconds of a process, its reaped children and its live descendants."""
    children = pathlib.Path(f"/proc/{pid}/task/{pid}/children")
    try:
        kids = [int(k) for k in children.read_text().split()]
    except OSError:
        kids = []
    return process_cpu(pid) + sum(tree_cpu(k) for k in kids)



class PrefectServer:
    """``prefect server start`` on the database at ``database_url`` (SQLite or PostgreSQL),
    for every run of a benchmark: the runs start no temporary server of their own."""

    def __init__(self, root: pathlib.Path, database_url: str):
        self.port = free_port()
        self.api_url = f"http://127.0.0.1:{self.port}/api"
        self.env = dict(os.environ, PREFECT_HOME=str(root / ".prefect-server"),
                        PREFECT_API_DATABASE_CONNECTION_URL=database_url,
                        PREFECT_SERVER_ANALYTICS_ENABLED="false", PREFECT_UI_ENABLED="false")
        self.env.pop("PREFECT_API_URL", None)
        self.log = root / "prefect-server.log"
        self.process: subprocess.Popen | None = None

    def start(self) -> "PrefectServer":
        prefect = pathlib.Path(sys.executable).parent / "prefect"
        self.process = subprocess.Popen(
            [str(prefect), "server", "start", "--host", "127.0.0.1", "--port", str(self.port)],
            env=self.env, stdout=self.log.open("w"), stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            try:
                with urllib.request.urlopen(f"{self.api_url}/health", timeout=2) as answer:
                    if answer.status == 200:
                        return self
            except OSError:
                pass
            if self.process.poll() is not None:
                break
            time.sleep(0.5)
        raise RuntimeError(f"the Prefect server did not start; see {self.log}")

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
