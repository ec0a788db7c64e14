"""``fleet-health check``: is everything in place for a run? What is wrong, and what to do.

It checks, in order, and reports each finding with its fix:

config      fleet.toml parses (else exit status 2, with the key at fault)
telemetry   the root exists; the assets found per class; listed assets without data
            (problem); assets no class claims and folders skipped (noted)
store       the tracking store is reachable (bounded wait for a server), readable and
            writable: a probe run with a tag and a small artifact is created in the
            ``fleet-health-check`` experiment, read back and deleted
prefect     Prefect's API answers (the temporary local server starts when none is set)
runs        a run of this fleet in progress (noted); orphaned flow runs (a killed run still
            Running) are marked Crashed (:mod:`flows.orphans`)
baseline    per asset: a baseline is promoted, loads and verifies through the registry's
            loader (its artifacts are read), and is calibrated

Exit status 0 when all is good, 1 when a problem was found, 2 for a usage or configuration
error. Nothing of the fleet's records is changed (the probe run is deleted; orphans are
marked Crashed, as the next run would).
"""
from __future__ import annotations

import argparse
import contextlib
import json
from dataclasses import asdict, dataclass

from flows.commands.plumbing import USAGE_ERRORS, config_options, load, prefect_environment
from flows.config import FleetConfig
from flows.terminal import EXIT_FAILED, EXIT_OK, EXIT_USAGE, print_error, rich_console

PROBLEM, NOTE, OK = "problem", "note", "ok"


@dataclass(frozen=True)
class Finding:
    """One thing ``check`` found: its area, subject, level (ok, note, problem), what it
    found and, for a problem, what to do."""

    area: str
    subject: str
    level: str
    detail: str
    fix: str = ""


def add_check_command(subparsers) -> argparse.ArgumentParser:
    """Add ``check`` to the top-level subparsers."""
    parser = subparsers.add_parser(
        "check", help="check the configuration, telemetry, stores, Prefect and baselines",
        description="Check that a run can work: the configuration, the telemetry layout "
                    "(assets found, unmatched, folders skipped), the MLflow store (reachable, "
                    "writable, every baseline's artifacts loadable), Prefect's API, and each "
                    "asset's baseline (present, calibrated, loadable). Orphaned flow runs "
                    "(killed while Running) are marked Crashed. Prints what it found and "
                    "what to do about each problem.",
        epilog="Exit status: 0 all good; 1 problems found; 2 usage or configuration error.")
    parser.add_argument("--json", action="store_true",
                        help="print the findings as JSON")
    config_options(parser)
    parser.set_defaults(handler=check)
    return parser


def check(args: argparse.Namespace) -> int:
    """Run every check; print the findings; return the exit status."""
    try:
        config = load(args)
    except USAGE_ERRORS as error:
        finding = Finding("config", str(args.config), PROBLEM, str(error),
                          "fix the named key of the configuration (see "
                          "docs/configuration.md)")
        return _report(args, [finding], EXIT_USAGE)
    prefect_environment(args)
    findings = [Finding("config", str(config.path), OK, "parses")]
    try:
        refs, telemetry = check_telemetry(config)
    except USAGE_ERRORS as error:
        findings.append(Finding("telemetry", str(config.telemetry_root), PROBLEM, str(error),
                                "point [telemetry] root at the telemetry store"))
        return _report(args, findings, EXIT_USAGE)
    findings += telemetry
    registry, store = check_store(config)
    findings += store
    findings += check_prefect()
    findings += check_runs(config)
    if registry is not None:
        findings += check_baselines(registry, refs)
    status = EXIT_FAILED if any(f.level == PROBLEM for f in findings) else EXIT_OK
    return _report(args, findings, status, config)


