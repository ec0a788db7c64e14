"""``fleet-health reanalyze``: ad-hoc reanalysis of assets and a time range."""
from __future__ import annotations

import argparse

from rich.table import Table

from flows.commands.plumbing import (asset_option, class_option, flow_command_options, load,
                                     prefect_environment, report_summary, run_flow,
                                     start_pool_early)
from flows.commands.temporary_server import TemporaryServer
from flows.errors import FlowFailed, UsageError
from flows.discovery import not_in_future, parse_time, range_windows
from flows.run_tables import window_label
from flows.results import RunSummary
from flows.terminal import EXIT_FAILED, print_error, rich_console


def add_reanalyze_command(subparsers) -> argparse.ArgumentParser:
    """Add ``reanalyze`` to the top-level subparsers."""
    parser = subparsers.add_parser(
        "reanalyze", help="ad-hoc reanalysis of assets and a time range",
        description="Refit and compare [--start, --end) against the baseline (or --version); "
                    "moves no watermark and no alias.")
    asset_option(parser, help="asset to reanalyse (repeatable)")
    class_option(parser, help="every asset of this vehicle class")
    parser.add_argument("--start", required=True, metavar="WHEN", help="start (UTC)")
    parser.add_argument("--end", required=True, metavar="WHEN", help="end (UTC, exclusive)")
    parser.add_argument("--version", metavar="N|ALIAS",
                        help="compare with this version number or alias (default: baseline)")
    parser.add_argument("--candidate-nights", type=_nights, metavar="N",
                        help="fit each window's candidate on it and the N - 1 windows before "
                             "it (default: [nightly] candidate_nights)")
    flow_command_options(parser, reanalyze)
    return parser


def _nights(text: str) -> int:
    """``--candidate-nights``: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return value


def reanalyze(args: argparse.Namespace) -> int:
    """Run the reanalysis flow; print its windows and summary; return the exit status."""
    if not (args.assets or args.vehicle_class):
        raise UsageError("name the assets (--asset A, repeatable) or a --class")
    config = load(args)
    start = not_in_future(parse_time(args.start, "--start"), "--start")
    end = parse_time(args.end, "--end")
    range_windows(start, end, config.nightly.window_delta, whole_only=False)
    prefect_environment(args)
    start_pool_early(config, args.assets, args.vehicle_class)
    # its child starts while the flow's modules load (prefect loads only for commands that
    # run flows, after prefect_environment)
    server = TemporaryServer().start()
    from flows.reanalyze import reanalyze as reanalyze_flow

    try:
        summary = run_flow(args, server, lambda: reanalyze_flow(
            start=start.isoformat(), end=end.isoformat(), assets=args.assets,
            config_path=str(config.path), vehicle_class=args.vehicle_class,
            version=args.version, tracking_uri=args.tracking_uri,
            candidate_nights=args.candidate_nights, return_state=True))
    except FlowFailed as error:
        print_error(f"the reanalysis failed: {error}")
        return EXIT_FAILED
    if not args.json:
        rich_console().print(window_table(summary))
    return report_summary(args, summary, f"Reanalysis {start:%Y-%m-%d %H:%M} → "
                                         f"{end:%Y-%m-%d %H:%M}")


def window_table(summary: RunSummary) -> Table:
    """Every reanalysed window of every asset, with its ratio and alarm, and every window
    that failed."""
    table = Table(title="Reanalysed windows", title_justify="left")
    for column in ("asset", "window", "against", "max zeta/epsilon", "channel tier", "alarm",
                   "run"):
        table.add_column(column, no_wrap=True)
    for asset in summary.assets:
        for w in asset.windows:
            ratio = "" if w.max_ratio is None else f"{w.max_ratio:.2f}"
            table.add_row(asset.asset_id, window_label(w.window_start, w.window_end),
                          f"v{asset.baseline_version}", ratio, w.max_ratio_at or "",
                          "[bold red]ALARM[/]" if w.alarm else "ok", w.run_id[:12])
        for error in asset.window_errors:       # the reason is printed below the tables
            table.add_row(asset.asset_id, f"{error.window_start[:16].replace('T', ' ')} ...",
                          f"v{asset.baseline_version}", "", "", "[bold]FAILED[/]",
                          error.kind or error.type)
    return table
