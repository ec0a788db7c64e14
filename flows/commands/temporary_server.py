"""Prefect's temporary local server for one command: said on stderr, and started while the
flow's code loads.

Without a Prefect server (``PREFECT_API_URL`` unset), Prefect starts one in a child process at
the flow's first API call and waits for it to answer: about 4 s on 2 cores, in which the
command does nothing else. :meth:`TemporaryServer.start`, called before the flow's modules are
imported, starts that server's child at once, and it boots on the other core while this
process imports the flow; :meth:`TemporaryServer.wait` is called before the flow runs, and the
flow runs within :meth:`TemporaryServer.flow_settings` (no flow-run heartbeats on a server that
stops with the command).

Where it is certain, before Prefect is imported, that no server is set
(:func:`no_server_set`), the child is started here, the way Prefect starts it (``uvicorn`` on
Prefect's ``create_app``, no UI), on a socket this process binds (no race for the port), and
``PREFECT_API_URL`` names it before Prefect reads its settings: Prefect then never imports its
server's modules in this process, about 2.3 s of CPU that only the child needs
(docs/performance.md, "The temporary server's child started by the command"). Otherwise (a
profile or settings file that may set a server, Prefect already imported) Prefect's own
``SubprocessASGIServer`` is started in a thread, as before; Prefect keeps one per process, so
the flow finds it running.
"""
from __future__ import annotations

import atexit
import contextlib
import contextvars
import importlib.util
import os
import pathlib
import socket
import subprocess
import sys
import threading
import time
import tomllib
import urllib.error
import urllib.request
from typing import Mapping

#: said on stderr when a flow runs without a Prefect server (PREFECT_API_URL unset)
TEMPORARY_SERVER_HINT = (
    "fleet-health: no Prefect server set: starting a temporary one for this run (10-30 s); "
    "to skip it, run `prefect server start` once and export "
    "PREFECT_API_URL=http://127.0.0.1:4200/api")
#: the start of the error a temporary server that does not answer in time raises (Prefect's
#: own words, which the command line turns into one line and exit status 3)
STARTUP_TIMEOUT_MESSAGE = "Timed out while attempting to connect to ephemeral Prefect API"
#: seconds Prefect waits for its temporary server by default
#: (``PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS``)
PREFECT_STARTUP_TIMEOUT = 20.0
#: environment variables that point Prefect at a server or other settings than the ones read
#: here, or that decide whether it may start a temporary server at all
SETTINGS_POINTERS = ("PREFECT_API_URL", "PREFECT_PROFILE", "PREFECT_PROFILES_PATH",
                     "PREFECT_SERVER_ALLOW_EPHEMERAL_MODE", "PREFECT_SERVER_EPHEMERAL_ENABLED")
#: the profile Prefect keeps active by default: no server, a temporary one per process
EPHEMERAL_PROFILE = "ephemeral"


def temporary_server_hint() -> str | None:
    """:data:`TEMPORARY_SERVER_HINT` when Prefect will start a temporary local server (no
    API URL in the environment or the active Prefect profile); None otherwise."""
    from prefect.settings import PREFECT_API_URL

    return None if PREFECT_API_URL.value() else TEMPORARY_SERVER_HINT


def no_server_set(environ: Mapping[str, str], directory: pathlib.Path) -> bool:
    """Whether Prefect, once imported, will find no server set, decided without importing it.

    True only where certain: none of :data:`SETTINGS_POINTERS` in ``environ``; a profiles
    file (``$PREFECT_HOME/profiles.toml``, default ``~/.prefect``) that is absent or keeps
    Prefect's ``ephemeral`` profile active and names no ``PREFECT_API_URL`` (Prefect's own
    ``local`` and ``cloud`` profiles name a server without the user's file saying so); in
    ``directory`` (where Prefect looks for settings files) no ``prefect.toml``, no
    ``[tool.prefect]`` in ``pyproject.toml`` and no ``PREFECT_`` line in ``.env``. Anything
    else may set a server: False, and Prefect decides.
    """
    if any(environ.get(name) for name in SETTINGS_POINTERS):
        return False
    home = pathlib.Path(environ.get("PREFECT_HOME") or "~/.prefect").expanduser()
    try:
        profiles = home / "profiles.toml"
        if profiles.is_file():
            text = profiles.read_text(errors="replace")
            if "PREFECT_API_URL" in text or tomllib.loads(text).get(
                    "active", EPHEMERAL_PROFILE) != EPHEMERAL_PROFILE:
                return False
        if (directory / "prefect.toml").exists():
            return False
        return not any(path.is_file() and word in path.read_text(errors="replace")
                       for path, word in ((directory / "pyproject.toml", "tool.prefect"),
                                          (directory / ".env", "PREFECT_")))
    except (OSError, tomllib.TOMLDecodeError):  # unreadable: Prefect's own reading decides
        return False


