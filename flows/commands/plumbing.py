"""What the commands share: Prefect's environment, errors as exit statuses, running a flow
and printing its run summary, and argparse helpers."""
from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Callable, Sequence

from flows import progress
from flows.config import ConfigError, FleetConfig, load_config
from flows.errors import FlowFailed, StoreUnavailable, UsageError
from flows.run_tables import alert_table, fleet_table, outside_line
from flows.results import MONITORED, RunSummary, state_summary
from flows.store_probe import bound_mlflow_requests, require_store
from flows.commands.temporary_server import TemporaryServer
from graybox.exceptions import InvalidAssetIdError
from flows.terminal import EXIT_FAILED, EXIT_USAGE, print_error, rich_console

#: seconds Prefect's temporary local server may take to start (Prefect's own default, 20 s,
#: is missed on a loaded machine: a first run in a new PREFECT_HOME took 27.7 s on an idle one)
EPHEMERAL_STARTUP_TIMEOUT = 180

#: errors of the request or the configuration: exit status 2
USAGE_ERRORS = (ConfigError, UsageError, InvalidAssetIdError)


def start_pool_early(config: FleetConfig, assets: Sequence[str] | None = None,
                     vehicle_class: str | None = None) -> None:
    """Start the compute pool's forkserver now when the run's batches go to a pool (the
    sequential runner, ``[nightly] processes`` > 1, for ``"auto"`` a fleet of enough assets,
    and not one named asset (``assets``, the command's ``--asset``; ``vehicle_class``, its
    ``--class``); :func:`flows.batching.run_over_fleet` decides): its imports then run beside
    the temporary server's start (about 3 s of the first worker's start at 2 cores). Call
    after :func:`prefect_environment`."""
    if config.nightly.task_runner != "sequential" or (assets is not None and len(assets) == 1):
        return
    count = None
    if config.nightly.processes == "auto":
        from flows.discovery import discover

        try:
            count = len(discover(config, assets, vehicle_class).assets)
        except Exception:                # the flow reports it; nothing to start early
            return
    if config.nightly.process_count(assets=count) > 1:
        from flows.compute_pool import start_forkserver

        start_forkserver()


def prefect_environment(args: argparse.Namespace) -> None:
    """Quiet Prefect's and MLflow's console logs unless -v (Prefect's logs still reach its
    UI); no usage telemetry. Must run before prefect and mlflow are imported."""
    level = "INFO" if getattr(args, "verbose", False) else "WARNING"
    os.environ.setdefault("PREFECT_LOGGING_HANDLERS_CONSOLE_LEVEL", level)
    os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
    os.environ.setdefault("PREFECT_SERVER_LOGGING_LEVEL", "WARNING")
    os.environ.setdefault("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS",
                          str(EPHEMERAL_STARTUP_TIMEOUT))
    os.environ.setdefault("MLFLOW_LOGGING_LEVEL", level)
    bound_mlflow_requests(os.environ)


def config_options(parser: argparse.ArgumentParser) -> None:
    """``--config``/``--tracking-uri`` also after the command (SUPPRESS keeps the global)."""
    parser.add_argument("--config", metavar="PATH", default=argparse.SUPPRESS,
                        help="the fleet.toml (default: ./fleet.toml)")
    parser.add_argument("--tracking-uri", metavar="URI", default=argparse.SUPPRESS,
                        help="MLflow tracking URI (overrides [mlflow] tracking_uri)")


def asset_option(parser: argparse.ArgumentParser,
                 help: str = "only this asset (repeatable)") -> None:
    """``--asset ASSET``, repeatable: the assets a command works on (``args.assets``)."""
    parser.add_argument("--asset", dest="assets", action="append", metavar="ASSET", help=help)


def class_option(parser: argparse.ArgumentParser, help: str = "only this vehicle class") -> None:
    """``--class CLASS``: a vehicle class of fleet.toml (``args.vehicle_class``)."""
    parser.add_argument("--class", dest="vehicle_class", metavar="CLASS", help=help)


def flow_command_options(parser: argparse.ArgumentParser,
                         handler: Callable[[argparse.Namespace], int]) -> None:
    """What every command that runs a flow ends with: ``--json`` (its run summary), the
    :func:`config_options`, and its ``handler`` (errors as exit statuses, see :func:`guarded`)."""
    parser.add_argument("--json", action="store_true", help="print the run summary as JSON")
    config_options(parser)
    parser.set_defaults(handler=guarded(handler))


#: commands that run a flow: they wait for the tracking store (bounded) before starting it
STORE_COMMANDS = ("run", "reanalyze", "baseline")


