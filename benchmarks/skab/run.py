"""SKAB through the product's own command line: import, baseline, reanalysis.

Everything a user would type is what runs here, in this process (:func:`flows.cli.main`, so
Prefect's temporary server starts once):

1. **Signal conditioning** (the user's, before the import): the logged 1-s current and voltage
   are replaced by their trailing 60-s mean (:data:`benchmarks.skab.data.INPUT_AVERAGING`,
   the white box's docstring says why), and each asset's export files are written in SKAB's
   own format (``;``, Moscow local time, SKAB's column names).
2. ``fleet-health import FILES --asset A --timezone Europe/Moscow --delimiter ';' --map ...``.
3. ``fleet-health baseline fit A --start S --end E --promote`` on the healthy rows of the
   experiment's session that are not part of it (:mod:`benchmarks.skab.protocol`).
4. ``fleet-health reanalyze --asset A --start S --end E --json`` over the experiment.

The product setting SKAB's 20-minute experiments need is ``[nightly] window = "5min"``: the
prefix before a fault is about 10 minutes, so 5-minute windows give it a whole window, and
300 one-second samples are enough for a candidate (``min_samples = 200``; the analysis
interval follows the window: :func:`graybox.analysis_rate.choose_analysis_interval` keeps the
samples a window needs).
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import pathlib
from dataclasses import dataclass, field

import pandas as pd

from benchmarks.skab.data import (INPUT_AVERAGING, SKAB_GRID, TESTBED_TIMEZONE)
from benchmarks.skab.protocol import BaselinePlan, Experiment
from benchmarks.skab.white_box import SKAB_COLUMNS
from graybox.alert_diagnosis import cause_text

WINDOW = "5min"
CLASS_NAME = "skab_pump"
MODEL = "benchmarks.skab.white_box:SkabPump"
STARTUP_TIMEOUT = "180"
#: the least time a window must cover: a 5-minute window logged at 1 Hz with its 2-s steps
#: covers 299 s, and the class grid's 5-minute floor would reject it
MIN_DURATION = "4min"
#: white-box parameters each baseline fits to its asset's healthy rows: the sessions run at
#: different operating points (flow 32 to 126 l/min, vibration 0.03 to 0.2 g), which the
#: healthy file's values (the class defaults) do not describe
ESTIMATE = ("vibration_1_level", "vibration_2_level", "flow_per_watt",
            "motor_ambient_conductance", "fluid_ambient_conductance")


def conditioned(rows: pd.DataFrame, seconds: int = INPUT_AVERAGING) -> pd.DataFrame:
    """``rows`` (read_skab_csv) with current and voltage replaced by their trailing mean over
    ``seconds`` of time (causal: each row averages what came up to it)."""
    out = rows.set_index("timestamp")
    for column in ("current", "voltage"):
        out[column] = out[column].rolling(f"{seconds}s", min_periods=1).mean()
    return out.reset_index()


def write_export(rows: pd.DataFrame, path: pathlib.Path) -> pathlib.Path:
    """Rows written back in SKAB's format: ``;``, Moscow local time, SKAB's column names."""
    names = {channel: column for column, channel in SKAB_COLUMNS.items()}
    local = rows["timestamp"].dt.tz_convert(TESTBED_TIMEZONE).dt.strftime("%Y-%m-%d %H:%M:%S")
    frame = pd.DataFrame({"datetime": local})
    for channel, column in names.items():
        frame[column] = rows[channel].to_numpy()
    path.parent.mkdir(parents=True, exist_ok=True)
    frame.to_csv(path, sep=";", index=False)
    return path


def import_arguments(files, asset: str, root: pathlib.Path) -> list[str]:
    """``fleet-health import`` for SKAB-format files of one asset."""
    arguments = ["import", *map(str, files), "--asset", asset, "--root", str(root),
                 "--timestamp-column", "datetime", "--timestamp-format", "%Y-%m-%d %H:%M:%S",
                 "--timezone", TESTBED_TIMEZONE, "--delimiter", ";"]
    for column, channel in SKAB_COLUMNS.items():
        arguments += ["--map", f"{column}={channel}"]
    return arguments


def fleet_config(assets, window: str = WINDOW, candidate_nights: int = 1) -> str:
    """The benchmark's fleet.toml: one class, the testbed's white box, the SKAB grid."""
    asset_list = ", ".join(f'"{a}"' for a in assets)
    return f'''[telemetry]
root = "telemetry"

[mlflow]
tracking_uri = "sqlite:///mlflow.db"

[nightly]
window = "{window}"
candidate_nights = {candidate_nights}
plots = "none"

[classes.{CLASS_NAME}]
model = "{MODEL}"
assets = [{asset_list}]
estimate = [{", ".join(f'"{name}"' for name in ESTIMATE)}]
grid = {{ sample_interval = "{SKAB_GRID.sample_interval:g}s", max_gap = "{SKAB_GRID.max_gap:g}s", min_duration = "{MIN_DURATION}", intermittent = true }}
'''


@dataclass
class Cli:
    """``fleet-health`` run in this process, in ``workdir`` (its own Prefect home)."""

    workdir: pathlib.Path
    log: list = field(default_factory=list)

    def __post_init__(self):
        os.environ.pop("PREFECT_API_URL", None)
        os.environ["PREFECT_HOME"] = str(self.workdir / ".prefect")
        os.environ.setdefault("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS",
                              STARTUP_TIMEOUT)

    def __call__(self, *arguments: str, json_output: bool = False) -> tuple[int, dict | None]:
        from flows.cli import main

        command = ["--config", str(self.workdir / "fleet.toml"), *arguments]
        if json_output:
            command.append("--json")
        out, err = io.StringIO(), io.StringIO()
        here = pathlib.Path.cwd()
        os.chdir(self.workdir)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                status = main(command)
        finally:
            os.chdir(here)
        self.log.append({"command": arguments, "status": status, "stderr": err.getvalue()[-2000:]})
        summary = json.loads(out.getvalue()) if json_output and out.getvalue().strip() else None
        if status not in (0, 1):
            raise RuntimeError(f"fleet-health {' '.join(arguments)} exited {status}:\n"
                               f"{err.getvalue()[-2000:]}")
        return status, summary


@dataclass
class GrayBoxWindow:
    """One reanalysed window: its ratio and alarm, and the alarmed tiers as ``tier:channel``."""

    start: pd.Timestamp
    alarm: bool | None                 # None: not analysed (named in ``status``)
    ratio: float | None
    status: str
    alarms: tuple[str, ...] = ()
    cause: str = ""                    # the top diagnosis of the window's largest alert


@dataclass(frozen=True)
class Conditioned:
    """An experiment's rows and its baseline's healthy parts, conditioned (what is imported,
    and what the comparison detectors see)."""

    rows: pd.DataFrame
    parts: tuple[pd.DataFrame, ...]

    @classmethod
    def of(cls, experiment: Experiment, plan: BaselinePlan) -> "Conditioned":
        return cls(conditioned(experiment.rows), tuple(conditioned(p) for p in plan.parts))

    def training(self) -> pd.DataFrame:
        """The healthy parts as one frame."""
        return pd.concat(self.parts, ignore_index=True)


def prepare(workdir: pathlib.Path, data: dict[str, Conditioned], window: str = WINDOW,
            candidate_nights: int = 1) -> None:
    """Write the conditioned exports and the fleet.toml of every experiment with a baseline."""
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / "fleet.toml").write_text(fleet_config(sorted(data), window, candidate_nights))
    for asset, frames in data.items():
        folder = workdir / "exports" / asset
        for index, part in enumerate(frames.parts):
            write_export(part, folder / f"healthy-{index}.csv")
        write_export(frames.rows, folder / "experiment.csv")


def run_gray_box(workdir: pathlib.Path, plans: dict[str, tuple[Experiment, BaselinePlan]],
                 window: str = WINDOW, progress=print) -> dict[str, list[GrayBoxWindow]]:
    """Import, baseline and reanalyse every planned experiment; its windows by asset."""
    cli = Cli(workdir)
    delta = pd.Timedelta(window)
    for asset in sorted(plans):
        files = sorted((workdir / "exports" / asset).glob("*.csv"))
        status, _ = cli(*import_arguments(files, asset, workdir / "telemetry"))
        if status != 0:
            raise RuntimeError(f"import of {asset} failed: {cli.log[-1]['stderr']}")
    by_range: dict[tuple, list[str]] = {}
    for asset, (_, plan) in plans.items():
        by_range.setdefault((plan.start, plan.end), []).append(asset)
    fitted: dict[str, str] = {}
    for (start, end), assets in sorted(by_range.items()):
        progress(f"baseline {len(assets)} asset(s) on {start:%Y-%m-%d %H:%M} to {end:%H:%M} UTC")
        _, summary = cli("baseline", "fit", *sorted(assets), "--start", start.isoformat(),
                         "--end", end.isoformat(), "--promote", "--reason",
                         "SKAB healthy rows of the session", json_output=True)
        for entry in summary["assets"]:
            fitted[entry["asset_id"]] = entry["status"] if not entry.get("error") else (
                f"{entry['status']}: {entry['error']['message']}")
            if entry.get("error"):
                progress(f"  {entry['asset_id']}: no baseline ({fitted[entry['asset_id']]})")
    results = {}
    for asset in sorted(plans):
        experiment, _ = plans[asset]
        start, end = experiment.start.floor(delta), experiment.end.ceil(delta)
        progress(f"reanalyse {asset} ({experiment.name}) {start:%H:%M} to {end:%H:%M} UTC")
        _, summary = cli("reanalyze", "--asset", asset, "--start", start.isoformat(), "--end",
                         end.isoformat(), json_output=True)
        results[asset] = windows_of(summary, asset, fitted.get(asset, "?"))
    return results


def _likely_cause(alert: dict) -> str:
    """The product's own "likely cause" line of an alert's diagnosis ("" if none)."""
    return cause_text(alert["diagnosis"][0] if alert.get("diagnosis") else None)


def windows_of(summary: dict, asset: str, baseline_status: str) -> list[GrayBoxWindow]:
    """The reanalysis summary's windows of ``asset`` (alarmed tiers from its alerts)."""
    (entry,) = [a for a in summary["assets"] if a["asset_id"] == asset]
    alarms: dict[str, list[str]] = {}
    largest: dict[str, dict] = {}
    for alert in entry.get("alerts", []):
        start = alert["window_start"]
        alarms.setdefault(start, []).append(f"{alert['tier']}:{alert['channel']}")
        if start not in largest or alert["ratio"] > largest[start]["ratio"]:
            largest[start] = alert
    out = [GrayBoxWindow(pd.Timestamp(w["window_start"]), bool(w["alarm"]), w["max_ratio"],
                         entry["status"], tuple(alarms.get(w["window_start"], ())),
                         _likely_cause(largest.get(w["window_start"], {})))
           for w in entry.get("windows", [])]
    if not out:
        reason = entry.get("error", {}) or {}
        out = [GrayBoxWindow(pd.NaT, None, None,
                             f"{entry['status']}: {reason.get('message', baseline_status)}")]
    return out
