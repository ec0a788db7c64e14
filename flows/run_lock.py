"""One run at a time per fleet: the run lock.

Every flow (``nightly``, ``baseline``, ``reanalyze``) holds an exclusive lock on the fleet's
tracking store for its whole body: ``fleet-run.lock`` in the store's lock directory
(:func:`registry.store.locks.file_lock`; beside the SQLite file, or in the user's cache for a
server). A second run of the same fleet started meanwhile (a manual ``run`` while the
scheduled one works) waits for it, at most ``$FLEET_HEALTH_RUN_LOCK_WAIT`` seconds (default
:data:`DEFAULT_LOCK_WAIT`), saying whom it waits for; then it finds the windows the first
run committed and does not fit them again. If the wait runs out, it stops with
:class:`RunLockTimeout` (nothing done) naming the holder.

The holder writes ``fleet-run.json`` beside the lock (its flow, flow run id, pid, host,
start) and removes it when it finishes. A ``flock`` dies with its process, so a run that
acquires the lock and still finds that file knows its writer was killed: that flow run is
orphaned and :mod:`flows.orphans` marks it Crashed.
"""
from __future__ import annotations

import contextlib
import json
import logging
import os
import pathlib
import socket
import threading
import time
from dataclasses import asdict, dataclass
from typing import Iterator

from flows.env_seconds import env_seconds
from flows.results import now_iso
from registry import RegistryError, file_lock, resolve_store
from flows.errors import RunLockTimeout
from flows.run_logger import run_logger

logger = logging.getLogger(__name__)

LOCK_WAIT_ENV = "FLEET_HEALTH_RUN_LOCK_WAIT"
DEFAULT_LOCK_WAIT = 900.0
LOCK_NAME, HOLDER_NAME = "fleet-run.lock", "fleet-run.json"


@dataclass(frozen=True)
class Holder:
    """Who holds (or held) the run lock."""

    flow: str
    flow_run_id: str | None
    pid: int
    host: str
    started: str

    def describe(self) -> str:
        run = f"flow run {self.flow_run_id}, " if self.flow_run_id else ""
        return f"the {self.flow} run ({run}pid {self.pid} on {self.host}, since {self.started})"


@dataclass
class RunLock:
    """The run lock of one fleet: where it is, and what acquiring it found.

    Attributes
    ----------
    directory : pathlib.Path
        The store's lock directory.
    waited_seconds : float
        How long the run waited for another one.
    waited_for : Holder or None
        The run it waited for.
    orphan : Holder or None
        A holder that died without releasing cleanly (its file was left behind).
    """

    directory: pathlib.Path
    waited_seconds: float = 0.0
    waited_for: Holder | None = None
    orphan: Holder | None = None

    @classmethod
    def of(cls, tracking_uri: str) -> "RunLock":
        return cls(resolve_store(tracking_uri).lock_dir)

    @property
    def path(self) -> pathlib.Path:
        return self.directory / LOCK_NAME

    @property
    def holder_path(self) -> pathlib.Path:
        return self.directory / HOLDER_NAME

    def holder(self) -> Holder | None:
        """The holder file's content (None when absent or unreadable)."""
        try:
            return Holder(**json.loads(self.holder_path.read_text()))
        except FileNotFoundError:
            return None
        except (ValueError, TypeError) as error:
            run_logger(logger).warning("run lock: unreadable %s (%s): ignored",
                                       self.holder_path, error)
            return None

    def is_held(self) -> bool:
        """Whether a live process holds the lock now (tried without waiting)."""
        try:
            with file_lock(self.path, timeout=0):
                return False
        except RegistryError:
            return True

    @contextlib.contextmanager
    def hold(self, flow: str, flow_run_id: str | None = None,
             wait: float | None = None) -> Iterator["RunLock"]:
        """Hold the lock for a run of ``flow``; wait at most ``wait`` seconds for it.

        Raises
        ------
        RunLockTimeout
            When another run still holds it after ``wait`` seconds.
        """
        wait = lock_wait() if wait is None else wait
        started = time.monotonic()
        stop_telling = threading.Event()
        teller = threading.Thread(target=self._tell_waiting, args=(flow, stop_telling),
                                  daemon=True)
        teller.start()
        with contextlib.ExitStack() as stack:
            try:
                stack.enter_context(file_lock(self.path, timeout=wait,
                                              what=f"the fleet's run lock ({flow})"))
            except RegistryError:
                holder = self.holder()
                raise RunLockTimeout(
                    f"{holder.describe() if holder else 'another run'} of this fleet still "
                    f"holds its run lock ({self.path}) after {wait:g} s: nothing was run. "
                    f"Rerun when it has finished (or raise ${LOCK_WAIT_ENV})") from None
            finally:
                stop_telling.set()
                teller.join()
            self.waited_seconds = round(time.monotonic() - started, 1)
            self.orphan = self.holder()
            self._write_holder(Holder(flow, flow_run_id, os.getpid(), socket.gethostname(),
                                      now_iso()))
            try:
                yield self
            finally:
                self.holder_path.unlink(missing_ok=True)

    def _tell_waiting(self, flow: str, stop: threading.Event) -> None:
        """Say once whom the run waits for, if it waits more than a moment."""
        if stop.wait(0.5):
            return
        holder = self.holder()
        self.waited_for = holder
        run_logger(logger).warning("fleet-health %s: waiting for %s of this fleet to finish "
                                   "(run lock %s)", flow,
                                   holder.describe() if holder else "another run", self.path)

    def _write_holder(self, holder: Holder) -> None:
        temporary = self.holder_path.with_suffix(".tmp")
        temporary.write_text(json.dumps(asdict(holder)))
        temporary.replace(self.holder_path)

    def to_dict(self) -> dict:
        """What the run summary records (``extra["run_lock"]``)."""
        return {"lock": str(self.path), "waited_seconds": self.waited_seconds,
                "waited_for": None if self.waited_for is None else asdict(self.waited_for),
                "orphan": None if self.orphan is None else asdict(self.orphan)}


def lock_wait() -> float:
    """Seconds a run waits for the lock (``$FLEET_HEALTH_RUN_LOCK_WAIT``)."""
    return env_seconds(LOCK_WAIT_ENV, DEFAULT_LOCK_WAIT, RunLockTimeout)
