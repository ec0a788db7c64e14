"""Orphaned flow runs: a killed run stays Running in Prefect forever, so its ``on_crashed``
hook never fires. The next run (and ``fleet-health check``) finds such runs and marks them
Crashed through Prefect's API, then sends the notification the dead process could not.

A flow run of ours is orphaned when

* the run lock's holder file names it but the lock was free (:mod:`flows.run_lock`: the
  process that held it is gone; a run that ends cleanly removes the file), or
* it is Running or Pending for longer than ``$FLEET_HEALTH_ORPHAN_AFTER`` seconds (default
  :data:`DEFAULT_ORPHAN_AFTER`, a day: no nightly run lasts that long), whatever its fleet.

(Prefect's own remedy, flow-run heartbeats and a "zombie" automation, needs a worker or
runner and a server-side automation; ``fleet-health run`` has neither.)
"""
from __future__ import annotations

import logging
import uuid
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from types import SimpleNamespace

from flows.env_seconds import env_seconds
from flows.run_lock import Holder
from flows.run_logger import run_logger

logger = logging.getLogger(__name__)

FLOW_NAMES = ("fleet-health-nightly", "fleet-health-baseline", "fleet-health-reanalyze")
ORPHAN_AFTER_ENV = "FLEET_HEALTH_ORPHAN_AFTER"
DEFAULT_ORPHAN_AFTER = 24 * 3600.0
ACTIVE = ("RUNNING", "PENDING")


@dataclass(frozen=True)
class Orphan:
    """A flow run marked Crashed, and why."""

    flow_run_id: str
    flow: str
    name: str
    why: str

    def describe(self) -> str:
        return f"{self.flow} flow run {self.name} ({self.flow_run_id}): {self.why}"


def orphan_after() -> timedelta:
    """``$FLEET_HEALTH_ORPHAN_AFTER`` (seconds) as a timedelta."""
    return timedelta(seconds=env_seconds(ORPHAN_AFTER_ENV, DEFAULT_ORPHAN_AFTER))


def crash_orphans(dead_holder: Holder | None = None, current: str | None = None,
                  older_than: timedelta | None = None, notify: bool = True) -> list[Orphan]:
    """Mark our orphaned flow runs Crashed (see the module docstring) and notify.

    Parameters
    ----------
    dead_holder : Holder, optional
        The run lock's holder left behind by a killed process.
    current : str, optional
        The calling flow run's id (never marked).
    older_than : timedelta, optional
        Age after which a Running/Pending run is orphaned (default :func:`orphan_after`).
    notify : bool
        Send each crash to the notification block of the run's fleet.toml.

    Returns
    -------
    list of Orphan
        The runs marked Crashed.
    """
    from prefect.client.orchestration import get_client
    from prefect.client.schemas.filters import (FlowFilter, FlowFilterName, FlowRunFilter,
                                                FlowRunFilterState, FlowRunFilterStateType)
    from prefect.client.schemas.objects import StateType

    older_than = orphan_after() if older_than is None else older_than
    now = datetime.now(timezone.utc)
    found: dict[str, tuple[object, str]] = {}
    with get_client(sync_client=True) as client:
        if dead_holder is not None and dead_holder.flow_run_id:
            run = client.read_flow_run(uuid.UUID(dead_holder.flow_run_id))
            if run.state is not None and run.state.type.value in ACTIVE:
                found[str(run.id)] = (run, f"its process (pid {dead_holder.pid} on "
                                           f"{dead_holder.host}) died holding the run lock")
        active = client.read_flow_runs(
            flow_filter=FlowFilter(name=FlowFilterName(any_=list(FLOW_NAMES))),
            flow_run_filter=FlowRunFilter(state=FlowRunFilterState(
                type=FlowRunFilterStateType(any_=[StateType.RUNNING, StateType.PENDING]))))
        for run in active:
            since = run.start_time or run.expected_start_time or run.created
            if since is not None and now - since > older_than and str(run.id) not in found:
                found[str(run.id)] = (run, f"{run.state.name} since {since:%Y-%m-%d %H:%M} UTC, "
                                           f"longer than {older_than}")
        found.pop(str(current), None)
        orphans = []
        for run_id, (run, why) in found.items():
            orphans.append(_crash(client, run, why, notify))
    return orphans


def _crash(client, run, why: str, notify: bool) -> Orphan:
    from prefect.states import Crashed

    flow_name = client.read_flow(run.flow_id).name
    message = f"orphaned: {why}; marked Crashed by a later fleet-health run"
    state = Crashed(message=message)
    client.set_flow_run_state(run.id, state, force=True)
    run_logger(logger).warning("fleet-health: %s flow run %s (%s) was orphaned (%s): marked "
                               "Crashed", flow_name, run.name, run.id, why)
    if notify:
        from flows.hooks import notify_hook

        notify_hook(SimpleNamespace(name=flow_name), run, state)
    return Orphan(str(run.id), flow_name, run.name, why)
