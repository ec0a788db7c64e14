"""``fleet-health demo``: the whole product on a simulated fleet."""
from __future__ import annotations

import argparse
import os
import pathlib
import sys

from flows.commands.plumbing import (guarded, nonnegative_int, positive_int,
                                     prefect_environment)
from flows.commands.temporary_server import TemporaryServer
from flows.demo import prepare_workdir, run_demo
from flows.terminal import rich_console


def add_demo_command(subparsers) -> argparse.ArgumentParser:
    """Add ``demo`` to the top-level subparsers."""
    parser = subparsers.add_parser(
        "demo", help="simulate a fleet with faults, fit baselines, run the nightly flow over "
                     "the following days, print the alerts and how to open the UIs",
        description="The whole product on a simulated fleet, in a work directory that holds "
                    "the telemetry, fleet.toml, the MLflow store and PREFECT_HOME.")
    parser.add_argument("--workdir", default="fleet-health-demo", metavar="DIR",
                        help="where everything goes (default: ./fleet-health-demo; a previous "
                             "demo there is replaced)")
    parser.add_argument("--vehicles", type=positive_int, default=8, metavar="N")
    parser.add_argument("--days", type=positive_int, default=10, metavar="N")
    parser.add_argument("--baseline-days", type=positive_int, default=4, metavar="N")
    parser.add_argument("--seed", type=nonnegative_int, default=0, metavar="S")
    parser.add_argument("--sample-interval", type=float, default=10.0, metavar="SECONDS")
    parser.set_defaults(handler=guarded(demo))
    return parser


def demo(args: argparse.Namespace) -> int:
    """Run the demo in --workdir; return the exit status."""
    workdir = prepare_workdir(pathlib.Path(args.workdir))
    if "prefect" not in sys.modules:
        # the demo's Prefect database lives in the workdir, so its UI can show the runs
        os.environ["PREFECT_HOME"] = str(workdir / ".prefect")
        os.environ.pop("PREFECT_API_URL", None)
    prefect_environment(args)
    # the temporary server boots while the fleet is simulated
    server = TemporaryServer().start(announce=False)
    with server.flow_settings():
        return run_demo(workdir, vehicles=args.vehicles, days=args.days,
                        baseline_days=args.baseline_days, seed=args.seed,
                        sample_interval=args.sample_interval, console=rich_console(),
                        server=server)
