"""``fleet-health demo`` (and ``simulate``): the whole product on a simulated fleet.

1. simulate :func:`graybox.simulation.demo_fleet` (8 gas-turbine vehicles over 10 days, 10 s
   samples; faults friction 0.5, nonlinear 0.3 and noise 1.0 on three of them, with onsets
   in days 7-8) and write it in the telemetry layout with ``fleet_truth.json``;
2. write a ``fleet.toml`` in the work directory (MLflow store ``mlflow.db`` beside it,
   Prefect's database in ``.prefect``);
3. run the ``baseline`` flow on the healthy first days and promote the fits;
4. run the ``nightly`` flow once per following day (``as_of`` = the next midnight);
5. print the alert table, each asset's verdict against the simulator's ground truth, and
   how to open the MLflow and Prefect UIs on what was produced.

The demo's magnitudes are ``demo_fleet``'s own; nothing is tuned here.
"""
from __future__ import annotations

import dataclasses
import json
import pathlib
import shutil
import sys
import time
from typing import TYPE_CHECKING, Sequence

import pandas as pd
from rich.console import Console
from rich.table import Table

from flows import progress
from flows.config import DEFAULT_CONFIG, load_config, render_config
from flows.errors import UsageError
from flows.run_tables import alert_table, fleet_table
from flows.results import state_summary
from graybox.simulation import TRUTH_FILE, Fault, demo_fleet, simulate_fleet
from graybox.telemetry import write_telemetry
from graybox.alert import Alert

if TYPE_CHECKING:
    from flows.commands.temporary_server import TemporaryServer

MARKER = ".fleet-health-demo"
_OURS = ("telemetry", "mlflow.db", "mlflow.db-wal", "mlflow.db-shm", "mlflow.db.init.lock",
         "mlartifacts", ".fleet-health-locks", ".prefect", DEFAULT_CONFIG, "alerts.jsonl",
         "alerts.jsonl.lock", MARKER)


# -- simulation ---------------------------------------------------------------------------------

def parse_fault(text: str):
    """``ASSET:KIND:ONSET_DAY[:MAGNITUDE]`` -> (asset_id, Fault)."""
    parts = text.split(":")
    if len(parts) not in (3, 4):
        raise UsageError(f"--fault {text!r}: expected ASSET:KIND:ONSET_DAY:MAGNITUDE")
    defaults = {"friction": 0.5, "nonlinear": 0.3, "noise": 1.0, "bias": 1.0,
                "heavy_tails": 1.0}
    asset, kind, onset = parts[:3]
    try:
        magnitude = float(parts[3]) if len(parts) == 4 else defaults.get(kind, 1.0)
        return asset, Fault(kind, float(onset), magnitude)
    except ValueError as error:
        raise UsageError(f"--fault {text!r}: {error}") from None


def simulated_fleet(vehicles: int = 8, days: int = 10, seed: int = 0,
                    start: str = "2026-01-01", sample_interval: float = 10.0,
                    faults=None, healthy: bool = False):
    """``demo_fleet`` with another start, sample interval or faults.

    Parameters
    ----------
    faults : list of (asset_id, Fault), optional
        Replace demo_fleet's faults with these.
    healthy : bool
        No faults at all.
    """
    spec = demo_fleet(vehicles, days, seed)
    try:
        spec = dataclasses.replace(spec, start=start, sample_interval=float(sample_interval))
    except ValueError as error:
        raise UsageError(str(error)) from None
    if healthy or faults is not None:
        by_asset: dict[str, list] = {}
        for asset, fault in faults or []:
            by_asset.setdefault(asset, []).append(fault)
        unknown = set(by_asset) - {v.asset_id for v in spec.vehicles}
        if unknown:
            raise UsageError(f"--fault names unknown vehicle(s) {sorted(unknown)}; the fleet "
                             f"is T-001 .. T-{vehicles:03d}")
        spec = dataclasses.replace(spec, vehicles=tuple(
            dataclasses.replace(v, faults=tuple(by_asset.get(v.asset_id, ())))
            for v in spec.vehicles))
    return spec


def write_simulation(spec, root: pathlib.Path, config_out: str | None = None) -> None:
    """Simulate ``spec`` and write it under ``root`` (and a fleet.toml at ``config_out``)."""
    root = pathlib.Path(root)
    progress.start("simulating", len(spec.vehicles))
    frames = simulate_fleet(spec)
    root.mkdir(parents=True, exist_ok=True)
    for asset_id, frame in frames.items():
        write_telemetry(root, asset_id, frame)
        progress.advance(1, asset_id)
    (root / TRUTH_FILE).write_text(json.dumps(spec.to_dict(), indent=2) + "\n")
    if config_out:
        config_path = pathlib.Path(config_out)
        relative = _relative(root.resolve(), config_path.resolve().parent)
        config_path.write_text(render_config(telemetry_root=relative))


