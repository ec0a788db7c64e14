"""Exclusive locks the registry and the flows hold: a ``flock`` on a file (one machine), and a
PostgreSQL advisory lock (every machine using the database). See
:mod:`registry.store.tracking_store` for which lock guards what.
"""
from __future__ import annotations

import contextlib
import fcntl
import hashlib
import logging
import os
import pathlib
import threading
import time
from typing import Iterator

from registry.exceptions import RegistryError

logger = logging.getLogger(__name__)


def advisory_key(name: str) -> int:
    """The signed 64-bit key of a PostgreSQL advisory lock named ``name``."""
    return int.from_bytes(hashlib.sha256(name.encode()).digest()[:8], "big", signed=True)


def _connect(conninfo: str, what: str):
    import psycopg

    try:
        return psycopg.connect(conninfo, autocommit=True, connect_timeout=30)
    except psycopg.OperationalError as error:
        raise ConnectionError(f"could not connect to PostgreSQL to lock {what}: "
                              f"{error}") from error


def _lock(connection, key: int, timeout: float, what: str) -> None:
    import psycopg

    connection.execute("SELECT set_config('lock_timeout', %s, false)",
                       (f"{max(1, int(timeout * 1000))}ms",))
    try:
        connection.execute("SELECT pg_advisory_lock(%s)", (key,))
    except psycopg.errors.LockNotAvailable:
        raise RegistryError(f"could not lock {what} within {timeout:g} s "
                            f"(PostgreSQL advisory lock {key})") from None


@contextlib.contextmanager
def advisory_lock(conninfo: str, name: str, timeout: float = 120.0,
                  what: str | None = None) -> Iterator[None]:
    """An exclusive PostgreSQL advisory lock, held on a connection of its own.

    The wait is bounded by ``lock_timeout``; the lock goes with the connection, so a
    holder that dies releases it. (:class:`AdvisoryLocks` keeps its connection for the
    next lock.)

    Raises
    ------
    RegistryError
        If the lock is not acquired within ``timeout`` seconds.
    ConnectionError
        If the database cannot be reached (a transient error: the flows retry the batch).
    """
    import psycopg

    key = advisory_key(name)
    connection = _connect(conninfo, what or name)
    with connection:
        _lock(connection, key, timeout, what or name)
        try:
            yield
        finally:
            try:
                connection.execute("SELECT pg_advisory_unlock(%s)", (key,))
            except psycopg.Error:     # a broken connection: closing it releases the lock
                logger.warning("could not release advisory lock %d (%s); the connection's "
                               "end releases it", key, what or name)


class AdvisoryLocks:
    """Exclusive PostgreSQL advisory locks taken on a kept connection: one per thread (and
    process), opened on first use and kept for the next lock, instead of a new connection
    (a new server process) per lock.

    Two threads, two processes or two instances exclude each other as with
    :func:`advisory_lock`; one thread taking a lock it holds already is granted it (a
    session's advisory locks count). The wait is bounded by ``lock_timeout``; a holder that
    dies releases its locks with its connection; a kept connection found broken is replaced
    once (a lock is never taken on a connection that broke since: its locks went with it).
    Pickling keeps only the database's address.
    """

    def __init__(self, conninfo: str):
        self.conninfo = conninfo
        self._local = threading.local()

    def __getstate__(self):
        return {"conninfo": self.conninfo}

    def __setstate__(self, state):
        self.__init__(state["conninfo"])

    def _connection(self, what: str):
        local = self._local
        connection = getattr(local, "connection", None)
        if connection is None or connection.closed or local.pid != os.getpid():
            connection = _connect(self.conninfo, what)
            local.connection, local.pid, local.held = connection, os.getpid(), 0
        return connection

    def _drop(self) -> None:
        connection = getattr(self._local, "connection", None)
        self._local.connection = None
        if connection is not None and self._local.pid == os.getpid():
            try:
                connection.close()
            except Exception:  # noqa: BLE001 - already broken
                pass

    @contextlib.contextmanager
    def hold(self, name: str, timeout: float = 120.0, what: str | None = None
             ) -> Iterator[None]:
        """Hold the lock ``name`` (see :func:`advisory_lock` for the errors)."""
        import psycopg

        what = what or name
        key = advisory_key(name)
        connection = self._connection(what)
        try:
            _lock(connection, key, timeout, what)
        except psycopg.OperationalError:
            if self._local.held:          # its other locks are gone with it: say so
                self._drop()
                raise ConnectionError(f"the connection holding PostgreSQL advisory locks "
                                      f"broke while locking {what}") from None
            self._drop()                  # a kept connection that broke while idle
            connection = self._connection(what)
            try:
                _lock(connection, key, timeout, what)
            except psycopg.OperationalError as error:
                self._drop()
                raise ConnectionError(f"could not lock {what} in PostgreSQL: "
                                      f"{error}") from error
        self._local.held += 1
        try:
            yield
        finally:
            self._local.held -= 1
            try:
                connection.execute("SELECT pg_advisory_unlock(%s)", (key,))
            except psycopg.Error:     # a broken connection: closing it releases the lock
                logger.warning("could not release advisory lock %d (%s); closing its "
                               "connection releases it", key, what)
                self._drop()


@contextlib.contextmanager
def file_lock(path: pathlib.Path, timeout: float = 120.0, what: str | None = None) -> Iterator[None]:
    """An exclusive ``flock`` on ``path`` (created if needed), polled until ``timeout``.

    ``flock`` locks belong to the open file, so two threads of one process exclude each
    other as two processes do.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    deadline = time.monotonic() + timeout
    with open(path, "a+") as handle:
        delay = 0.005
        while True:
            try:
                fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() > deadline:
                    raise RegistryError(f"could not lock {what or path} within {timeout:g} s "
                                        f"(lock file {path})") from None
                time.sleep(delay)
                delay = min(0.1, delay * 2)
        try:
            yield
        finally:
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)


