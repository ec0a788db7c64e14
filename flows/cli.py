"""The ``fleet-health`` command line (also ``python -m flows``).

A top-level parser with the global options, and one command group per entry of
:data:`COMMANDS`: each entry adds its sub-parser and sets ``handler`` (``args -> exit
status``) on every leaf command. Add a command by adding an entry.

Global options (before the command; ``run``, ``reanalyze``, ``alerts``, ``baseline fit``,
``serve`` also take ``--config`` and ``--tracking-uri`` after it):

``--config PATH``       the fleet.toml (default ``$FLEET_HEALTH_CONFIG`` or ``./fleet.toml``)
``--tracking-uri URI``  overrides ``[mlflow] tracking_uri`` (and ``$FLEET_HEALTH_TRACKING_URI``)
``-v``                  show Prefect's and the libraries' log lines

Exit status: 0 all assets processed; 1 some assets failed (each named, with why) or the
operation failed; 2 bad usage or configuration; 3 Prefect's API server could not be started
or reached (one line says what to do).
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import sys
from typing import Callable

from registry.cli import EXIT_FAILED, EXIT_OK, EXIT_USAGE, _console, _error, add_baseline_commands

DEFAULT_TRACKING_URI = "sqlite:///mlflow.db"
DEFAULT_CONFIG = "fleet.toml"
#: seconds Prefect's temporary local server may take to start (Prefect's own default, 20 s,
#: is missed on a loaded machine: a first run in a new PREFECT_HOME took 27.7 s on an idle one)
EPHEMERAL_STARTUP_TIMEOUT = 180
EXIT_UNAVAILABLE = 3
_EPHEMERAL_TIMEOUT_MESSAGE = "Timed out while attempting to connect to ephemeral Prefect API"


# -- plumbing --------------------------------------------------------------------------------

def _prefect_environment(args: argparse.Namespace) -> None:
    """Quiet Prefect's and MLflow's console logs unless -v (Prefect's logs still reach its
    UI); no usage telemetry. Must run before prefect and mlflow are imported."""
    level = "INFO" if getattr(args, "verbose", False) else "WARNING"
    os.environ.setdefault("PREFECT_LOGGING_HANDLERS_CONSOLE_LEVEL", level)
    os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
    os.environ.setdefault("PREFECT_SERVER_LOGGING_LEVEL", "WARNING")
    os.environ.setdefault("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS",
                          str(EPHEMERAL_STARTUP_TIMEOUT))
    os.environ.setdefault("MLFLOW_LOGGING_LEVEL", level)


def _config_options(parser: argparse.ArgumentParser) -> None:
    """``--config``/``--tracking-uri`` also after the command (SUPPRESS keeps the global)."""
    parser.add_argument("--config", metavar="PATH", default=argparse.SUPPRESS,
                        help="the fleet.toml (default: ./fleet.toml)")
    parser.add_argument("--tracking-uri", metavar="URI", default=argparse.SUPPRESS,
                        help="MLflow tracking URI (overrides [mlflow] tracking_uri)")


def _load(args: argparse.Namespace):
    from flows.config import load_config

    return load_config(args.config).with_tracking_uri(args.tracking_uri)


def _usage_errors():
    from flows.config import ConfigError
    from flows.fleet import UsageError
    from graybox.exceptions import InvalidAssetIdError

    return (ConfigError, UsageError, InvalidAssetIdError)


def _guarded(function: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """Map errors to exit statuses: configuration and usage 2, anything else 1."""
    def run(args: argparse.Namespace) -> int:
        try:
            return function(args)
        except _usage_errors() as error:
            _error(str(error))
            return EXIT_USAGE
        except KeyboardInterrupt:
            _error("interrupted; rerun the command: committed results are kept and nothing "
                   "is duplicated")
            return 130
    run.__name__ = function.__name__
    return run


def _state_summary(state):
    """The run summary of a finished flow state, or raise its error."""
    from flows.results import RunSummary

    data = state.result(raise_on_failure=False)
    if isinstance(data, BaseException):
        raise data
    if not isinstance(data, dict):
        raise RuntimeError(f"the flow run ended {state.name}: {state.message}")
    return RunSummary.from_dict(data)


def _run_flow(args: argparse.Namespace, call: Callable[[], object]):
    """Run a flow with progress on stderr; return its RunSummary."""
    from flows import progress

    with progress.reporting(progress.for_stream(sys.stderr)):
        state = call()
    try:
        return _state_summary(state)
    except _usage_errors():
        raise
    except Exception as error:  # noqa: BLE001 - the flow itself failed: say why, exit 1
        raise _FlowFailed(f"{type(error).__name__}: {error}") from error


class _FlowFailed(RuntimeError):
    pass


def _report_summary(args: argparse.Namespace, summary, title: str) -> int:
    """Print a run summary (tables, or JSON) and the failures; return its exit status."""
    from flows.report import alert_table, fleet_table

    if args.json:
        print(json.dumps(summary.to_dict(), indent=2, default=str))
    else:
        console = _console()
        console.print(fleet_table(summary, title=title))
        if summary.alerts:
            console.print(alert_table(summary.alerts))
        elif summary.flow != "baseline":
            console.print("No alerts.")
        counts = ", ".join(f"{n} {status}" for status, n in summary.counts().items() if n)
        count = len(summary.assets)
        console.print(f"{count} asset{'' if count == 1 else 's'}: {counts or 'none'}.")
        if summary.unmatched:
            console.print(f"{len(summary.unmatched)} asset(s) in the telemetry match no vehicle "
                          f"class and were left alone: {', '.join(summary.unmatched[:20])}")
    for asset in summary.failed:
        print(f"fleet-health: {asset.asset_id} failed: {asset.reason()}", file=sys.stderr)
    return summary.exit_status


# -- run -------------------------------------------------------------------------------------

def add_run_command(subparsers) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "run", help="one nightly pass now, over every asset with new telemetry",
        description="One nightly pass: every asset's whole windows (UTC days) after its "
                    "watermark and before --as-of, against its baseline.")
    parser.add_argument("--as-of", metavar="WHEN",
                        help="process windows ending by this date/time (UTC; default now)")
    parser.add_argument("--asset", dest="assets", action="append", metavar="ASSET",
                        help="only this asset (repeatable)")
    parser.add_argument("--class", dest="vehicle_class", metavar="CLASS",
                        help="only this vehicle class")
    parser.add_argument("--json", action="store_true", help="print the run summary as JSON")
    _config_options(parser)
    parser.set_defaults(handler=_guarded(_run))
    return parser


def _run(args: argparse.Namespace) -> int:
    from flows.fleet import parse_time

    config = _load(args)
    as_of = None if args.as_of is None else parse_time(args.as_of, "--as-of").isoformat()
    _prefect_environment(args)
    from flows.nightly import nightly

    try:
        summary = _run_flow(args, lambda: nightly(
            config_path=str(config.path), as_of=as_of, assets=args.assets,
            vehicle_class=args.vehicle_class, tracking_uri=args.tracking_uri,
            return_state=True))
    except _FlowFailed as error:
        _error(f"the nightly run failed: {error}")
        return EXIT_FAILED
    return _report_summary(args, summary, f"Nightly run as of {summary.as_of[:16]} UTC")


# -- baseline fit ----------------------------------------------------------------------------

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
    fit.add_argument("--class", dest="vehicle_class", metavar="CLASS",
                     help="every asset of this vehicle class")
    fit.add_argument("--all", action="store_true", help="every asset of the fleet")
    fit.add_argument("--start", required=True, metavar="DATE", help="first healthy day (UTC)")
    fit.add_argument("--end", required=True, metavar="DATE",
                     help="end of the healthy range (exclusive)")
    fit.add_argument("--promote", action="store_true",
                     help="make each new fit the baseline at once (needs --reason)")
    fit.add_argument("--reason", help="why (recorded with the promotion)")
    fit.add_argument("--json", action="store_true", help="print the summary as JSON")
    _config_options(fit)
    fit.set_defaults(handler=_guarded(_baseline_fit))
    return parser


def _baseline_fit(args: argparse.Namespace) -> int:
    from flows.fleet import UsageError, parse_time

    if not (args.assets or args.vehicle_class or args.all):
        raise UsageError("name the assets, a --class, or --all")
    if args.promote and not (args.reason and args.reason.strip()):
        raise UsageError("--promote needs --reason (it is recorded with the promotion)")
    config = _load(args)
    start = parse_time(args.start, "--start")
    end = parse_time(args.end, "--end")
    from flows.baseline import baseline_windows

    baseline_windows(config, start, end)
    _prefect_environment(args)
    from flows.baseline import baseline

    try:
        summary = _run_flow(args, lambda: baseline(
            start=start.isoformat(), end=end.isoformat(), config_path=str(config.path),
            assets=args.assets or None, vehicle_class=args.vehicle_class,
            promote=args.promote, reason=args.reason, tracking_uri=args.tracking_uri,
            return_state=True))
    except _FlowFailed as error:
        _error(f"the baseline flow failed: {error}")
        return EXIT_FAILED
    return _report_summary(args, summary, f"Baselines from {start:%Y-%m-%d} to {end:%Y-%m-%d}")


# -- reanalyze -------------------------------------------------------------------------------

def add_reanalyze_command(subparsers) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "reanalyze", help="ad-hoc reanalysis of assets and a time range",
        description="Refit and compare [--start, --end) against the baseline (or --version); "
                    "moves no watermark and no alias.")
    parser.add_argument("--asset", dest="assets", action="append", metavar="ASSET",
                        help="asset to reanalyse (repeatable)")
    parser.add_argument("--class", dest="vehicle_class", metavar="CLASS",
                        help="every asset of this vehicle class")
    parser.add_argument("--start", required=True, metavar="WHEN", help="start (UTC)")
    parser.add_argument("--end", required=True, metavar="WHEN", help="end (UTC, exclusive)")
    parser.add_argument("--version", metavar="N|ALIAS",
                        help="compare with this version number or alias (default: baseline)")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    _config_options(parser)
    parser.set_defaults(handler=_guarded(_reanalyze))
    return parser


def _reanalyze(args: argparse.Namespace) -> int:
    from flows.fleet import UsageError, parse_time, range_windows

    if not (args.assets or args.vehicle_class):
        raise UsageError("name the assets (--asset A, repeatable) or a --class")
    config = _load(args)
    start = parse_time(args.start, "--start")
    end = parse_time(args.end, "--end")
    range_windows(start, end, config.nightly.window_delta, whole_only=False)
    _prefect_environment(args)
    from flows.reanalyze import reanalyze

    try:
        summary = _run_flow(args, lambda: reanalyze(
            start=start.isoformat(), end=end.isoformat(), assets=args.assets,
            config_path=str(config.path), vehicle_class=args.vehicle_class,
            version=args.version, tracking_uri=args.tracking_uri, return_state=True))
    except _FlowFailed as error:
        _error(f"the reanalysis failed: {error}")
        return EXIT_FAILED
    if not args.json:
        from rich.table import Table

        from flows.report import window_label

        table = Table(title="Reanalysed windows", title_justify="left")
        for column in ("asset", "window", "against", "max zeta/epsilon", "alarm", "run"):
            table.add_column(column, no_wrap=True)
        for asset in summary.assets:
            for w in asset.windows:
                ratio = "" if w.max_ratio is None else f"{w.max_ratio:.2f}"
                table.add_row(asset.asset_id, window_label(w.window_start, w.window_end),
                              f"v{asset.baseline_version}", ratio,
                              "[bold red]ALARM[/]" if w.alarm else "ok", w.run_id[:12])
        _console().print(table)
    return _report_summary(args, summary, f"Reanalysis {start:%Y-%m-%d %H:%M} → "
                                          f"{end:%Y-%m-%d %H:%M}")


# -- alerts ----------------------------------------------------------------------------------

def add_alerts_command(subparsers) -> argparse.ArgumentParser:
    parser = subparsers.add_parser("alerts", help="the alerts recorded",
                                   description="The nightly alerts (from the alerts file, or "
                                               "the registry with --from-registry).")
    parser.add_argument("--since", metavar="DATE", help="windows ending at or after DATE (UTC)")
    parser.add_argument("--asset", dest="assets", action="append", metavar="ASSET",
                        help="only this asset (repeatable)")
    parser.add_argument("--from-registry", action="store_true",
                        help="read the alerts from the MLflow registry (the system of record) "
                             "instead of the JSON-lines file")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    _config_options(parser)
    parser.set_defaults(handler=_guarded(_alerts))
    return parser


def _alerts(args: argparse.Namespace) -> int:
    from flows.alerts import AlertLog
    from flows.fleet import parse_time
    from flows.report import alert_table

    config = _load(args)
    since = None if args.since is None else parse_time(args.since, "--since")
    if args.from_registry:
        from graybox.exceptions import ArtifactError
        from registry.exceptions import RegistryError

        try:
            alerts = config.registry().alerts(since=since,
                                              major_ratio=config.alerts.major_ratio,
                                              critical_ratio=config.alerts.critical_ratio)
        except (RegistryError, ArtifactError) as error:
            _error(str(error))
            return EXIT_FAILED
        if args.assets:
            alerts = [a for a in alerts if a.asset_id in set(args.assets)]
    else:
        alerts = AlertLog(config.alerts.jsonl).read(since=since, assets=args.assets)
    if args.json:
        print(json.dumps([a.to_dict() for a in alerts], indent=2, default=str))
        return EXIT_OK
    console = _console()
    if not alerts:
        where = "the registry" if args.from_registry else str(config.alerts.jsonl)
        console.print(f"No alerts recorded in {where}" + (f" since {since:%Y-%m-%d}"
                                                          if since is not None else "") + ".")
        return EXIT_OK
    console.print(alert_table(alerts))
    return EXIT_OK


# -- simulate --------------------------------------------------------------------------------

def add_simulate_command(subparsers) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "simulate", help="write a simulated fleet in the telemetry layout, with chosen faults",
        description="Simulate gas-turbine vehicles (graybox.simulator) and write their "
                    "telemetry and fleet_truth.json. Without --fault or --healthy, "
                    "demo_fleet's faults are injected (friction, nonlinear, noise on up to "
                    "3 vehicles).")
    parser.add_argument("--out", required=True, metavar="DIR", help="telemetry root to write")
    parser.add_argument("--vehicles", type=_positive_int, default=8, metavar="N")
    parser.add_argument("--days", type=_positive_int, default=10, metavar="N")
    parser.add_argument("--seed", type=_nonnegative_int, default=0, metavar="S")
    parser.add_argument("--start", default="2026-01-01", metavar="DATE")
    parser.add_argument("--sample-interval", type=float, default=10.0, metavar="SECONDS")
    faults = parser.add_mutually_exclusive_group()
    faults.add_argument("--fault", action="append", metavar="ASSET:KIND:ONSET_DAY:MAGNITUDE",
                        help="inject a fault (repeatable); KIND is friction, nonlinear, noise, "
                             "bias or heavy_tails; ONSET_DAY counts days from --start")
    faults.add_argument("--healthy", action="store_true", help="no faults at all")
    parser.add_argument("--config-out", metavar="PATH",
                        help="also write a fleet.toml for this telemetry")
    parser.set_defaults(handler=_guarded(_simulate))
    return parser


def _int_at_least(low: int) -> Callable[[str], int]:
    """An argparse type: an integer >= ``low``."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be >= {low}, got {value}")
        return value
    return parse