def _relative(path: pathlib.Path, base: pathlib.Path) -> str:
    try:
        return str(path.relative_to(base))
    except ValueError:
        return str(path)


# -- the demo ----------------------------------------------------------------------------------

def prepare_workdir(workdir: pathlib.Path) -> pathlib.Path:
    """Create the work directory, or clear a previous demo's outputs in it.

    Raises
    ------
    UsageError
        If the directory exists, is not empty and is not a previous demo's.
    """
    workdir = pathlib.Path(workdir).expanduser().resolve()
    if workdir.exists():
        if not workdir.is_dir():
            raise UsageError(f"--workdir {workdir} is not a directory")
        if any(workdir.iterdir()) and not (workdir / MARKER).exists():
            raise UsageError(f"--workdir {workdir} is not empty and holds no previous demo; "
                             f"choose another directory")
        for name in _OURS:
            path = workdir / name
            if path.is_dir():
                shutil.rmtree(path)
            elif path.exists():
                path.unlink()
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / MARKER).write_text("created by fleet-health demo; the next demo run replaces "
                                  "this directory's demo files\n")
    return workdir


@dataclasses.dataclass
class Verdict:
    asset_id: str
    fault: str
    onset: pd.Timestamp | None
    alert_nights: list[str]
    first_alert_end: pd.Timestamp | None
    verdict: str
    ok: bool


def verdicts(spec, alerts: Sequence[Alert]) -> list[Verdict]:
    """Each vehicle's alerts against the simulator's ground truth.

    A faulty vehicle is *detected* when it alerts, and all its alert windows end after the
    onset (they contain faulty data); a healthy vehicle should stay quiet.
    """
    start = spec.start_timestamp
    out = []
    for vehicle in spec.vehicles:
        mine = sorted({(a.window_start, a.window_end) for a in alerts
                       if a.asset_id == vehicle.asset_id})
        # the night a window is for is its last one (a multi-night candidate spans several)
        nights = sorted({(pd.Timestamp(e) - pd.Timedelta(1, "ns")).strftime("%Y-%m-%d")
                         for _, e in mine})
        first_end = pd.Timestamp(mine[0][1]) if mine else None
        if vehicle.faults:
            onset = start + pd.Timedelta(days=min(f.onset_day for f in vehicle.faults))
            label = ", ".join(f"{f.kind} {f.magnitude:g}" for f in vehicle.faults)
            early = [s for s, e in mine if pd.Timestamp(e) <= onset]
            if not mine:
                text, ok = "MISSED: no alert after the onset", False
            elif early:
                text, ok = f"ALERT BEFORE ONSET ({len(early)} night(s))", False
            else:
                delay = (first_end - onset) / pd.Timedelta(hours=1)
                text, ok = (f"detected: first alert in the window ending {delay:.0f} h after "
                            f"onset"), True
        else:
            onset, label = None, "none"
            text, ok = (("quiet", True) if not mine
                        else (f"FALSE ALARM ({len(mine)} night(s))", False))
        out.append(Verdict(vehicle.asset_id, label, onset, nights, first_end, text, ok))
    return out


def _verdict_table(rows: list[Verdict]):
    table = Table(title="Against the simulator's ground truth (fleet_truth.json)",
                  title_justify="left")
    for column in ("asset", "injected fault", "onset (UTC)", "alert nights", "verdict"):
        table.add_column(column, no_wrap=column != "alert nights")
    for row in rows:
        verdict = row.verdict if row.ok else f"[bold red]{row.verdict}[/]"
        table.add_row(row.asset_id, row.fault,
                      "" if row.onset is None else f"{row.onset:%Y-%m-%d %H:%M}",
                      ", ".join(row.alert_nights), verdict)
    return table