def load(args: argparse.Namespace) -> FleetConfig:
    """The configuration of ``--config``, with ``--tracking-uri`` applied; for the commands
    of :data:`STORE_COMMANDS`, once the tracking store answers.

    Raises
    ------
    flows.errors.StoreUnavailable
        When an MLflow server does not answer within the bound (nothing was run).
    """
    config = load_config(args.config).with_tracking_uri(args.tracking_uri)
    if getattr(args, "command", None) in STORE_COMMANDS:
        require_store(config.tracking_uri)
    return config


def guarded(function: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """Map errors to exit statuses: configuration and usage 2, anything else 1."""
    def run(args: argparse.Namespace) -> int:
        try:
            return function(args)
        except USAGE_ERRORS as error:
            print_error(str(error))
            return EXIT_USAGE
        except StoreUnavailable as error:
            print_error(str(error))
            return EXIT_FAILED
        except KeyboardInterrupt:
            print_error("interrupted; rerun the command: committed results are kept and nothing "
                   "is duplicated")
            return 130
    run.__name__ = function.__name__
    return run


def run_flow(args: argparse.Namespace, server: TemporaryServer,
             call: Callable[[], object]) -> RunSummary:
    """Run a flow with progress on stderr, once the command's temporary Prefect server (if
    any, started with :meth:`TemporaryServer.start` before the flow's modules loaded)
    answers, with that server's :meth:`TemporaryServer.flow_settings`; return its
    RunSummary.

    Raises
    ------
    FlowFailed
        If the flow failed for another reason than a usage or configuration error.
    RuntimeError
        Prefect's, when its temporary server did not start in time (nothing was run).
    """
    server.wait()
    with server.flow_settings(), progress.reporting(progress.for_stream(sys.stderr)):
        state = call()
    try:
        return state_summary(state)
    except USAGE_ERRORS:
        raise
    except Exception as error:  # noqa: BLE001 - the flow itself failed: say why, exit 1
        raise FlowFailed(f"{type(error).__name__}: {error}") from error


def report_summary(args: argparse.Namespace, summary: RunSummary, title: str) -> int:
    """Print a run summary (tables, or JSON) and the failures; return its exit status."""
    if args.json:
        print(json.dumps(summary.to_dict(), indent=2, default=str))
    else:
        console = rich_console()
        console.print(fleet_table(summary, title=title))
        if summary.alerts:
            console.print(alert_table(summary.alerts))
            beyond = outside_line(summary.alerts)
            if beyond:
                console.print(beyond)
        elif summary.flow != "baseline":
            console.print("No alerts.")
        counts = ", ".join(f"{n} {status}" for status, n in summary.counts().items() if n)
        count = len(summary.assets)
        console.print(f"{count} asset{'' if count == 1 else 's'}: {counts or 'none'}.")
        console.print(f"Coverage: {summary.coverage.line()}")
        if summary.unmatched:
            console.print(f"{len(summary.unmatched)} asset(s) in the telemetry match no vehicle "
                          f"class and were left alone: {', '.join(summary.unmatched[:20])}")
    for entry in summary.skipped:
        print(f"fleet-health: skipped {entry['path']}: {entry['reason']}", file=sys.stderr)
    for line in guard_lines(summary):
        print(f"fleet-health: {line}", file=sys.stderr)
    for asset in summary.assets:
        if asset.status in MONITORED:
            continue
        what = "failed" if asset.failed else f"not monitored ({asset.status})"
        print(f"fleet-health: {asset.asset_id} {what}: {asset.reason()}", file=sys.stderr)
        for error in asset.window_errors:
            if error != asset.error:             # the first is the line above
                print(f"fleet-health: {asset.asset_id} window {error.window_start} failed "
                      f"too: {error.message}", file=sys.stderr)
    return summary.exit_status


def guard_lines(summary: RunSummary) -> list[str]:
    """What the run lock and the orphan check found (:mod:`flows.run_guard`), one line each."""
    lines = []
    lock = summary.extra.get("run_lock") or {}
    if lock.get("waited_seconds", 0) >= 1:
        holder = lock.get("waited_for") or {}
        whom = (f"the {holder['flow']} run (flow run {holder['flow_run_id']}, pid "
                f"{holder['pid']})" if holder else "another run")
        lines.append(f"waited {lock['waited_seconds']:g} s for {whom} of this fleet to "
                     f"finish first (the run lock)")
    for orphan in summary.extra.get("orphans_crashed", []):
        lines.append(f"marked the orphaned {orphan['flow']} flow run {orphan['name']} "
                     f"({orphan['flow_run_id']}) Crashed: {orphan['why']}")
    return lines


def int_at_least(low: int) -> Callable[[str], int]:
    """An argparse type: an integer >= ``low``."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be >= {low}, got {value}")
        return value
    return parse


positive_int, nonnegative_int = int_at_least(1), int_at_least(0)
