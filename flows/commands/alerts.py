"""``fleet-health alerts``: the alerts recorded (the JSON-lines file, or the registry), and
``--export``: the registry's alerts written into the file."""
from __future__ import annotations

import argparse
import json

from flows.alerts import AlertLog, export_alerts
from flows.commands.plumbing import asset_option, config_options, guarded, load
from flows.discovery import parse_time
from flows.run_tables import alert_table
from graybox.exceptions import ArtifactError
from flows.terminal import EXIT_FAILED, EXIT_OK, print_error, rich_console
from registry import RegistryError


def add_alerts_command(subparsers) -> argparse.ArgumentParser:
    """Add ``alerts`` to the top-level subparsers."""
    parser = subparsers.add_parser("alerts", help="the alerts recorded",
                                   description="The nightly alerts (from the alerts file, or "
                                               "the registry with --from-registry).")
    parser.add_argument("--since", metavar="DATE", help="windows ending at or after DATE (UTC)")
    asset_option(parser)
    parser.add_argument("--from-registry", action="store_true",
                        help="read the alerts from the MLflow registry (the system of record) "
                             "instead of the JSON-lines file")
    parser.add_argument("--export", action="store_true",
                        help="write the registry's alerts (since --since) into the JSON-lines "
                             "file, skipping those already there: rebuilds a lost or partial "
                             "file")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    config_options(parser)
    parser.set_defaults(handler=guarded(alerts))
    return parser


def alerts(args: argparse.Namespace) -> int:
    """Print the alerts (a table, or JSON); return the exit status."""
    config = load(args)
    since = None if args.since is None else parse_time(args.since, "--since")
    if args.export:
        return export(config, since)
    if args.from_registry:
        try:
            found = config.registry().alerts(since=since, scale=config.alerts.scale)
        except (RegistryError, ArtifactError) as error:
            print_error(str(error))
            return EXIT_FAILED
        if args.assets:
            found = [a for a in found if a.asset_id in set(args.assets)]
    else:
        found = AlertLog(config.alerts.jsonl).read(since=since, assets=args.assets)
    if args.json:
        print(json.dumps([a.to_dict() for a in found], indent=2, default=str))
        return EXIT_OK
    console = rich_console()
    if not found:
        where = "the registry" if args.from_registry else str(config.alerts.jsonl)
        console.print(f"No alerts recorded in {where}" + (f" since {since:%Y-%m-%d}"
                                                          if since is not None else "") + ".")
        return EXIT_OK
    console.print(alert_table(found))
    return EXIT_OK


def export(config, since) -> int:
    """``alerts --export``: append the registry's alerts missing from the file."""
    log = AlertLog(config.alerts.jsonl)
    try:
        recorded, written = export_alerts(config.registry(), log, since=since,
                                          scale=config.alerts.scale)
    except (RegistryError, ArtifactError) as error:
        print_error(str(error))
        return EXIT_FAILED
    rich_console().print(f"{len(written)} alert(s) written to {log.path} ({len(recorded)} in the "
                     f"registry" + (f" since {since:%Y-%m-%d}" if since is not None else "")
                     + f", {len(recorded) - len(written)} already in the file).")
    return EXIT_OK
