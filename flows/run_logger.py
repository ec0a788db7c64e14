"""The logger of the Prefect flow or task run in progress: its lines are on the run's page in
Prefect's UI (a served deployment's runs have no terminal)."""
from __future__ import annotations

import logging


def run_logger(fallback: logging.Logger) -> logging.Logger | logging.LoggerAdapter:
    """The current flow or task run's logger, or ``fallback`` outside a run."""
    from prefect.exceptions import MissingContextError
    from prefect.logging import get_run_logger

    try:
        return get_run_logger()
    except MissingContextError:
        return fallback
