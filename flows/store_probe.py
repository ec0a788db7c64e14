"""A bounded wait for the tracking store: a dead MLflow server fails a run in seconds, not
minutes.

MLflow retries every HTTP request itself (7 retries with a backoff factor of 2 and a 120 s
timeout by default: a dead server kept a nightly run busy 13.5 minutes). The command line
sets tighter defaults (:data:`MLFLOW_HTTP_DEFAULTS`) unless the user set those variables,
and every run first probes the store (:func:`require_store`) for at most
``$FLEET_HEALTH_STORE_TIMEOUT`` seconds (default :data:`DEFAULT_STORE_TIMEOUT`): when the
server does not answer, the run stops with one line naming the URI and nothing is done.
"""
from __future__ import annotations

import os
import time
import urllib.error
import urllib.request

from flows.env_seconds import env_seconds
from flows.errors import StoreUnavailable

#: MLflow's HTTP retry settings the command line sets unless already set: a request to a
#: dead server gives up after 1 + 2 + 4 s of backoff, a hanging one after 4 x 20 s
MLFLOW_HTTP_DEFAULTS = {"MLFLOW_HTTP_REQUEST_MAX_RETRIES": "3",
                       "MLFLOW_HTTP_REQUEST_BACKOFF_FACTOR": "1",
                       "MLFLOW_HTTP_REQUEST_BACKOFF_JITTER": "0.5",
                       "MLFLOW_HTTP_REQUEST_TIMEOUT": "20"}

STORE_TIMEOUT_ENV = "FLEET_HEALTH_STORE_TIMEOUT"
DEFAULT_STORE_TIMEOUT = 60.0


def bound_mlflow_requests(environ: dict = os.environ) -> None:
    """Set :data:`MLFLOW_HTTP_DEFAULTS` in ``environ`` where not already set."""
    for name, value in MLFLOW_HTTP_DEFAULTS.items():
        environ.setdefault(name, value)


def store_timeout() -> float:
    """Seconds :func:`require_store` waits (``$FLEET_HEALTH_STORE_TIMEOUT``)."""
    return env_seconds(STORE_TIMEOUT_ENV, DEFAULT_STORE_TIMEOUT, StoreUnavailable)


def http_answers(uri: str, timeout: float) -> str | None:
    """None when the server at ``uri`` answers HTTP at all (any status), else why not."""
    try:
        with urllib.request.urlopen(uri.rstrip("/") + "/health", timeout=timeout):
            return None
    except urllib.error.HTTPError:
        return None     # it answered: authentication or routing are the registry's to report
    except (urllib.error.URLError, OSError) as error:
        reason = getattr(error, "reason", error)
        return f"{type(reason).__name__}: {reason}"


def require_store(tracking_uri: str, timeout: float | None = None) -> None:
    """Wait until the MLflow server of ``tracking_uri`` answers, at most ``timeout`` seconds.

    SQLite and other database URIs are not probed (their errors are immediate).

    Raises
    ------
    StoreUnavailable
        One line naming the URI and what to do.
    """
    if not tracking_uri.startswith(("http://", "https://")):
        return
    timeout = store_timeout() if timeout is None else timeout
    deadline = time.monotonic() + timeout
    delay = 0.5
    while True:
        left = deadline - time.monotonic()
        why = http_answers(tracking_uri, timeout=max(1.0, min(10.0, left)))
        if why is None:
            return
        if time.monotonic() + delay > deadline:
            raise StoreUnavailable(
                f"the MLflow tracking server {tracking_uri} did not answer within "
                f"{timeout:g} s ({why}): nothing was run. Start it, or fix [mlflow] "
                f"tracking_uri / --tracking-uri (${STORE_TIMEOUT_ENV} sets the wait)")
        time.sleep(delay)
        delay = min(8.0, delay * 2)
