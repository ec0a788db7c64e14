"""Realized false-alarm rate on a healthy fleet simulated by ProgPy's centrifugal pump.

``python -m benchmarks.detection.progpy_false_alarms [--assets N] [--intermittent N]
[--nights N] [--out docs/benchmarks.md]``

Every pump is healthy throughout. Telemetry comes from ProgPy's own ``simulate_to`` with its
process and measurement noise (1 s samples, 0.5 s Euler steps, the duty cycle of
:func:`graybox.models.progpy_simulation.pump_cycle_load`). The last ``--intermittent`` pumps
run intermittently: each has its own random stops (``pump_stops``: 20-45 min running, 5-15
min stopped), in which its motor voltage is 0 and the pump spins down by ProgPy's dynamics,
then restarts direct-on-line. They keep writing rows while stopped, and their class's
``fleet.toml`` line :data:`INTERMITTENT_GRID` makes the stops pauses between operating
periods: the pump runs while its motor is on and it delivers flow. The telemetry is written
in the store layout and read back window by window through ``graybox.read_window``
(validation and grid), as the nightly flow reads it. Each pump gets a calibrated baseline of
its first ``--baseline-windows`` windows (target 1 % false alarms per asset-night) and every
later window is fitted as a nightly candidate. An asset-night alarms when any (channel,
tier) zeta exceeds its epsilon. The result (rate overall and for continuous and intermittent
pumps, 95 % Clopper-Pearson interval, alarms per channel and tier) is printed and, with
``--out``, written into its own section of that markdown page (replaced on every run).
``tests/benchmarks/test_progpy_false_alarms.py`` runs :func:`run` on a reduced fleet.
"""
from __future__ import annotations

import argparse
import collections
import os
import pathlib
import re
import sys
import tempfile
import time
import tomllib

import pandas as pd

import graybox as gb
from graybox.models.progpy_simulation import (pump_cycle_load, pump_stops, simulate_progpy_fleet,
                                              stopped_load)
from graybox.telemetry.writing import write_telemetry

from benchmarks.detection.grid import trailing_nights
from benchmarks.detection.metrics import rate
from flows.config.settings import NightlySettings

SPEC = "graybox.models.progpy:CentrifugalPump"
COLUMNS = {"Q": "Qout"}
START = pd.Timestamp("2026-01-01", tz="UTC")
PROCESS_NOISE = {"w": 0.5, "Q": 1e-4, "Tt": 0.01, "Tr": 0.01, "To": 0.001}
MEASUREMENT_NOISE = {"w": 0.05, "Qout": 1e-5, "Tt": 0.01, "Tr": 0.01, "To": 0.01}
WARM = {"w": 385.0, "Q": 0.117, "Tt": 336.0, "Tr": 329.0, "To": 318.0}
#: the intermittent pumps' class line in fleet.toml: the pump runs while its motor is on and
#: it delivers flow. Rows with the motor off (V = 0) are pauses, and so are the first seconds
#: of a restart, in which the pump cannot yet lift the discharge pressure: ProgPy's flow
#: output reads 0 (``Qout = max(0, Q - QLeak)``) while its flow state is negative, which the
#: white box, observing the state Q in the column Qout, cannot follow (with ``V`` alone those
#: samples give the residual spikes of 160 noise deviations). A window needs 15 minutes of
#: operation.
INTERMITTENT_GRID = ('grid = { running = { V = [100.0, 1000.0], Qout = [0.01, 1.0] }, '
                     'min_duration = "15min" }')
BEGIN, END = "<!-- progpy-false-alarms:begin -->", "<!-- progpy-false-alarms:end -->"


def grid_policy(line: str) -> gb.GridPolicy:
    """The GridPolicy of a class's ``grid = {...}`` line of fleet.toml."""
    return gb.GridPolicy(**tomllib.loads(line)["grid"])