def check_telemetry(config: FleetConfig):
    """The assets with telemetry, and the findings of the telemetry layout."""
    from flows.discovery import discover
    from graybox.telemetry.layout import ASSET_PREFIX

    fleet = discover(config)
    root = config.telemetry_root
    per_class: dict[str, int] = {}
    for ref in fleet.assets:
        per_class[ref.vehicle_class] = per_class.get(ref.vehicle_class, 0) + 1
    found = ", ".join(f"{n} {name}" for name, n in per_class.items()) or "none"
    findings = [Finding("telemetry", str(root), OK if fleet.assets else PROBLEM,
                        f"{len(fleet.assets)} asset(s) found ({found})",
                        "" if fleet.assets else
                        "write telemetry as <root>/asset_id=<id>/date=<YYYY-MM-DD>/*.parquet "
                        "or fix [telemetry] root and the classes' assets patterns")]
    for ref in fleet.without_telemetry:
        findings.append(Finding("telemetry", ref.asset_id, PROBLEM,
                                f"listed in class {ref.vehicle_class!r} but no telemetry in "
                                f"{root}", f"write its telemetry under {root}/"
                                f"{ASSET_PREFIX}{ref.asset_id}/, or remove it from the class"))
    if fleet.unmatched:
        findings.append(Finding("telemetry", "unmatched", NOTE,
                                f"{len(fleet.unmatched)} asset(s) no vehicle class claims, left "
                                f"alone by every run: {', '.join(fleet.unmatched[:20])}",
                                "add them to a class's assets to monitor them"))
    known = {f"{ASSET_PREFIX}{a}" for a in [r.asset_id for r in fleet.assets] + fleet.unmatched}
    skipped = sorted(p.name for p in root.iterdir()
                     if not p.name.startswith(".") and p.name not in known)
    if skipped:
        findings.append(Finding("telemetry", "skipped", NOTE,
                                f"{len(skipped)} entr(y/ies) of the root are not asset folders "
                                f"(asset_id=<valid id>) and are skipped: {', '.join(skipped[:20])}",
                                f"rename them {ASSET_PREFIX}<id> to include them"))
    return fleet.assets, findings


def check_store(config: FleetConfig):
    """(registry or None, findings): the store reachable, readable and writable."""
    from flows.store_probe import require_store
    from flows.errors import StoreUnavailable
    from registry import resolve_store

    uri = config.tracking_uri
    store = resolve_store(uri)
    fix_uri = "fix [mlflow] tracking_uri (or --tracking-uri)"
    if store.db_path is not None and not store.db_path.exists():
        return None, [Finding("store", uri, PROBLEM, f"{store.db_path} does not exist: no "
                              f"baseline was ever fitted into this store",
                              "fit baselines (fleet-health baseline fit --all --start ... "
                              f"--end ... --promote --reason ...), or {fix_uri}")]
    try:
        require_store(uri)
        from registry import Registry

        registry = Registry(uri)
        registry.probe_read()
    except StoreUnavailable as error:
        return None, [Finding("store", uri, PROBLEM, str(error), f"start the server, or {fix_uri}")]
    except Exception as error:  # noqa: BLE001 - any failure to read is the finding
        return None, [Finding("store", uri, PROBLEM,
                              f"cannot be read: {type(error).__name__}: {error}",
                              f"restore the store from a backup, or {fix_uri}")]
    findings = [Finding("store", uri, OK, "reachable and readable")]
    try:
        experiment = registry.probe_write()
    except Exception as error:  # noqa: BLE001
        findings.append(Finding("store", uri, PROBLEM,
                                f"not writable: {type(error).__name__}: {error}",
                                "make the store (and its artifact location) writable for "
                                "this user; runs record every window there"))
    else:
        findings.append(Finding("store", "artifacts", OK,
                                f"writable (a probe run in experiment {experiment!r} wrote a "
                                f"tag and an artifact, read them back and was deleted)"))
    return registry, findings


def check_prefect() -> list[Finding]:
    """Prefect's API answers (starting the temporary local server if none is set)."""
    from prefect.client.orchestration import get_client
    from prefect.settings import PREFECT_API_URL

    where = PREFECT_API_URL.value() or "the temporary local server"
    try:
        with get_client(sync_client=True) as client:
            error = client.api_healthcheck()
    except Exception as failure:  # noqa: BLE001 - e.g. the temporary server did not start
        error = failure
    if error is None:
        return [Finding("prefect", where, OK, "the API answers")]
    return [Finding("prefect", where, PROBLEM, f"the API does not answer: "
                    f"{type(error).__name__}: {error}",
                    "start it (prefect server start) and set PREFECT_API_URL, or unset "
                    "PREFECT_API_URL to use a temporary local server")]