_positive_int, _nonnegative_int = _int_at_least(1), _int_at_least(0)


def _simulate(args: argparse.Namespace) -> int:
    from flows.demo import parse_fault, simulated_fleet, write_simulation

    faults = None if args.fault is None else [parse_fault(text) for text in args.fault]
    spec = simulated_fleet(args.vehicles, args.days, args.seed, args.start,
                           args.sample_interval, faults=faults, healthy=args.healthy)
    from flows import progress

    with progress.reporting(progress.for_stream(sys.stderr)):
        write_simulation(spec, pathlib.Path(args.out), config_out=args.config_out)
    console = _console()
    console.print(f"Wrote {len(spec.vehicles)} vehicles x {spec.days} days "
                  f"({spec.sample_interval:g} s samples) to {args.out}")
    for vehicle in spec.vehicles:
        for fault in vehicle.faults:
            console.print(f"  {vehicle.asset_id}: {fault.kind} {fault.magnitude:g} from day "
                          f"{fault.onset_day:g}")
    if args.config_out:
        console.print(f"Configuration: {args.config_out}")
    return EXIT_OK


# -- serve -----------------------------------------------------------------------------------

def add_serve_command(subparsers) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "serve", help="serve the deployments with their schedules (nightly cron)",
        description="Serve the nightly (on [schedule] cron), baseline and reanalyze "
                    "deployments from this process until interrupted. Set PREFECT_API_URL to "
                    "a running Prefect server (prefect server start) to see them in its UI.")
    parser.add_argument("--dry-run", action="store_true",
                        help="print the deployments and exit")
    _config_options(parser)
    parser.set_defaults(handler=_guarded(_serve))
    return parser


