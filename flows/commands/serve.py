"""``fleet-health serve``: serve the deployments with their schedules."""
from __future__ import annotations

import argparse
import os

from flows.commands.plumbing import config_options, guarded, load, prefect_environment
from flows.terminal import EXIT_OK, rich_console


def add_serve_command(subparsers) -> argparse.ArgumentParser:
    """Add ``serve`` to the top-level subparsers."""
    parser = subparsers.add_parser(
        "serve", help="serve the deployments with their schedules (nightly cron)",
        description="Serve the nightly (on [schedule] cron), baseline and reanalyze "
                    "deployments from this process until interrupted. Set PREFECT_API_URL to "
                    "a running Prefect server (prefect server start) to see them in its UI.")
    parser.add_argument("--dry-run", action="store_true",
                        help="print the deployments and exit")
    config_options(parser)
    parser.set_defaults(handler=guarded(serve))
    return parser


def serve(args: argparse.Namespace) -> int:
    """Print the deployments and (unless --dry-run) serve them until interrupted."""
    config = load(args)
    prefect_environment(args)
    # prefect loads only for commands that run flows, after prefect_environment
    from flows.serve import build_deployments, serve_deployments

    deployments = build_deployments(config, tracking_uri=args.tracking_uri)
    console = rich_console()
    for d in deployments:
        schedules = ", ".join(f"cron '{s.schedule.cron}' ({s.schedule.timezone})"
                              for s in (d.schedules or [])) or "on demand"
        console.print(f"{d.flow_name}/{d.name}: {d.entrypoint} - {schedules}")
    if args.dry_run:
        return EXIT_OK
    if not os.environ.get("PREFECT_API_URL"):
        console.print("PREFECT_API_URL is not set: serving against a temporary local server "
                      "(no UI). Start `prefect server start` and set PREFECT_API_URL to see "
                      "the runs.")
    serve_deployments(deployments)
    return EXIT_OK
