"""``fleet-health import``: CSV or Parquet exports into the telemetry layout.

Reading an export is :mod:`graybox.telemetry.exports`, merging it into the day partitions
:mod:`graybox.telemetry.merging`, marking the changed days for the nightly run
:mod:`graybox.telemetry.changes`; this module parses the options and prints what happened.
"""
from __future__ import annotations

import argparse
import pathlib
import sys

from rich.table import Table

from flows import progress
from flows.commands.plumbing import guarded
from flows.config import load_config
from flows.errors import UsageError
from graybox.telemetry.changes import mark_changed
from graybox.telemetry.exports import ExportError, ExportFormat, ExportRead, read_export
from graybox.telemetry.merging import DayImport, ImportConflict, plan_import, write_day
from flows.terminal import EXIT_FAILED, EXIT_OK, print_error, rich_console

#: export files taken from a directory given as FILE
EXPORT_SUFFIXES = (".csv", ".parquet")
#: bad rows named per file (the count says how many more)
BAD_ROWS_SHOWN = 20

EXAMPLES = """\
examples:
  # one machine per file, local time, own column names, European separators
  fleet-health import exports/pump-7.csv --asset P-7 --timestamp-column Zeit \\
      --timestamp-format "%d.%m.%Y %H:%M:%S" --timezone Europe/Berlin \\
      --delimiter ";" --decimal "," --map Druck=pressure --map Temp=temperature

  # one Parquet file for the whole fleet, UTC, an asset column; see first, then write
  fleet-health import fleet-2026-03.parquet --asset-column vehicle --dry-run
  fleet-health import fleet-2026-03.parquet --asset-column vehicle

  # every export of a folder, the asset id taken from each file name (T-001.csv -> T-001)
  fleet-health import exports/ --root telemetry

Channel names are those your class's white box reads (its required columns, fleet.toml's
[classes.<name>] model): map the export's columns to them with --map.
Re-importing the same rows adds nothing; new rows are merged into their UTC day; a timestamp
already stored with another value is an error naming the file and line. Days that gained rows
are marked, and the next `fleet-health run` re-analyses those before its watermark.
"""


def add_import_command(subparsers) -> argparse.ArgumentParser:
    """Add ``import`` to the top-level subparsers."""
    parser = subparsers.add_parser(
        "import", help="import CSV or Parquet exports into the telemetry layout",
        description="Write CSV or Parquet exports (a historian's, a data logger's) into\n"
                    "<root>/asset_id=<id>/date=<YYYY-MM-DD>/ in UTC. Nothing is written when\n"
                    "a file has bad rows (each named with file and line: CSV lines count\n"
                    "from 1 with the header, Parquet rows from 0) unless --skip-bad-rows.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", nargs="+", metavar="FILE",
                        help="export files (.csv or .parquet; other suffixes are read as CSV), "
                             "or folders of them")
    parser.add_argument("--root", metavar="DIR",
                        help="telemetry root to write (default: [telemetry] root of the "
                             "configuration)")
    parser.add_argument("--config", metavar="PATH", default=argparse.SUPPRESS,
                        help="the fleet.toml giving the root (default: ./fleet.toml)")
    parser.add_argument("--timestamp-column", default="timestamp", metavar="NAME",
                        help="column with the time of each row (default: %(default)s)")
    parser.add_argument("--timestamp-format", metavar="FMT",
                        help="strptime format such as '%%d.%%m.%%Y %%H:%%M:%%S', or unix / "
                             "unix_ms for epoch seconds / milliseconds (default: ISO 8601)")
    parser.add_argument("--timezone", default="UTC", metavar="TZ",
                        help="IANA zone of timestamps without offset, e.g. Europe/Berlin; "
                             "converted to UTC (default: %(default)s)")
    assets = parser.add_mutually_exclusive_group()
    assets.add_argument("--asset-column", metavar="NAME",
                        help="column naming each row's asset (one file for many assets)")
    assets.add_argument("--asset", metavar="ID",
                        help="the asset of every row (default: each file's name without "
                             "suffix)")
    parser.add_argument("--map", action="append", default=[], metavar="COLUMN=CHANNEL",
                        help="import the export's COLUMN as CHANNEL (repeatable); with any "
                             "--map only the mapped columns are imported, without, every "
                             "column but the timestamp and asset ones")
    parser.add_argument("--delimiter", default=",", metavar="CHAR",
                        help="CSV field separator (default: %(default)r)")
    parser.add_argument("--decimal", default=".", metavar="CHAR",
                        help="decimal mark of CSV numbers (default: %(default)r)")
    parser.add_argument("--skip-bad-rows", action="store_true",
                        help="import the good rows of files with bad rows (named on stderr)")
    parser.add_argument("--dry-run", action="store_true",
                        help="show what would be written (asset, day, rows new/existing); "
                             "write nothing")
    parser.set_defaults(handler=guarded(import_exports))
    return parser