def run(assets: int, baseline_windows: int, nights: int, window_hours: float, seed: int,
        intermittent: int | None = None, stop_schedules: int | None = None,
        false_alarm_rate: float = 0.01, candidate_windows: int | None = None) -> dict:
    """Simulate, fit and count; returns the figures and per-asset-night rows.

    Parameters
    ----------
    assets : int
        Pumps simulated.
    baseline_windows, nights : int
        Windows per pump fitted as its baseline, then scored as nightly candidates.
    window_hours : float
        Length of a window (an "asset-night").
    seed : int
        Seeds the noise and the stops.
    intermittent : int, optional
        How many of the pumps (the last ones) run intermittently; default half.
    stop_schedules : int, optional
        How many different stop schedules the intermittent pumps take in turn; default one
        each. Each schedule costs a ProgPy simulation of its own (pumps sharing one are
        simulated together), so a small test shares them.
    false_alarm_rate : float, default 0.01
        The baselines' calibration target per asset-night.
    candidate_windows : int, optional
        Each candidate is fitted on its window and the ``N - 1`` before it (never before the
        baseline's end), as ``[nightly] candidate_nights = N`` does; default the product's.

    Returns
    -------
    dict
        ``overall``, ``continuous`` and ``intermittent`` (each :func:`rate`), ``by_tier``
        (``(channel, tier) -> alarms``, per group), ``failed_reads``, ``failed_baselines``,
        ``failed_candidates`` (what failed, with its message), ``rows`` (one per scored
        asset-night), ``clock`` (seconds per stage) and the arguments.
    """
    model = gb.load_model(SPEC, columns=COLUMNS)
    span = candidate_windows or NightlySettings().candidate_nights
    names = [f"P-{i:03d}" for i in range(1, assets + 1)]
    intermittent = assets // 2 if intermittent is None else intermittent
    stopping = set(names[assets - intermittent:])
    window = window_hours * 3600.0
    total = baseline_windows + nights
    schedules = [stopped_load(pump_cycle_load, pump_stops(total * window, seed=[seed, k]))
                 for k in range(stop_schedules or max(intermittent, 1))]
    loads = {name: pump_cycle_load for name in names}
    for k, name in enumerate(sorted(stopping)):
        loads[name] = schedules[k % len(schedules)]
    policies = {name: grid_policy(INTERMITTENT_GRID) if name in stopping else gb.GridPolicy()
                for name in names}
    clock = {}
    began = time.perf_counter()
    frames = simulate_progpy_fleet(model, names, START, total * window, loads,
                                   sample_interval=1.0, step=0.5, process_noise=PROCESS_NOISE,
                                   measurement_noise=MEASUREMENT_NOISE, initial=WARM, seed=seed)
    clock["simulation"] = time.perf_counter() - began
    windows, failed_reads = {}, {}
    with tempfile.TemporaryDirectory(prefix="progpy-fa-") as root:
        began = time.perf_counter()
        for name, frame in frames.items():
            write_telemetry(root, name, frame.iloc[:-1])
            for k in range(total):
                begin = START + pd.Timedelta(seconds=k * window)
                try:
                    windows[name, k] = gb.read_window(
                        root, name, model.required_columns, begin,
                        begin + pd.Timedelta(seconds=window), policy=policies[name],
                        inputs=model.input_columns)
                except gb.GrayBoxError as error:
                    failed_reads[f"{name} window {k}"] = str(error)
        clock["write_read"] = time.perf_counter() - began
    began = time.perf_counter()
    ready = [n for n in names if all((n, k) in windows for k in range(baseline_windows))]
    requests = [gb.FitRequest(model, [windows[n, k] for k in range(baseline_windows)],
                              asset_id=n, seed=names.index(n)) for n in ready]
    fitted = gb.fit_baselines(requests, false_alarm_rate=false_alarm_rate)
    baselines, failed = {}, {}
    for name, baseline in zip(ready, fitted):
        if isinstance(baseline, gb.GrayBoxError):
            failed[name] = str(baseline)
        else:
            baselines[name] = baseline
    clock["baselines"] = time.perf_counter() - began
    began = time.perf_counter()
    def trailing(name: str, night: int) -> list:
        return [windows[name, k]
                for k in trailing_nights(baseline_windows + night, span, baseline_windows)
                if (name, k) in windows]

    candidates = [(n, k, gb.FitRequest(model, trailing(n, k), baseline=baselines[n][0],
                                       asset_id=n))
                  for n in names if n in baselines for k in range(nights)
                  if (n, baseline_windows + k) in windows]
    scored = gb.fit_signatures([request for _, _, request in candidates])
    clock["candidates"] = time.perf_counter() - began
    rows, by_tier, errors = [], collections.Counter(), {}
    for (name, night, _), candidate in zip(candidates, scored):
        if isinstance(candidate, gb.GrayBoxError):
            errors[f"{name} night {night}"] = str(candidate)
            continue
        signature, calibration = baselines[name]
        drift = gb.compute_drift(candidate, signature, calibration)
        exceeded = [(e.channel, e.tier) for e in drift.entries if e.exceeded]
        group = "intermittent" if name in stopping else "continuous"
        by_tier.update((group, c, t) for c, t in exceeded)
        rows.append({"asset": name, "group": group, "night": night, "alarm": bool(exceeded),
                     "periods": len(windows[name, baseline_windows + night].periods()),
                     "exceeded": ";".join(f"{c}/{t}" for c, t in exceeded),
                     "max_ratio": max(e.ratio if e.zeta > 0 else 0.0 for e in drift.entries)})
    groups = {group: rate(sum(r["alarm"] for r in rows if r["group"] == group),
                          sum(r["group"] == group for r in rows))
              for group in ("continuous", "intermittent")}
    return {"model": model, "assets": assets, "intermittent_assets": intermittent,
            "stop_schedules": len(schedules) if intermittent else 0,
            "baseline_windows": baseline_windows, "nights": nights,
            "candidate_windows": span, "window_hours": window_hours, "seed": seed,
            "overall": rate(sum(r["alarm"] for r in rows), len(rows)), **groups,
            "by_tier": dict(by_tier), "failed_reads": failed_reads,
            "failed_baselines": failed, "failed_candidates": errors, "rows": rows,
            "clock": clock}


