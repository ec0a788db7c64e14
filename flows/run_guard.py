"""What every flow does around its body: probe the store (bounded, :mod:`flows.store_probe`),
take the fleet's run lock (:mod:`flows.run_lock`), mark orphaned runs Crashed
(:mod:`flows.orphans`), and record what it found in the run summary."""
from __future__ import annotations

import contextlib
import logging
from dataclasses import asdict
from typing import Iterator

from flows.orphans import Orphan, crash_orphans
from flows.results import RunSummary
from flows.run_lock import RunLock
from flows.store_probe import require_store
from flows.run_logger import run_logger

logger = logging.getLogger(__name__)


class GuardedRun:
    """The run lock held by a flow run, and the orphans it marked Crashed."""

    def __init__(self, lock: RunLock):
        self.lock = lock
        self.orphans: list[Orphan] = []

    def annotate(self, summary: RunSummary) -> RunSummary:
        """Record the wait and the orphans in ``summary.extra``."""
        summary.extra["run_lock"] = self.lock.to_dict()
        if self.orphans:
            summary.extra["orphans_crashed"] = [asdict(o) for o in self.orphans]
        return summary


@contextlib.contextmanager
def exclusive_run(config, flow: str) -> Iterator[GuardedRun]:
    """Hold the fleet for one run of ``flow`` (``nightly``, ``baseline``, ``reanalyze``).

    Raises
    ------
    flows.errors.StoreUnavailable
        The MLflow server did not answer within the bound.
    flows.errors.RunLockTimeout
        Another run of the fleet held it longer than the wait.
    """
    from prefect.runtime import flow_run

    require_store(config.tracking_uri)
    current = str(flow_run.id) if flow_run.id else None
    lock = RunLock.of(config.tracking_uri)
    with lock.hold(flow, current):
        guarded = GuardedRun(lock)
        try:
            guarded.orphans = crash_orphans(lock.orphan, current)
        except Exception as error:  # noqa: BLE001 - the run goes on; the failure is said
            run_logger(logger).warning("fleet-health %s: could not check for orphaned flow "
                                       "runs: %s: %s", flow, type(error).__name__, error)
        yield guarded
