"""``fleet-health report --out DIR``: the fleet at a glance as a static HTML page."""
from __future__ import annotations

import argparse
import json
import pathlib
import textwrap

import pandas as pd

from flows.commands.plumbing import config_options, guarded, load, positive_int
from flows.discovery import parse_time
from flows.fleet_view import DEFAULT_NIGHTS, DEFAULT_TOP, collect_view
from graybox.exceptions import ArtifactError
from flows.terminal import EXIT_FAILED, EXIT_OK, print_error
from registry import RegistryError

PAGE_FILE = "index.html"


def _paragraphs(text: str) -> str:
    """``|``-separated paragraphs, each wrapped (the raw formatter keeps the breaks)."""
    return "\n\n".join(textwrap.fill(part, 79) for part in text.split("|"))


def add_report_command(subparsers) -> argparse.ArgumentParser:
    """Add ``report`` to the top-level subparsers."""
    parser = subparsers.add_parser(
        "report", help="the fleet at a glance: a static HTML page with the heat map",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=_paragraphs(
                    "Write the fleet at a glance as a static, self-contained HTML page "
                    f"(DIR/{PAGE_FILE}, the heat map inline) with fleet_heatmap.png and "
                    "fleet_view.json beside it.|"
                    "The heat map has one row per asset and one column per night (UTC date "
                    "a window starts on); a cell is the asset's worst zeta/epsilon ratio of "
                    "the night over its tiers and channels (above 1: an alarm). Failed, "
                    "stale, unusable-baseline, not-operating and dormant asset-nights are "
                    "marked F, S, U, N, D; a night "
                    "without a recorded window is hatched. Rows are sorted worst first; "
                    "below the --top worst, the rest are folded into one band row. The page "
                    "also has the alert table of those nights and the coverage counts "
                    "(assets monitored, stale, failed, without baseline) of the latest "
                    "nightly run. Read from the registry: the nightly candidates and the "
                    "nights' fleet-level runs (experiment fleet-health/fleet)."))
    parser.add_argument("--out", required=True, type=pathlib.Path, metavar="DIR",
                        help="directory to write the page into (created if missing)")
    parser.add_argument("--nights", type=positive_int, default=DEFAULT_NIGHTS, metavar="N",
                        help="how many nights, ending with the last (default %(default)s)")
    parser.add_argument("--last-night", metavar="DATE",
                        help="the last night shown (UTC date; default: the latest night with "
                             "a recorded candidate or nightly run)")
    parser.add_argument("--top", type=positive_int, default=DEFAULT_TOP, metavar="K",
                        help="assets shown one row each before the rest are folded "
                             "(default %(default)s)")
    config_options(parser)
    parser.set_defaults(handler=guarded(report))
    return parser


def report(args: argparse.Namespace) -> int:
    """Write the page; print its path; return the exit status."""
    config = load(args)
    from flows.fleet_plot import heatmap_png          # matplotlib loads only here
    from flows.html_report import render_page

    registry = config.registry()
    try:
        if args.last_night is not None:
            last = parse_time(args.last_night, "--last-night").strftime("%Y-%m-%d")
        else:
            last = registry.latest_night()
            if last is None:
                print_error(f"nothing recorded in {registry.tracking_uri} yet: run the nightly "
                       f"flow first (fleet-health run)")
                return EXIT_FAILED
        view = collect_view(registry, last, args.nights)
        first = pd.Timestamp(view.nights[0], tz="UTC")
        end = pd.Timestamp(last, tz="UTC") + pd.Timedelta(days=1)
        alerts = [a for a in registry.alerts(since=first, scale=config.alerts.scale)
                  if first <= pd.Timestamp(a.window_start) < end]
    except (RegistryError, ArtifactError) as error:
        print_error(str(error))
        return EXIT_FAILED
    png = heatmap_png(view, args.top)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "fleet_heatmap.png").write_bytes(png)
    (args.out / "fleet_view.json").write_text(json.dumps(view.to_dict(), indent=1),
                                              encoding="utf-8")
    page = args.out / PAGE_FILE
    page.write_text(render_page(view, png, alerts), encoding="utf-8")
    flagged = sum(row.flagged for row in view.rows)
    print(f"{page}: {len(view.rows)} assets over nights {view.nights[0]} to {view.nights[-1]}, "
          f"{flagged} flagged, {len(alerts)} alert(s)")
    return EXIT_OK
