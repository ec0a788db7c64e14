"""``fleet-health baseline ...``: review and move baselines from the command line.

Mounted on the top-level parser of :mod:`flows.cli` with :func:`add_baseline_commands`::

    fleet-health baseline list [--class C] [--json]
    fleet-health baseline history ASSET [--json]
    fleet-health baseline promote ASSET [--version N] --reason TEXT
    fleet-health baseline reject ASSET --version N --reason TEXT
    fleet-health baseline rollback ASSET --reason TEXT

The top-level parser provides ``--tracking-uri``. Exit status: 0 done, 1 the operation
failed (refused promotion, unknown asset or version, unreadable artifacts), 2 bad usage
(including a malformed asset id or class name).
"""
from __future__ import annotations

import argparse
import json
import sys
from typing import Callable

import pandas as pd

from graybox.exceptions import ArtifactError, InvalidAssetIdError
from flows.terminal import EXIT_FAILED, EXIT_OK, EXIT_USAGE, print_error, rich_console
from registry import RegistryError


def add_baseline_commands(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``baseline`` command group to a top-level parser's subparsers.

    Every subcommand sets ``handler`` (``args -> exit status``); the top-level parser must
    define ``--tracking-uri``.

    Returns
    -------
    argparse.ArgumentParser
        The ``baseline`` parser (so callers can add more subcommands, e.g. ``fit``).
    """
    parser = subparsers.add_parser("baseline", help="review baselines: list, history, promote, "
                                                    "reject, rollback",
                                   description="Review and move the baseline of each asset.")
    commands = parser.add_subparsers(dest="baseline_command", required=True, metavar="SUBCOMMAND")

    listing = commands.add_parser("list", help="every asset with its baseline and candidate")
    listing.add_argument("--class", dest="vehicle_class", metavar="CLASS",
                         help="only assets of this vehicle class")
    listing.add_argument("--json", action="store_true", help="print JSON instead of a table")
    listing.set_defaults(handler=_list)

    history = commands.add_parser("history", help="every version of one asset")
    history.add_argument("asset_id", metavar="ASSET")
    history.add_argument("--json", action="store_true", help="print JSON instead of a table")
    history.set_defaults(handler=_history)

    promote = commands.add_parser("promote", help="make a calibrated version the baseline")
    promote.add_argument("asset_id", metavar="ASSET")
    promote.add_argument("--version", type=_positive, metavar="N",
                         help="version to promote (default: the candidate)")
    promote.add_argument("--reason", required=True, help="why (recorded with the promotion)")
    promote.add_argument("--json", action="store_true", help="print JSON instead of text")
    promote.set_defaults(handler=_promote)

    reject = commands.add_parser("reject", help="mark a version rejected")
    reject.add_argument("asset_id", metavar="ASSET")
    reject.add_argument("--version", type=_positive, required=True, metavar="N")
    reject.add_argument("--reason", required=True, help="why (recorded with the rejection)")
    reject.add_argument("--json", action="store_true", help="print JSON instead of text")
    reject.set_defaults(handler=_reject)

    rollback = commands.add_parser("rollback", help="restore the previous baseline")
    rollback.add_argument("asset_id", metavar="ASSET")
    rollback.add_argument("--reason", required=True, help="why (recorded with the rollback)")
    rollback.add_argument("--json", action="store_true", help="print JSON instead of text")
    rollback.set_defaults(handler=_rollback)
    return parser


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a version number") from None
    if value < 1:
        raise argparse.ArgumentTypeError("version numbers start at 1")
    return value


# -- plumbing --------------------------------------------------------------------------------


def _guarded(function: Callable[[argparse.Namespace], int], *,
             needs_existing_store: bool = False) -> Callable[[argparse.Namespace], int]:
    def run(args: argparse.Namespace) -> int:
        from registry import resolve_store

        try:
            store = resolve_store(args.tracking_uri)
            if needs_existing_store and store.db_path is not None and not store.db_path.exists():
                print_error(f"no registry at {store.db_path} (nothing recorded yet); "
                       f"pass --tracking-uri or set FLEET_HEALTH_TRACKING_URI")
                return EXIT_FAILED
            return function(args)
        except (InvalidAssetIdError, ValueError) as error:
            print_error(str(error))
            return EXIT_USAGE
        except (RegistryError, ArtifactError) as error:   # the store's failures too
            print_error(str(error))
            return EXIT_FAILED
    return run


def _registry(args: argparse.Namespace):
    from registry import Registry

    return Registry(args.tracking_uri)


def _when(value: str | None) -> str:
    return "" if not value else pd.Timestamp(value).strftime("%Y-%m-%d %H:%M")


def _window(info) -> str:
    if info is None:
        return ""
    return f"{_when(info.window_start)} → {_when(info.window_end)}"


def _alarm(info) -> str:
    if info is None or info.alarm is None:
        return ""
    return "[bold red]ALARM[/]" if info.alarm else "ok"


# -- handlers --------------------------------------------------------------------------------

def _list_impl(args: argparse.Namespace) -> int:
    summaries = _registry(args).list_baselines(args.vehicle_class)
    if args.json:
        print(json.dumps([s.to_dict() for s in summaries], indent=2))
        return EXIT_OK
    from rich.table import Table

    console = rich_console()
    if not summaries:
        console.print("No assets recorded" + (f" in class {args.vehicle_class!r}"
                                              if args.vehicle_class else "") + ".")
        return EXIT_OK
    count = len(summaries)
    table = Table(title=f"Baselines ({count} asset{'' if count == 1 else 's'})", title_justify="left")
    for column in ("asset", "class", "baseline", "baseline window", "promoted", "candidate",
                   "candidate window", "drift", "latest", "watermark"):
        table.add_column(column, no_wrap=True)
    for s in summaries:
        base, cand = s.baseline, s.candidate
        table.add_row(s.asset_id, s.vehicle_class or "",
                      f"v{base.version}" if base else "[yellow]none[/]", _window(base),
                      _when(base.promoted_at) if base else "",
                      f"v{cand.version}" if cand else "", _window(cand), _alarm(cand),
                      f"v{s.latest_version}" if s.latest_version else "", _when(s.watermark))
    console.print(table)
    return EXIT_OK


def _history_impl(args: argparse.Namespace) -> int:
    versions = _registry(args).history(args.asset_id)
    if args.json:
        print(json.dumps([v.to_dict() for v in versions], indent=2))
        return EXIT_OK
    from rich.table import Table

    table = Table(title=f"Versions of {args.asset_id}", title_justify="left")
    for column in ("version", "status", "role", "window", "calibrated", "drift", "created",
                   "note"):
        table.add_column(column, no_wrap=column != "note")
    styles = {"baseline": "bold green", "candidate": "cyan", "rejected": "red"}
    for v in reversed(versions):
        notes = []
        if v.promoted_at:
            notes.append(f"promoted {_when(v.promoted_at)} by {v.promoted_by}: {v.promotion_reason}")
        if v.rolled_back_at:
            notes.append(f"rolled back {_when(v.rolled_back_at)} by {v.rolled_back_by}: "
                         f"{v.rollback_reason}")
        if v.rejected:
            notes.append(f"rejected {_when(v.rejected_at)} by {v.rejected_by}: {v.rejection_reason}")
        if v.baseline_version is not None:
            notes.append(f"vs baseline v{v.baseline_version}")
        style = styles.get(v.status)
        status = f"[{style}]{v.status}[/]" if style else v.status
        table.add_row(f"v{v.version}", status, v.role or "", _window(v),
                      "yes" if v.calibrated else "no", _alarm(v), _when(v.created),
                      "; ".join(notes))
    rich_console().print(table)
    return EXIT_OK


def _report(args: argparse.Namespace, info, message: str) -> int:
    if args.json:
        print(json.dumps(info.to_dict(), indent=2))
    else:
        rich_console().print(message)
    return EXIT_OK


def _promote_impl(args: argparse.Namespace) -> int:
    info = _registry(args).promote(args.asset_id, args.version, reason=args.reason)
    return _report(args, info, f"{args.asset_id}: baseline is now v{info.version} "
                               f"({_window(info)})")


def _reject_impl(args: argparse.Namespace) -> int:
    info = _registry(args).reject(args.asset_id, args.version, reason=args.reason)
    return _report(args, info, f"{args.asset_id}: v{info.version} rejected")


def _rollback_impl(args: argparse.Namespace) -> int:
    info = _registry(args).rollback(args.asset_id, reason=args.reason)
    return _report(args, info, f"{args.asset_id}: baseline rolled back to v{info.version} "
                               f"({_window(info)})")


_list = _guarded(_list_impl, needs_existing_store=True)
_history = _guarded(_history_impl, needs_existing_store=True)
_promote = _guarded(_promote_impl, needs_existing_store=True)
_reject = _guarded(_reject_impl, needs_existing_store=True)
_rollback = _guarded(_rollback_impl, needs_existing_store=True)