def check_runs(config: FleetConfig) -> list[Finding]:
    """A run of the fleet in progress (noted), orphaned flow runs (marked Crashed)."""
    from flows.orphans import crash_orphans
    from flows.run_lock import RunLock
    from registry import RegistryError, file_lock

    lock = RunLock.of(config.tracking_uri)
    findings = []
    with contextlib.ExitStack() as stack:
        try:
            stack.enter_context(file_lock(lock.path, timeout=0))
        except RegistryError:
            holder = lock.holder()
            findings.append(Finding("runs", "run lock", NOTE, f"in progress: "
                                    f"{holder.describe() if holder else 'a run'} holds "
                                    f"{lock.path}"))
            dead = None
        else:
            dead = lock.holder()
        try:
            orphans = crash_orphans(dead)
        except Exception as error:  # noqa: BLE001
            return findings + [Finding("runs", "orphans", PROBLEM,
                                       f"could not look for orphaned flow runs: "
                                       f"{type(error).__name__}: {error}",
                                       "make Prefect's API reachable (see 'prefect')")]
        if dead is not None:
            lock.holder_path.unlink(missing_ok=True)
    for orphan in orphans:
        findings.append(Finding("runs", orphan.name, NOTE, f"orphaned {orphan.describe()}: "
                                "marked Crashed (its notification sent)",
                                "rerun: what it committed is kept, the rest is done again"))
    if not orphans:
        findings.append(Finding("runs", "orphans", OK, "no orphaned flow run"))
    return findings


def check_baselines(registry, refs) -> list[Finding]:
    """Per asset: baseline promoted, loadable (artifacts verified), calibrated."""
    findings = []
    for ref in refs:
        fit = (f"fleet-health baseline fit {ref.asset_id} --start DAY --end DAY --promote "
               f"--reason TEXT")
        try:
            loaded = registry.baseline(ref.asset_id)
        except Exception as error:  # noqa: BLE001 - a baseline that cannot be loaded
            findings.append(Finding("baseline", ref.asset_id, PROBLEM,
                                    f"unusable baseline: {type(error).__name__}: {error}",
                                    f"fit and promote a new one ({fit}), or "
                                    f"fleet-health baseline rollback {ref.asset_id}"))
            continue
        if loaded is None:
            findings.append(Finding("baseline", ref.asset_id, PROBLEM, "no baseline: "
                                    "the nightly run skips it", f"fit and promote one: {fit}"))
        elif loaded.calibration is None:
            findings.append(Finding("baseline", ref.asset_id, PROBLEM,
                                    f"baseline v{loaded.version} is not calibrated (no epsilon)",
                                    f"fit and promote a calibrated one: {fit}"))
        else:
            findings.append(Finding("baseline", ref.asset_id, OK,
                                    f"v{loaded.version}, calibrated, loads and verifies"))
    return findings


def _report(args, findings: list[Finding], status: int, config: FleetConfig | None = None
            ) -> int:
    problems = [f for f in findings if f.level == PROBLEM]
    if args.json:
        print(json.dumps({"config": str(config.path) if config else str(args.config),
                          "tracking_uri": config.tracking_uri if config else None,
                          "ok": status == EXIT_OK, "exit_status": status,
                          "problems": len(problems),
                          "findings": [asdict(f) for f in findings]}, indent=2))
        return status
    from rich.markup import escape
    from rich.table import Table

    table = Table(title="fleet-health check", title_justify="left")
    for column in ("area", "subject", "", "found", "what to do"):
        table.add_column(column, no_wrap=column in ("area", ""), overflow="fold")
    marks = {OK: "[green]ok[/]", NOTE: "[yellow]note[/]", PROBLEM: "[bold red]PROBLEM[/]"}
    for f in findings:
        table.add_row(f.area, escape(f.subject), marks[f.level], escape(f.detail),
                      escape(f.fix))
    console = rich_console()
    console.print(table)
    if problems:
        console.print(f"{len(problems)} problem(s) found.")
        for f in problems:
            # a detail that already names its subject (a config error: "fleet.toml: ...")
            # is not prefixed with it again
            named = f.detail.startswith(f"{f.subject}:")
            text = f"{f.area} {f.detail}" if named else f"{f.area} {f.subject}: {f.detail}"
            print_error(text + (f" -> {f.fix}" if f.fix else ""))
    else:
        console.print("All good.")
    return status
