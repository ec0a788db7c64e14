"""``fleet-health run``: one nightly pass now."""
from __future__ import annotations

import argparse

from flows.commands.plumbing import (asset_option, class_option, flow_command_options, load,
                                     prefect_environment, report_summary, run_flow,
                                     start_pool_early)
from flows.commands.temporary_server import TemporaryServer
from flows.errors import FlowFailed
from flows.discovery import not_in_future, parse_time
from flows.terminal import EXIT_FAILED, print_error


def add_run_command(subparsers) -> argparse.ArgumentParser:
    """Add ``run`` to the top-level subparsers."""
    parser = subparsers.add_parser(
        "run", help="one nightly pass now, over every asset with new telemetry",
        description="One nightly pass: every asset's whole windows (UTC days) after its "
                    "watermark and before --as-of, against its baseline.")
    parser.add_argument("--as-of", metavar="WHEN",
                        help="process windows ending by this date/time (UTC; default now)")
    asset_option(parser)
    class_option(parser)
    flow_command_options(parser, run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Run the nightly flow once; print its summary; return the exit status."""
    config = load(args)
    as_of = None if args.as_of is None else not_in_future(
        parse_time(args.as_of, "--as-of"), "--as-of").isoformat()
    prefect_environment(args)
    start_pool_early(config, args.assets)
    # its child starts while the flow's modules load (prefect loads only for commands that
    # run flows, after prefect_environment)
    server = TemporaryServer().start()
    from flows.nightly import nightly

    try:
        summary = run_flow(args, server, lambda: nightly(
            config_path=str(config.path), as_of=as_of, assets=args.assets,
            vehicle_class=args.vehicle_class, tracking_uri=args.tracking_uri,
            return_state=True))
    except FlowFailed as error:
        print_error(f"the nightly run failed: {error}")
        return EXIT_FAILED
    return report_summary(args, summary, f"Nightly run as of {summary.as_of[:16]} UTC")
