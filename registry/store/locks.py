"""Exclusive locks the registry and the flows hold: a ``flock`` on a file (one machine), and a
PostgreSQL advisory lock (every machine using the database). See
:mod:`registry.store.tracking_store` for which lock guards what.
"""
from __future__ import annotations

import contextlib
import fcntl
import hashlib
import logging
import pathlib
import time
from typing import Iterator

from registry.exceptions import RegistryError

logger = logging.getLogger(__name__)


def advisory_key(name: str) -> int:
    """The signed 64-bit key of a PostgreSQL advisory lock named ``name``."""
    return int.from_bytes(hashlib.sha256(name.encode()).digest()[:8], "big", signed=True)


@contextlib.contextmanager
def advisory_lock(conninfo: str, name: str, timeout: float = 120.0,
                  what: str | None = None) -> Iterator[None]:
    """An exclusive PostgreSQL advisory lock, held on a connection of its own.

    The wait is bounded by ``lock_timeout``; the lock goes with the connection, so a
    holder that dies releases it.

    Raises
    ------
    RegistryError
        If the lock is not acquired within ``timeout`` seconds.
    ConnectionError
        If the database cannot be reached (a transient error: the flows retry the batch).
    """
    import psycopg

    key = advisory_key(name)
    try:
        connection = psycopg.connect(conninfo, autocommit=True, connect_timeout=30)
    except psycopg.OperationalError as error:
        raise ConnectionError(f"could not connect to PostgreSQL to lock {what or name}: "
                              f"{error}") from error
    with connection:
        connection.execute("SELECT set_config('lock_timeout', %s, false)",
                           (f"{max(1, int(timeout * 1000))}ms",))
        try:
            connection.execute("SELECT pg_advisory_lock(%s)", (key,))
        except psycopg.errors.LockNotAvailable:
            raise RegistryError(f"could not lock {what or name} within {timeout:g} s "
                                f"(PostgreSQL advisory lock {key})") from None
        try:
            yield
        finally:
            try:
                connection.execute("SELECT pg_advisory_unlock(%s)", (key,))
            except psycopg.Error:     # a broken connection: closing it releases the lock
                logger.warning("could not release advisory lock %d (%s); the connection's "
                               "end releases it", key, what or name)


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