def _serve(args: argparse.Namespace) -> int:
    config = _load(args)
    _prefect_environment(args)
    from flows.serve import build_deployments, serve_deployments

    deployments = build_deployments(config, tracking_uri=args.tracking_uri)
    console = _console()
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


# -- demo ------------------------------------------------------------------------------------

def add_demo_command(subparsers) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "demo", help="simulate a fleet with faults, fit baselines, run the nightly flow over "
                     "the following days, print the alerts and how to open the UIs",
        description="The whole product on a simulated fleet, in a work directory that holds "
                    "the telemetry, fleet.toml, the MLflow store and PREFECT_HOME.")
    parser.add_argument("--workdir", default="fleet-health-demo", metavar="DIR",
                        help="where everything goes (default: ./fleet-health-demo; a previous "
                             "demo there is replaced)")
    parser.add_argument("--vehicles", type=_positive_int, default=8, metavar="N")
    parser.add_argument("--days", type=_positive_int, default=10, metavar="N")
    parser.add_argument("--baseline-days", type=_positive_int, default=4, metavar="N")
    parser.add_argument("--seed", type=_nonnegative_int, default=0, metavar="S")
    parser.add_argument("--sample-interval", type=float, default=10.0, metavar="SECONDS")
    parser.set_defaults(handler=_guarded(_demo))
    return parser


