"""Prefect's temporary local server for one command: said on stderr, and started while the
flow's code loads.

Without a Prefect server (``PREFECT_API_URL`` unset), Prefect starts one in a child process at
the flow's first API call and waits for it to answer: about 4 s on 2 cores, in which the
command does nothing else. :meth:`TemporaryServer.start`, called before the flow's modules are
imported, starts the same server (Prefect keeps one per process, so the flow finds it
running) in a thread, and the child boots on the other core while this process imports the
flow; :meth:`TemporaryServer.wait` is called before the flow runs, and the flow runs within
:meth:`TemporaryServer.flow_settings` (no flow-run heartbeats on a server that stops with the
command).
"""
from __future__ import annotations

import contextlib
import contextvars
import sys
import threading

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
    before the flow's modules are imported, :meth:`wait` before the flow runs, and run the
    flow within :meth:`flow_settings`. With a server set (``PREFECT_API_URL``) all three do
    nothing.
    """

    def __init__(self) -> None:
        self._starting: threading.Thread | None = None
        self._error: BaseException | None = None

    def start(self, announce: bool = True) -> "TemporaryServer":
        """Say that a temporary server starts (:data:`TEMPORARY_SERVER_HINT`, unless not
        ``announce``: the demo, whose runs always go to a server of its own) and start it in
        a thread; return self."""
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
            Prefect's own, when the server did not answer within
            ``PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS``.
        """
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
        if temporary_server_hint() is None:
            return contextlib.nullcontext()
        from prefect.settings import PREFECT_FLOWS_HEARTBEAT_FREQUENCY, temporary_settings

        return temporary_settings(updates={PREFECT_FLOWS_HEARTBEAT_FREQUENCY: None})
