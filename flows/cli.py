"""The ``fleet-health`` command line (also ``python -m flows``).

A top-level parser with the global options, and one command group per entry of
:data:`COMMANDS`: each entry adds its sub-parser and sets ``handler`` (``args -> exit
status``) on every leaf command. Add a command by adding an entry
(its module in :mod:`flows.commands`).

Global options (before the command; ``run``, ``reanalyze``, ``alerts``, ``baseline fit``,
``serve`` also take ``--config`` and ``--tracking-uri`` after it):

``--config PATH``       the fleet.toml (default ``$FLEET_HEALTH_CONFIG`` or ``./fleet.toml``)
``--tracking-uri URI``  overrides ``[mlflow] tracking_uri`` (and ``$FLEET_HEALTH_TRACKING_URI``)
``-v``                  show Prefect's and the libraries' log lines

Exit status: 0 all assets processed; 1 an asset that should be monitored was not (failed,
stale, no baseline, unusable baseline, no telemetry, dormant: each named, with why) or the
operation failed (``check``: a problem found); 2 bad usage or configuration; 3 Prefect's API
server could not be started or reached (one line says what to do).
"""
from __future__ import annotations

import argparse
import os
import pathlib
import sys
from typing import Callable

from flows.commands.alerts import add_alerts_command
from flows.commands.baseline import add_baseline_group
from flows.commands.check import add_check_command
from flows.commands.demo import add_demo_command
from flows.commands.importing import add_import_command
from flows.commands.plumbing import EPHEMERAL_STARTUP_TIMEOUT, prefect_environment
from flows.commands.reanalyze import add_reanalyze_command
from flows.commands.report import add_report_command
from flows.commands.run import add_run_command
from flows.commands.serve import add_serve_command
from flows.commands.simulate import add_simulate_command
from flows.commands.temporary_server import STARTUP_TIMEOUT_MESSAGE
from flows.config import DEFAULT_CONFIG, DEFAULT_TRACKING_URI, ConfigError, load_config
from flows.terminal import EXIT_UNAVAILABLE, EXIT_USAGE, print_error

__all__ = ["COMMANDS", "DEFAULT_CONFIG", "DEFAULT_TRACKING_URI", "EPHEMERAL_STARTUP_TIMEOUT",
           "EXIT_UNAVAILABLE", "build_parser", "main"]

#: the name under which tests and earlier callers know :func:`prefect_environment`
_prefect_environment = prefect_environment

#: command name -> function adding its parser to the top-level subparsers
COMMANDS: dict[str, Callable[[argparse._SubParsersAction], argparse.ArgumentParser]] = {
    "demo": add_demo_command,
    "simulate": add_simulate_command,
    "import": add_import_command,
    "baseline": add_baseline_group,
    "run": add_run_command,
    "reanalyze": add_reanalyze_command,
    "alerts": add_alerts_command,
    "serve": add_serve_command,
    "report": add_report_command,
    "check": add_check_command,
}


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every command of :data:`COMMANDS` mounted."""
    parser = argparse.ArgumentParser(
        prog="fleet-health",
        description="Gray-box fleet health: nightly residual models, drift and baselines.",
        epilog="Exit status: 0 all assets processed; 1 an asset that should be monitored was "
               "not (failed, stale, no baseline, unusable baseline, no telemetry, dormant: "
               "each named, with why), or check found a problem; 2 bad usage or configuration; 3 "
               "Prefect's API server could not be started or reached.")
    parser.add_argument(
        "--config", metavar="PATH",
        default=os.environ.get("FLEET_HEALTH_CONFIG") or DEFAULT_CONFIG,
        help="the fleet configuration (default: $FLEET_HEALTH_CONFIG or %(default)s)")
    parser.add_argument(
        "--tracking-uri", metavar="URI",
        default=os.environ.get("FLEET_HEALTH_TRACKING_URI") or None,
        help="MLflow tracking URI: sqlite:///path.db (embedded) or http://host:port "
             "(default: $FLEET_HEALTH_TRACKING_URI, else [mlflow] tracking_uri of the "
             f"configuration, else {DEFAULT_TRACKING_URI})")
    parser.add_argument("-v", "--verbose", action="store_true",
                        help="show Prefect's log lines on the console")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in COMMANDS.values():
        add(commands)
    return parser


def _resolve_registry_uri(args: argparse.Namespace) -> int | None:
    """``baseline list/history/promote/...`` use the configuration's store when no URI is
    given; returns an exit status on a bad configuration."""
    if args.tracking_uri:
        return None
    path = pathlib.Path(args.config)
    if path.exists():
        try:
            args.tracking_uri = load_config(path).tracking_uri
        except ConfigError as error:
            print_error(str(error))
            return EXIT_USAGE
    else:
        args.tracking_uri = DEFAULT_TRACKING_URI
    return None


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 1 failed, 2 bad usage)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:           # argparse: 2 on bad usage, 0 after --help
        return int(stop.code or 0)
    if args.command != "demo":            # the demo first points PREFECT_HOME at its workdir
        prefect_environment(args)
    if args.command == "baseline" and getattr(args, "baseline_command", None) != "fit":
        status = _resolve_registry_uri(args)
        if status is not None:
            return status
    try:
        return int(args.handler(args))
    except RuntimeError as error:
        if STARTUP_TIMEOUT_MESSAGE not in str(error):
            raise
        timeout = os.environ.get("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS")
        print_error(f"Prefect's temporary API server did not start within {timeout} s (a busy "
               f"machine?): nothing was run. Retry, raise "
               f"PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS, or start a server once "
               f"(`prefect server start`) and set PREFECT_API_URL=http://127.0.0.1:4200/api.")
        return EXIT_UNAVAILABLE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