class TemporaryServer:
    """The temporary server of one command, if it needs one.

    Call :meth:`start` after Prefect's environment is set (``prefect_environment``) and
    before the flow's modules are imported, :meth:`wait` before the flow runs, and run the
    flow within :meth:`flow_settings`. With a server set (``PREFECT_API_URL``) all three do
    nothing.
    """

    def __init__(self) -> None:
        self._starting: threading.Thread | None = None
        self._error: BaseException | None = None
        self._child: subprocess.Popen | None = None
        self._url: str | None = None

    def start(self, announce: bool = True) -> "TemporaryServer":
        """Say that a temporary server starts (:data:`TEMPORARY_SERVER_HINT`, unless not
        ``announce``: the demo, whose runs always go to a server of its own) and start it;
        return self. The child is started here where :func:`no_server_set` is certain
        (before Prefect is imported), else Prefect's own in a thread."""
        if "prefect" not in sys.modules and os.name == "posix" and no_server_set(
                os.environ, pathlib.Path.cwd()):
            if announce:
                print(TEMPORARY_SERVER_HINT, file=sys.stderr)
            self._child, self._url = _start_child(os.environ)
            atexit.register(_stop, self._child)
            # read by Prefect when it is imported: every client of this process (and a Dask
            # worker it starts) talks to the child
            os.environ["PREFECT_API_URL"] = self._url
            return self
        if temporary_server_hint() is None:
            return self
        if announce:
            print(TEMPORARY_SERVER_HINT, file=sys.stderr)
        # imported by the caller's thread, not the starting one: two threads importing at once can
        # see a module half initialised
        from prefect.server.api.server import SubprocessASGIServer

        # a daemon: a command that fails before its flow runs exits at once (Prefect stops
        # the child at exit); the thread reads Prefect's settings (the start-up timeout)
        # from this context
        self._starting = threading.Thread(
            target=self._start, args=(contextvars.copy_context(), SubprocessASGIServer()),
            name="prefect-temporary-server", daemon=True)
        self._starting.start()
        return self

    def _start(self, context: contextvars.Context, server) -> None:
        try:
            context.run(server.start)
        except BaseException as error:  # noqa: BLE001 - raised by wait(), in the caller's thread
            self._error = error

    def wait(self) -> None:
        """Return once the server answers.

        Raises
        ------
        RuntimeError
            :data:`STARTUP_TIMEOUT_MESSAGE` (Prefect's own, when it started the server), when
            the server did not answer within ``PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS``.
        """
        if self._child is not None:
            _wait_until_healthy(self._child, self._url, float(os.environ.get(
                "PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS", PREFECT_STARTUP_TIMEOUT)))
        if self._starting is not None:
            self._starting.join()
        if self._error is not None:
            raise self._error

    def flow_settings(self) -> contextlib.AbstractContextManager:
        """Prefect's settings for a flow run on this command's temporary server: no flow-run
        heartbeats (Prefect's default since 3.8 is one every 180 s).

        Heartbeats serve a server's automation that marks a silent run crashed; a server
        that stops with the command runs none. And at the flow's end Prefect joins its
        heartbeat thread, which sleeps in 1-s steps: up to a second more per flow run. With a
        server set, Prefect's own setting holds.
        """
        if self._child is None and temporary_server_hint() is None:
            return contextlib.nullcontext()
        from prefect.settings import PREFECT_FLOWS_HEARTBEAT_FREQUENCY, temporary_settings

        return temporary_settings(updates={PREFECT_FLOWS_HEARTBEAT_FREQUENCY: None})


def _start_child(environ: Mapping[str, str]) -> tuple[subprocess.Popen, str]:
    """Prefect's temporary server started as Prefect starts it (``SubprocessASGIServer``:
    ``uvicorn`` on ``create_app``, no UI), on a socket bound here and handed over; the child
    and its API URL."""
    spec = importlib.util.find_spec("prefect")      # found, not imported
    site = pathlib.Path(spec.origin).parent.parent
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
        child = subprocess.Popen(
            [sys.executable, "-m", "uvicorn", "--app-dir", str(site), "--factory",
             "prefect.server.api.server:create_app", "--fd", str(sock.fileno()),
             "--log-level", "error", "--lifespan", "on"],
            env={**environ, "PREFECT_UI_ENABLED": "0", "PREFECT__SERVER_EPHEMERAL": "1",
                 "PREFECT__SERVER_FINAL": "1"},
            pass_fds=(sock.fileno(),))
    return child, f"http://127.0.0.1:{port}/api"


def _wait_until_healthy(child: subprocess.Popen, url: str, timeout: float) -> None:
    """Poll the child's health endpoint until it answers; RuntimeError when it has not
    within ``timeout`` seconds or has exited."""
    deadline = time.monotonic() + timeout
    # the loopback address, never through a proxy of the environment
    opener = urllib.request.build_opener(urllib.request.ProxyHandler({}))
    while True:
        if child.poll() is not None:
            raise RuntimeError(f"{STARTUP_TIMEOUT_MESSAGE} server: its process exited with "
                               f"code {child.returncode}.")
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise RuntimeError(f"{STARTUP_TIMEOUT_MESSAGE} server at {url}.")
        try:
            with opener.open(f"{url}/health", timeout=min(remaining, 2.0)) as response:
                if response.status == 200:
                    return
        except (OSError, urllib.error.URLError):      # not listening yet, or still booting
            pass
        time.sleep(min(0.1, max(deadline - time.monotonic(), 0.0)))


def _stop(child: subprocess.Popen) -> None:
    """Stop the child at this process's exit (Prefect's own server stops the same way)."""
    if child.poll() is None:
        child.terminate()
        try:
            child.wait(timeout=10)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