def markdown(result: dict, command: str, notes: str = "") -> str:
    """The page section of one run (``notes``: date, wall time and load, as measured)."""
    model = result["model"]

    def figure(group: str) -> str:
        r = result[group]
        low, high = r["interval"]
        return (f"{r['alarms']} of {r['asset_nights']} asset-nights = {100 * r['rate']:.2f} % "
                f"(95 % Clopper-Pearson interval {100 * low:.2f}-{100 * high:.2f} %)")

    def tiers(group: str) -> str:
        found = sorted((c, t, n) for (g, c, t), n in result["by_tier"].items() if g == group)
        return ", ".join(f"{c}/{t}: {n}" for c, t, n in found) or "none"

    clock = ", ".join(f"{k} {v:.0f} s" for k, v in result["clock"].items())
    failures = sum(len(result[k]) for k in ("failed_reads", "failed_baselines",
                                            "failed_candidates"))
    periods = [r["periods"] for r in result["rows"] if r["group"] == "intermittent"]
    spread = f"{min(periods)}-{max(periods)}" if periods else "-"
    return f"""{BEGIN}
## ProgPy pump fleet: realized false alarms

A healthy fleet of ProgPy `CentrifugalPump`s (`{SPEC}`, columns `{COLUMNS}`), simulated by
ProgPy itself with its process and measurement noise; five channels per pump
({", ".join(model.states)}). {result["assets"]} pumps, of which
{result["intermittent_assets"]} run intermittently, with random stops (20-45 min running,
5-15 min stopped; {result["stop_schedules"]} different schedules): the motor voltage is 0,
the pump spins down by ProgPy's dynamics and restarts direct-on-line. They write rows while
stopped, and their class's `{INTERMITTENT_GRID}` makes the stops pauses (the residual and the
tiers never span one; a scored intermittent window held {spread} operating periods).
Baselines of {result["baseline_windows"]} windows of {result["window_hours"]:g} h each
(target 1 % false alarms per asset-night), then {result["nights"]} nightly windows per pump,
each read through `graybox.read_window` as the nightly flow reads it; each window's candidate
is fitted on it and the {result["candidate_windows"] - 1} window(s) before it, never before
the baseline's end (`[nightly] candidate_nights = {result["candidate_windows"]}`, epsilon
scaled to the span); an asset-night alarms when any channel and tier exceeds its epsilon.

- **Realized false-alarm rate: {figure("overall")}**; target <= 1 %.
- Continuous pumps: {figure("continuous")}; exceedances by channel/tier: {tiers("continuous")}.
- Intermittent pumps: {figure("intermittent")}; exceedances by channel/tier:
  {tiers("intermittent")}.
- Failed reads or fits: {failures}.
- Seconds: {clock} (seed {result["seed"]}).{notes}

Command: `{command}`
{END}
"""


def write_section(page: pathlib.Path, section: str) -> None:
    """Replace this benchmark's section of ``page`` (or append it)."""
    text = page.read_text() if page.exists() else ""
    pattern = re.compile(re.escape(BEGIN) + ".*?" + re.escape(END) + "\n?", re.S)
    if pattern.search(text):
        text = pattern.sub(lambda _: section, text)
    else:
        text = text.rstrip("\n") + "\n\n" + section
    page.write_text(text)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--assets", type=int, default=24)
    parser.add_argument("--intermittent", type=int, help="intermittent pumps (default half)")
    parser.add_argument("--baseline-windows", type=int, default=4)
    parser.add_argument("--nights", type=int, default=9)
    parser.add_argument("--window-hours", type=float, default=1.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--candidate-windows", type=int, default=None, metavar="N",
                        help="candidates on the window and the N - 1 before it (default: the "
                             "product's [nightly] candidate_nights)")
    parser.add_argument("--out", type=pathlib.Path, help="markdown page to write the section into")
    parser.add_argument("--csv", type=pathlib.Path, help="per-asset-night rows")
    args = parser.parse_args(argv)
    command = "python -m benchmarks.detection.progpy_false_alarms " + " ".join(
        argv if argv is not None else sys.argv[1:])
    began, when = time.perf_counter(), pd.Timestamp.now(tz="UTC")
    result = run(args.assets, args.baseline_windows, args.nights, args.window_hours, args.seed,
                 intermittent=args.intermittent, candidate_windows=args.candidate_windows)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    notes = (f"\n- Measured {when:%Y-%m-%d %H:%M} UTC on {os.cpu_count()} CPUs: wall time "
             f"{time.perf_counter() - began:.0f} s, load average (1, 5, 15 min) at the end "
             f"{load}.")
    section = markdown(result, command.strip(), notes)
    print(section)
    for what, failures in (("read", result["failed_reads"]),
                           ("baseline", result["failed_baselines"]),
                           ("candidate", result["failed_candidates"])):
        for key, message in failures.items():
            print(f"failed {what} {key}: {message}", file=sys.stderr)
    if args.csv:
        pd.DataFrame(result["rows"]).to_csv(args.csv, index=False)
    if args.out:
        write_section(args.out, section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
