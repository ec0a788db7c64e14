"""``fleet-health baseline``: the registry's group (list, history, promote, reject,
rollback; :mod:`flows.commands.review`) plus ``baseline fit``."""
from __future__ import annotations

import argparse

from flows.commands.plumbing import (class_option, flow_command_options, load,
                                     prefect_environment, report_summary, run_flow)
from flows.commands.temporary_server import TemporaryServer
from flows.errors import FlowFailed, UsageError
from flows.discovery import parse_time
from flows.commands.review import add_baseline_commands
from flows.terminal import EXIT_FAILED, print_error


def add_baseline_group(subparsers) -> argparse.ArgumentParser:
    """The registry's ``baseline`` group plus ``baseline fit``."""
    parser = add_baseline_commands(subparsers)
    parser.description = "Fit baselines from healthy ranges, review them and move the baseline."
    for choice in subparsers._choices_actions:
        if choice.dest == "baseline":
            choice.help = "fit and review baselines: fit, list, history, promote, reject, rollback"
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    fit = commands.add_parser(
        "fit", help="fit calibrated baselines from a healthy range",
        description="Fit a calibrated baseline for each asset from the whole days in "
                    "[--start, --end); it becomes the candidate (or, with --promote, the "
                    "baseline).")
    fit.add_argument("assets", nargs="*", metavar="ASSET", help="assets to fit")
    class_option(fit, help="every asset of this vehicle class")
    fit.add_argument("--all", action="store_true", help="every asset of the fleet")
    fit.add_argument("--start", required=True, metavar="DATE", help="first healthy day (UTC)")
    fit.add_argument("--end", required=True, metavar="DATE",
                     help="end of the healthy range (exclusive)")
    fit.add_argument("--promote", action="store_true",
                     help="make each new fit the baseline at once (needs --reason)")
    fit.add_argument("--reason", help="why (recorded with the promotion)")
    flow_command_options(fit, baseline_fit)
    return parser


def baseline_fit(args: argparse.Namespace) -> int:
    """Run the baseline flow over [--start, --end); print its summary; return the status."""
    if not (args.assets or args.vehicle_class or args.all):
        raise UsageError("name the assets, a --class, or --all")
    if args.promote and not (args.reason and args.reason.strip()):
        raise UsageError("--promote needs --reason (it is recorded with the promotion)")
    config = load(args)
    start = parse_time(args.start, "--start")
    end = parse_time(args.end, "--end")
    prefect_environment(args)
    # its child starts while the flow's modules load (prefect loads only for commands that
    # run flows, after prefect_environment)
    server = TemporaryServer().start()
    from flows.baseline import baseline, baseline_windows

    baseline_windows(config, start, end)
    try:
        summary = run_flow(args, server, lambda: baseline(
            start=start.isoformat(), end=end.isoformat(), config_path=str(config.path),
            assets=args.assets or None, vehicle_class=args.vehicle_class,
            promote=args.promote, reason=args.reason, tracking_uri=args.tracking_uri,
            return_state=True))
    except FlowFailed as error:
        print_error(f"the baseline flow failed: {error}")
        return EXIT_FAILED
    return report_summary(args, summary, f"Baselines from {start:%Y-%m-%d} to {end:%Y-%m-%d}")
