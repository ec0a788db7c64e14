"""Prefect's temporary local server for one command: said on stderr, and started while the
flow's code loads.

Without a Prefect server (``PREFECT_API_URL`` unset), Prefect starts one in a child process at
the flow's first API call and waits for it to answer: about 4 s on 2 cores, in which the
command does nothing else. :meth:`TemporaryServer.start`, called before the flow's modules are
imported, starts the same server (Prefect keeps one per process, so the flow finds it
running) in a thread, and the child boots on the other core while this process imports the
flow; :meth:`TemporaryServer.wait` is called before the flow runs.
"""
from __future__ import annotations

import concurrent.futures
import contextvars
import sys

#: said on stderr when a flow runs without a Prefect server (PREFECT_API_URL unset)
TEMPORARY_SERVER_HINT = (
    "fleet-health: no Prefect server set: starting a temporary one for this run (10-30 s); "
    "to skip it, run `prefect server start` once and export "
    "PREFECT_API_URL=http://127.0.0.1:4200/api")


def temporary_server_hint() -> str | None:
    """:data:`TEMPORARY_SERVER_HINT` when Prefect will start a temporary local server (no
    API URL in the environment or the active Prefect profile); None otherwise."""
    from prefect.settings import PREFECT_API_URL

    return None if PREFECT_API_URL.value() else TEMPORARY_SERVER_HINT


class TemporaryServer:
    """The temporary server of one command, if it needs one.

    Call :meth:`start` after Prefect's environment is set (``prefect_environment``) and
    before the flow's modules are imported, and :meth:`wait` before the flow runs. With a
    server set (``PREFECT_API_URL``) both do nothing.
    """

    def __init__(self) -> None:
        self._starting: concurrent.futures.Future | None = None

    def start(self) -> "TemporaryServer":
        """Say that a temporary server starts (:data:`TEMPORARY_SERVER_HINT`) and start it in
        a thread; return self."""
        if temporary_server_hint() is None:
            return self
        print(TEMPORARY_SERVER_HINT, file=sys.stderr)
        # imported by the caller's thread, not the pool's: two threads importing at once can
        # see a module half initialised
        from prefect.server.api.server import SubprocessASGIServer

        server = SubprocessASGIServer()
        pool = concurrent.futures.ThreadPoolExecutor(
            max_workers=1, thread_name_prefix="prefect-temporary-server")
        # the thread reads Prefect's settings (the start-up timeout) from this context
        self._starting = pool.submit(contextvars.copy_context().run, server.start)
        pool.shutdown(wait=False)
        return self

    def wait(self) -> None:
        """Return once the server answers.

        Raises
        ------
        RuntimeError
            Prefect's own, when the server did not answer within
            ``PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS``.
        """
        if self._starting is not None:
            self._starting.result()
