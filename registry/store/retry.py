"""Retrying the registry's MLflow calls when the database is locked (SQLite) or asks for the
transaction again (PostgreSQL): :func:`call_with_retry` and :class:`RetryingClient`.

Only those errors are retried, with exponential backoff and jitter, each retry logged; the
same errors relayed by an ``mlflow server`` (HTTP 500 with that message) are retried too. See
:mod:`registry.store.tracking_store` for why SQLite answers "database is locked" at once.
"""
from __future__ import annotations

import logging
import random
import time
from dataclasses import dataclass
from typing import Any, Callable, TypeVar

logger = logging.getLogger(__name__)

T = TypeVar("T")

_LOCKED_MESSAGES = ("database is locked", "database is busy", "database table is locked",
                    # PostgreSQL asks for the transaction to be run again
                    "deadlock detected", "could not serialize access")


@dataclass(frozen=True)
class RetryPolicy:
    """Backoff of :func:`call_with_retry`.

    Attributes
    ----------
    attempts : int
        Tries in all (the first call included).
    base_delay : float
        Seconds before the second try; doubled after each further failure.
    max_delay : float
        Cap on one wait, before jitter.
    jitter : float
        Each wait is multiplied by a uniform factor in ``[1 - jitter, 1 + jitter]``.
    """

    attempts: int = 12
    base_delay: float = 0.05
    max_delay: float = 2.0
    jitter: float = 0.5

    def delay(self, failures: int) -> float:
        """Seconds to wait after ``failures`` consecutive failures (>= 1)."""
        raw = min(self.max_delay, self.base_delay * 2 ** (failures - 1))
        return raw * random.uniform(1 - self.jitter, 1 + self.jitter)


def is_locked_error(error: BaseException) -> bool:
    """Whether ``error`` (or an exception it was raised from) is SQLite's "database is locked"
    (or PostgreSQL's deadlock or serialization failure: the transaction should be retried)."""
    seen = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        seen.add(id(current))
        text = str(current).lower()
        if any(message in text for message in _LOCKED_MESSAGES):
            return True
        current = current.__cause__ or current.__context__
    return False


def is_transient_store_error(error: BaseException) -> bool:
    """Whether the tracking store was only briefly unavailable, so a later try could succeed:
    locked or asking for the transaction again (:func:`is_locked_error`), or an MLflow error
    whose code says the server was temporarily unavailable, failed internally, limited the
    request rate or had an I/O error.

    The one place that reads MLflow's error codes: the registry's boundary asks this and
    raises :class:`~registry.exceptions.TransientStoreError` (:mod:`registry.store.boundary`).
    """
    if is_locked_error(error):
        return True
    try:  # mlflow loads only when an error may be its own: --help must not import it
        from mlflow.exceptions import MlflowException
        from mlflow.protos import databricks_pb2
    except ImportError:  # pragma: no cover
        return False
    if isinstance(error, MlflowException):
        transient_codes = {databricks_pb2.ErrorCode.Name(code) for code in (
            databricks_pb2.INTERNAL_ERROR, databricks_pb2.TEMPORARILY_UNAVAILABLE,
            databricks_pb2.REQUEST_LIMIT_EXCEEDED, databricks_pb2.IO_ERROR)}
        return error.error_code in transient_codes
    return False


def is_passing_failure(error: BaseException) -> bool:
    """A failure that a later try of the whole group could get past: a transient store error
    (:func:`is_transient_store_error`) or a lost connection or answer (``ConnectionError``,
    ``TimeoutError``). A group's writes raise these instead of trying each member alone
    (:mod:`registry.write.group`)."""
    return is_transient_store_error(error) or isinstance(error, (ConnectionError, TimeoutError))


def call_with_retry(function: Callable[..., T], *args, policy: RetryPolicy = RetryPolicy(),
                    what: str | None = None, **kwargs) -> T:
    """Call ``function(*args, **kwargs)``, retrying only "database is locked" errors.

    Parameters
    ----------
    function : callable
    policy : RetryPolicy, optional
    what : str, optional
        Name used in the log message (defaults to the function's name).

    Returns
    -------
    Whatever ``function`` returns.

    Raises
    ------
    Exception
        The last error once ``policy.attempts`` tries failed, or at once any other error.
    """
    name = what or getattr(function, "__name__", repr(function))
    for attempt in range(1, policy.attempts + 1):
        try:
            return function(*args, **kwargs)
        except Exception as error:
            if not is_locked_error(error) or attempt == policy.attempts:
                raise
            wait = policy.delay(attempt)
            logger.warning("%s: database is locked (attempt %d of %d); retrying in %.3f s",
                           name, attempt, policy.attempts, wait)
            time.sleep(wait)
    raise AssertionError("unreachable")  # pragma: no cover


class RetryingClient:
    """An ``MlflowClient`` whose every method call goes through :func:`call_with_retry`.

    Parameters
    ----------
    client : mlflow.MlflowClient
    policy : RetryPolicy, optional
    """

    def __init__(self, client: Any, policy: RetryPolicy = RetryPolicy()):
        self._client = client
        self._policy = policy

    @property
    def wrapped(self) -> Any:
        """The underlying ``MlflowClient``."""
        return self._client

    def __getattr__(self, name: str) -> Any:
        attribute = getattr(self._client, name)
        if not callable(attribute):
            return attribute

        def call(*args, **kwargs):
            return call_with_retry(attribute, *args, policy=self._policy, what=f"mlflow {name}",
                                   **kwargs)

        call.__name__ = name
        return call


