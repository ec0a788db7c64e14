"""``fleet-health serve``: the deployments, served from this process with their schedules.

:func:`build_deployments` makes one deployment per flow with ``flow.to_deployment``: the
``nightly`` deployment on ``[schedule] cron`` (in ``[schedule] timezone``), ``baseline`` and
``reanalyze`` on demand (start them from the Prefect UI or ``prefect deployment run``).
:func:`serve_deployments` serves them with ``prefect.serve`` until interrupted; each run
executes in a subprocess of this one.

The alternative for production is a work pool: ``prefect.yaml`` at the repository root
declares the same deployments (``prefect deploy --all``), and a worker
(``prefect worker start --pool fleet-health``) runs them.
"""
from __future__ import annotations

from prefect import serve
from prefect.deployments.runner import EntrypointType
from prefect.schedules import Cron

from flows.baseline import baseline
from flows.config import FleetConfig
from flows.nightly import nightly
from flows.reanalyze import reanalyze


def build_deployments(config: FleetConfig, tracking_uri: str | None = None) -> list:
    """The three deployments for ``config`` (nightly scheduled on its cron)."""
    # module entrypoints (flows.nightly.nightly) load wherever the package is installed
    options = {"tags": ["fleet-health"], "entrypoint_type": EntrypointType.MODULE_PATH}
    common = {"config_path": str(config.path)}
    if tracking_uri:
        common["tracking_uri"] = tracking_uri
    return [
        nightly.to_deployment(
            name="nightly", schedules=[Cron(config.schedule.cron,
                                            timezone=config.schedule.timezone)],
            parameters=dict(common), **options,
            description="Nightly fleet run: every asset's new telemetry against its baseline."),
        baseline.to_deployment(
            name="baseline", parameters=dict(common), **options,
            description="Fit calibrated baselines from a healthy range (start, end)."),
        reanalyze.to_deployment(
            name="reanalyze", parameters=dict(common), **options,
            description="Ad-hoc reanalysis of assets and a time range."),
    ]


#: how far ahead of its scheduled time a run's process is started, beyond the runner's poll
#: interval: the process imports Prefect and the flow (about 3 s) and then waits
#: for the scheduled time, so a run starts on time instead of up to that much late
SPAWN_AHEAD_SECONDS = 20.0


def serve_deployments(deployments: list) -> None:
    """Serve until interrupted (schedules stay active on shutdown).

    The runner polls the server every ``PREFECT_RUNNER_POLL_FREQUENCY`` seconds and takes the
    runs due within ``prefetch_seconds``; with the poll interval plus
    :data:`SPAWN_AHEAD_SECONDS` of prefetch, each run's process is started at least that long
    before the run is due (Prefect's default prefetch equals the poll interval, so a run could
    be picked up just before its time and start late by its process's import time).
    """
    from prefect.settings import get_current_settings

    poll = float(get_current_settings().runner.poll_frequency)
    serve(*deployments, pause_on_shutdown=False, query_seconds=poll,
          prefetch_seconds=poll + SPAWN_AHEAD_SECONDS)
