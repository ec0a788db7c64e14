"""``fleet-health simulate``: write a simulated fleet in the telemetry layout."""
from __future__ import annotations

import argparse
import pathlib
import sys

from flows import progress
from flows.commands.plumbing import guarded, nonnegative_int, positive_int
from flows.demo import parse_fault, simulated_fleet, write_simulation
from flows.terminal import EXIT_OK, rich_console


def add_simulate_command(subparsers) -> argparse.ArgumentParser:
    """Add ``simulate`` to the top-level subparsers."""
    parser = subparsers.add_parser(
        "simulate", help="write a simulated fleet in the telemetry layout, with chosen faults",
        description="Simulate gas-turbine vehicles (graybox.simulation) and write their "
                    "telemetry and fleet_truth.json. Without --fault or --healthy, "
                    "demo_fleet's faults are injected (friction, nonlinear, noise on up to "
                    "3 vehicles).")
    parser.add_argument("--out", required=True, metavar="DIR", help="telemetry root to write")
    parser.add_argument("--vehicles", type=positive_int, default=8, metavar="N")
    parser.add_argument("--days", type=positive_int, default=10, metavar="N")
    parser.add_argument("--seed", type=nonnegative_int, default=0, metavar="S")
    parser.add_argument("--start", default="2026-01-01", metavar="DATE")
    parser.add_argument("--sample-interval", type=float, default=10.0, metavar="SECONDS")
    faults = parser.add_mutually_exclusive_group()
    faults.add_argument("--fault", action="append", metavar="ASSET:KIND:ONSET_DAY:MAGNITUDE",
                        help="inject a fault (repeatable); KIND is friction, nonlinear, noise, "
                             "bias or heavy_tails; ONSET_DAY counts days from --start")
    faults.add_argument("--healthy", action="store_true", help="no faults at all")
    parser.add_argument("--config-out", metavar="PATH",
                        help="also write a fleet.toml for this telemetry")
    parser.set_defaults(handler=guarded(simulate))
    return parser


def simulate(args: argparse.Namespace) -> int:
    """Simulate the fleet and write it; say what was written; return the exit status."""
    faults = None if args.fault is None else [parse_fault(text) for text in args.fault]
    spec = simulated_fleet(args.vehicles, args.days, args.seed, args.start,
                           args.sample_interval, faults=faults, healthy=args.healthy)
    with progress.reporting(progress.for_stream(sys.stderr)):
        write_simulation(spec, pathlib.Path(args.out), config_out=args.config_out)
    console = rich_console()
    console.print(f"Wrote {len(spec.vehicles)} vehicles x {spec.days} days "
                  f"({spec.sample_interval:g} s samples) to {args.out}")
    for vehicle in spec.vehicles:
        for fault in vehicle.faults:
            console.print(f"  {vehicle.asset_id}: {fault.kind} {fault.magnitude:g} from day "
                          f"{fault.onset_day:g}")
    if args.config_out:
        console.print(f"Configuration: {args.config_out}")
    return EXIT_OK