def import_exports(args: argparse.Namespace) -> int:
    """Read, check, merge and write the exports; return the exit status."""
    fmt = export_format(args)
    root = pathlib.Path(args.root) if args.root else load_config(args.config).telemetry_root
    files = export_files(args.files)
    with progress.reporting(progress.for_stream(sys.stderr)):
        try:
            reads = read_all(files, fmt)
        except ExportError as error:
            print_error(str(error))
            return EXIT_FAILED
        if report_bad_rows(reads, args.skip_bad_rows):
            return EXIT_FAILED
        try:
            days = plan_import(root, [rows for read in reads for rows in read.assets])
        except ImportConflict as error:
            print_error(f"conflicting rows, nothing written:\n{error}")
            return EXIT_FAILED
        console = rich_console()
        console.print(day_table(days, dry_run=args.dry_run))
        changed = [day for day in days if day.changed]
        if args.dry_run:
            console.print(f"Dry run: would add {sum(d.new_rows for d in changed)} rows to "
                          f"{len(changed)} asset-day(s) under {root}; nothing written.")
            return EXIT_OK
        write_days(root, changed)
    console.print(summary_line(root, days))
    return EXIT_OK


def export_format(args: argparse.Namespace) -> ExportFormat:
    """The :class:`ExportFormat` of the options (a bad one is a usage error)."""
    column_map = {}
    for text in args.map:
        column, sep, channel = text.partition("=")
        if not sep or not column.strip() or not channel.strip():
            raise UsageError(f"--map {text!r}: expected COLUMN=CHANNEL")
        column_map[column.strip()] = channel.strip()
    try:
        return ExportFormat(timestamp_column=args.timestamp_column,
                            timestamp_format=args.timestamp_format, timezone=args.timezone,
                            asset_column=args.asset_column, asset_id=args.asset,
                            column_map=column_map, delimiter=args.delimiter,
                            decimal=args.decimal)
    except ValueError as error:
        raise UsageError(str(error)) from None


def export_files(names: list[str]) -> list[pathlib.Path]:
    """The files named, folders replaced by their ``.csv`` and ``.parquet`` files."""
    files = []
    for name in names:
        path = pathlib.Path(name)
        if path.is_dir():
            found = sorted(p for p in path.iterdir() if p.is_file()
                           and p.suffix.lower() in EXPORT_SUFFIXES and not p.name.startswith("."))
            if not found:
                raise UsageError(f"{path}: no .csv or .parquet file in this folder")
            files += found
        elif path.is_file():
            files.append(path)
        else:
            raise UsageError(f"{path}: no such file or folder")
    return files


def read_all(files: list[pathlib.Path], fmt: ExportFormat) -> list[ExportRead]:
    """Every export read, with progress per file."""
    progress.start("reading exports", len(files))
    reads = []
    for path in files:
        read = read_export(path, fmt)
        reads.append(read)
        progress.advance(text=f"{path.name}: {read.rows} rows, {len(read.bad_rows)} bad",
                         failed=int(bool(read.bad_rows)))
    return reads


def report_bad_rows(reads: list[ExportRead], skip: bool) -> bool:
    """Name the bad rows on stderr; True when the import must stop (bad rows, no skip)."""
    bad = [read for read in reads if read.bad_rows]
    for read in bad:
        for row in read.bad_rows[:BAD_ROWS_SHOWN]:
            print(f"fleet-health: bad row: {row}", file=sys.stderr)
        more = len(read.bad_rows) - BAD_ROWS_SHOWN
        if more > 0:
            print(f"fleet-health: ... and {more} more bad rows in {read.file}", file=sys.stderr)
    if bad and not skip:
        total = sum(len(read.bad_rows) for read in bad)
        print_error(f"{total} bad row(s) in {len(bad)} file(s): nothing written (fix them, or "
               f"--skip-bad-rows to import the other rows)")
        return True
    return False


def day_table(days: list[DayImport], dry_run: bool) -> Table:
    """One line per asset-day: rows new and existing, and what is (or would be) done."""
    table = Table(title="Would write" if dry_run else "Imported", title_justify="left")
    for column in ("asset", "day (UTC)", "new rows", "existing rows", "action"):
        table.add_column(column, no_wrap=True)
    for day in days:
        action = ("unchanged" if not day.changed else "new day" if not day.existing_rows
                  else "merged")
        table.add_row(day.asset_id, day.day.isoformat(), str(day.new_rows),
                      str(day.existing_rows), action)
    return table


def write_days(root: pathlib.Path, changed: list[DayImport]) -> None:
    """Write the changed asset-days and mark them for the nightly run, with progress."""
    progress.start("writing asset-days", len(changed))
    for day in changed:
        mark_changed(root, day.asset_id, [day.day])   # first: a crash between re-analyses
        write_day(root, day)                            # a day in vain, never misses one
        progress.advance(text=f"{day.asset_id} {day.day}: +{day.new_rows} rows")


def summary_line(root: pathlib.Path, days: list[DayImport]) -> str:
    """What the import did and what happens next."""
    changed = [day for day in days if day.changed]
    merged = [day for day in changed if day.existing_rows]
    text = (f"Added {sum(d.new_rows for d in changed)} rows to {len(changed)} asset-day(s) "
            f"under {root} ({len(merged)} merged into existing days); "
            f"{len(days) - len(changed)} asset-day(s) already held every row.")
    if changed:
        text += (" The next `fleet-health run` analyses the new days and re-analyses the "
                 "changed ones before its watermark.")
    return text