def _demo(args: argparse.Namespace) -> int:
    from flows.demo import prepare_workdir, run_demo

    workdir = prepare_workdir(pathlib.Path(args.workdir))
    if "prefect" not in sys.modules:
        # the demo's Prefect database lives in the workdir, so its UI can show the runs
        os.environ["PREFECT_HOME"] = str(workdir / ".prefect")
        os.environ.pop("PREFECT_API_URL", None)
    _prefect_environment(args)
    return run_demo(workdir, vehicles=args.vehicles, days=args.days,
                    baseline_days=args.baseline_days, seed=args.seed,
                    sample_interval=args.sample_interval, console=_console())


# -- the parser ------------------------------------------------------------------------------

#: command name -> function adding its parser to the top-level subparsers
COMMANDS: dict[str, Callable[[argparse._SubParsersAction], argparse.ArgumentParser]] = {
    "demo": add_demo_command,
    "simulate": add_simulate_command,
    "baseline": add_baseline_group,
    "run": add_run_command,
    "reanalyze": add_reanalyze_command,
    "alerts": add_alerts_command,
    "serve": add_serve_command,
}


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every command of :data:`COMMANDS` mounted."""
    parser = argparse.ArgumentParser(
        prog="fleet-health",
        description="Gray-box fleet health: nightly residual models, drift and baselines.",
        epilog="Exit status: 0 all assets processed; 1 some assets failed (each named, with "
               "why); 2 bad usage or configuration; 3 Prefect's API server could not be "
               "started or reached.")
    parser.add_argument(
        "--config", metavar="PATH",
        default=os.environ.get("FLEET_HEALTH_CONFIG") or DEFAULT_CONFIG,
        help="the fleet configuration (default: $FLEET_HEALTH_CONFIG or %(default)s)")
    parser.add_argument(
        "--tracking-uri", metavar="URI",
        default=os.environ.get("FLEET_HEALTH_TRACKING_URI") or None,
        help="MLflow tracking URI: sqlite:///path.db (embedded) or http://host:port "
             "(default: $FLEET_HEALTH_TRACKING_URI, else [mlflow] tracking_uri of the "
             f"configuration, else {DEFAULT_TRACKING_URI})")
    parser.add_argument("-v", "--verbose", action="store_true",
                        help="show Prefect's log lines on the console")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in COMMANDS.values():
        add(commands)
    return parser


def _resolve_registry_uri(args: argparse.Namespace) -> int | None:
    """``baseline list/history/promote/...`` use the configuration's store when no URI is
    given; returns an exit status on a bad configuration."""
    if args.tracking_uri:
        return None
    from flows.config import ConfigError, load_config

    path = pathlib.Path(args.config)
    if path.exists():
        try:
            args.tracking_uri = load_config(path).tracking_uri
        except ConfigError as error:
            _error(str(error))
            return EXIT_USAGE
    else:
        args.tracking_uri = DEFAULT_TRACKING_URI
    return None


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 1 failed, 2 bad usage)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:           # argparse: 2 on bad usage, 0 after --help
        return int(stop.code or 0)
    if args.command != "demo":            # the demo first points PREFECT_HOME at its workdir
        _prefect_environment(args)
    if args.command == "baseline" and getattr(args, "baseline_command", None) != "fit":
        status = _resolve_registry_uri(args)
        if status is not None:
            return status
    try:
        return int(args.handler(args))
    except RuntimeError as error:
        if _EPHEMERAL_TIMEOUT_MESSAGE not in str(error):
            raise
        timeout = os.environ.get("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS")
        _error(f"Prefect's temporary API server did not start within {timeout} s (a busy "
               f"machine?): nothing was run. Retry, raise "
               f"PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS, or start a server once "
               f"(`prefect server start`) and set PREFECT_API_URL=http://127.0.0.1:4200/api.")
        return EXIT_UNAVAILABLE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
