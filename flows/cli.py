"""The ``fleet-health`` command line (also ``python -m flows``).

A top-level parser with the global options, and one command group per entry of
:data:`COMMANDS`: each entry adds its sub-parser and sets ``handler`` (``args -> exit
status``) on every leaf command. Add a command by adding an entry.

Exit status: 0 done, 1 the operation failed (some assets failed, a refused promotion),
2 bad usage or configuration.
"""
from __future__ import annotations

import argparse
import os
import sys
from typing import Callable

from registry.cli import add_baseline_commands

DEFAULT_TRACKING_URI = "sqlite:///mlflow.db"

#: command name -> function adding its parser to the top-level subparsers
COMMANDS: dict[str, Callable[[argparse._SubParsersAction], argparse.ArgumentParser]] = {
    "baseline": add_baseline_commands,
}


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every command of :data:`COMMANDS` mounted."""
    parser = argparse.ArgumentParser(
        prog="fleet-health",
        description="Gray-box fleet health: nightly residual models, drift and baselines.")
    parser.add_argument(
        "--tracking-uri", metavar="URI",
        default=os.environ.get("FLEET_HEALTH_TRACKING_URI") or DEFAULT_TRACKING_URI,
        help="MLflow tracking URI: sqlite:///path.db (embedded) or http://host:port "
             "(default: $FLEET_HEALTH_TRACKING_URI or %(default)s)")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in COMMANDS.values():
        add(commands)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 1 failed, 2 bad usage)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:           # argparse: 2 on bad usage, 0 after --help
        return int(stop.code or 0)
    return int(args.handler(args))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