def run_demo(workdir: pathlib.Path, vehicles: int = 8, days: int = 10, baseline_days: int = 4,
             seed: int = 0, sample_interval: float = 10.0, console=None,
             server: TemporaryServer | None = None) -> int:
    """Run the demo in a prepared work directory; returns the exit status.

    ``server``, the command's temporary Prefect server started before the fleet is simulated,
    is waited for before the first flow runs.

    0 when every run processed every asset and the alerts agree with the ground truth
    (faulty vehicles alert, only after their onsets; healthy ones stay quiet); 1 otherwise.
    """
    console = console or Console()
    if baseline_days < 3:
        raise UsageError("--baseline-days must be at least 3 (epsilon is calibrated from "
                         "them)")
    if days <= baseline_days:
        raise UsageError(f"--days ({days}) must exceed --baseline-days ({baseline_days})")
    began = time.monotonic()
    workdir = pathlib.Path(workdir)
    spec = simulated_fleet(vehicles, days, seed, sample_interval=sample_interval)
    console.print(f"[bold]fleet-health demo[/] in {workdir}")
    console.print(f"Simulating {len(spec.vehicles)} gas-turbine vehicles over {days} days "
                  f"({spec.sample_interval:g} s samples, "
                  f"{int(round(86400 / spec.sample_interval))} per day) ...")
    with progress.reporting(progress.for_stream(sys.stderr)):
        write_simulation(spec, workdir / "telemetry")
    config_path = workdir / DEFAULT_CONFIG
    config_path.write_text(render_config(telemetry_root="telemetry"))
    config = load_config(config_path)

    # prefect loads only here: the command line sets PREFECT_HOME and its logging first
    from flows.baseline import baseline
    from flows.nightly import nightly

    if server is not None:
        server.wait()
    day0 = spec.start_timestamp.normalize()
    base_end = day0 + pd.Timedelta(days=baseline_days)
    console.print(f"Fitting baselines on the healthy days {day0:%Y-%m-%d} .. "
                  f"{base_end - pd.Timedelta(days=1):%Y-%m-%d} and promoting them ...")
    failures = 0
    with progress.reporting(progress.for_stream(sys.stderr)):
        state = baseline(start=day0.isoformat(), end=base_end.isoformat(),
                         config_path=str(config.path), vehicle_class=None,
                         promote=True, reason=f"demo: healthy days 1-{baseline_days}",
                         return_state=True)
    summary = state_summary(state)
    failures += len(summary.failed)
    if summary.failed:
        console.print(fleet_table(summary, title="Baselines"))
    nightly_alerts: list[Alert] = []
    last = None
    for night in range(baseline_days, days):
        as_of = day0 + pd.Timedelta(days=night + 1)
        with progress.reporting(progress.for_stream(sys.stderr)):
            state = nightly(config_path=str(config.path), as_of=as_of.isoformat(),
                            return_state=True)
        last = state_summary(state)
        failures += len(last.failed)
        nightly_alerts += last.alerts
        alarmed = sorted({a.asset_id for a in last.alerts})
        console.print(f"night {as_of - pd.Timedelta(days=1):%Y-%m-%d}: "
                      f"{sum(len(a.windows) for a in last.assets)} windows, "
                      f"{len(last.alerts)} alert(s)"
                      + (f" on {', '.join(alarmed)}" if alarmed else "")
                      + (f", {len(last.failed)} FAILED" if last.failed else ""))
    if last is not None and (last.failed or failures):
        console.print(fleet_table(last, title="Last night"))
    console.print()
    if nightly_alerts:
        console.print(alert_table(nightly_alerts, title=f"Alerts ({len(nightly_alerts)})"))
    else:
        console.print("No alerts.")
    rows = verdicts(spec, nightly_alerts)
    console.print(_verdict_table(rows))
    elapsed = time.monotonic() - began
    db = workdir / "mlflow.db"
    console.print()
    console.print(f"Done in {elapsed:.0f} s. Everything is in {workdir}:")
    console.print("  fleet.toml, telemetry/, alerts.jsonl, mlflow.db + mlartifacts/, .prefect/")
    console.print("Open the MLflow UI (experiments fleet-health/turbine; models fleet-health.T-*):")
    console.print(f"  mlflow ui --backend-store-uri sqlite:///{db} --port 5000")
    console.print("  then http://127.0.0.1:5000")
    console.print("Open the Prefect UI (flow runs, the nightly fleet and alert table artifacts):")
    console.print(f"  PREFECT_HOME={workdir / '.prefect'} prefect server start")
    console.print("  then http://127.0.0.1:4200")
    console.print("Try the command line on it (PREFECT_HOME keeps its runs in the same UI):")
    console.print(f"  cd {workdir} && export PREFECT_HOME=$PWD/.prefect")
    faulty = [v.asset_id for v in spec.vehicles if v.faults] or [spec.vehicles[0].asset_id]
    console.print(f"  fleet-health alerts; fleet-health baseline list; fleet-health reanalyze "
                  f"--asset {faulty[0]} --start {base_end:%Y-%m-%d} --end "
                  f"{day0 + pd.Timedelta(days=days):%Y-%m-%d}")
    ok = failures == 0 and all(r.ok for r in rows)
    if not ok:
        console.print("[bold red]The demo did not go as expected: see the failures and "
                      "verdicts above.[/]")
    return 0 if ok else 1
