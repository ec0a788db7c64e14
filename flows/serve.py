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


def serve_deployments(deployments: list) -> None:
    """Serve until interrupted (schedules stay active on shutdown)."""
    serve(*deployments, pause_on_shutdown=False)
