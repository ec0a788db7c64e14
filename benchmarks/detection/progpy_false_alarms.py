"""Realized false-alarm rate on a healthy fleet simulated by ProgPy's centrifugal pump.

``python -m benchmarks.detection.progpy_false_alarms [--assets N] [--nights N] [--out docs/benchmarks.md]``

Every pump is healthy throughout. Telemetry comes from ProgPy's own ``simulate_to`` with its
process and measurement noise (1 s samples, 0.5 s Euler steps, the duty cycle of
:func:`graybox.models.progpy_simulation.pump_cycle_load`), is written in the store layout and
read back through ``graybox.read_window`` (validation and grid), cut into hourly windows; each
pump gets a calibrated baseline of its first ``--baseline-windows`` windows (target 1 % false
alarms per asset-night) and every later window is fitted as a nightly candidate. An
asset-night alarms when any (channel, tier) zeta exceeds its epsilon. The result (rate, 95 %
Clopper-Pearson interval, alarms per channel and tier) is printed and, with ``--out``, written
into its own section of that markdown page (replaced on every run).
"""
from __future__ import annotations

import argparse
import collections
import pathlib
import re
import sys
import tempfile
import time

import pandas as pd
from scipy import stats

import graybox as gb
from graybox.models.progpy_simulation import pump_cycle_load, simulate_progpy_fleet
from graybox.telemetry.writing import write_telemetry

SPEC = "graybox.models.progpy:CentrifugalPump"
COLUMNS = {"Q": "Qout"}
START = pd.Timestamp("2026-01-01", tz="UTC")
PROCESS_NOISE = {"w": 0.5, "Q": 1e-4, "Tt": 0.01, "Tr": 0.01, "To": 0.001}
MEASUREMENT_NOISE = {"w": 0.05, "Qout": 1e-5, "Tt": 0.01, "Tr": 0.01, "To": 0.01}
WARM = {"w": 385.0, "Q": 0.117, "Tt": 336.0, "Tr": 329.0, "To": 318.0}
BEGIN, END = "<!-- progpy-false-alarms:begin -->", "<!-- progpy-false-alarms:end -->"


def clopper_pearson(alarms: int, trials: int, level: float = 0.95) -> tuple[float, float]:
    """Exact binomial interval of a rate."""
    tail = (1 - level) / 2
    low = stats.beta.ppf(tail, alarms, trials - alarms + 1) if alarms else 0.0
    high = stats.beta.ppf(1 - tail, alarms + 1, trials - alarms) if alarms < trials else 1.0
    return float(low), float(high)


def run(assets: int, baseline_windows: int, nights: int, window_hours: float, seed: int,
        false_alarm_rate: float = 0.01) -> dict:
    """Simulate, fit and count; returns the figures and per-asset-night rows."""
    model = gb.load_model(SPEC, columns=COLUMNS)
    names = [f"P-{i:03d}" for i in range(1, assets + 1)]
    window = window_hours * 3600.0
    clock = {}
    began = time.perf_counter()
    frames = simulate_progpy_fleet(model, names, START, (baseline_windows + nights) * window,
                                   pump_cycle_load, sample_interval=1.0, step=0.5,
                                   process_noise=PROCESS_NOISE,
                                   measurement_noise=MEASUREMENT_NOISE, initial=WARM, seed=seed)
    clock["simulation"] = time.perf_counter() - began
    windows = {}
    with tempfile.TemporaryDirectory(prefix="progpy-fa-") as root:
        began = time.perf_counter()
        for name, frame in frames.items():
            write_telemetry(root, name, frame.iloc[:-1])
            telemetry = gb.read_window(root, name, model.required_columns,
                                       inputs=model.input_columns)
            windows[name] = telemetry.split(f"{window}s")
        clock["write_read"] = time.perf_counter() - began
    began = time.perf_counter()
    requests = [gb.FitRequest(model, windows[n][:baseline_windows], asset_id=n, seed=i)
                for i, n in enumerate(names)]
    baselines = dict(zip(names, gb.fit_baselines(requests, false_alarm_rate=false_alarm_rate)))
    clock["baselines"] = time.perf_counter() - began
    failed = {n: str(b) for n, b in baselines.items() if isinstance(b, gb.GrayBoxError)}
    began = time.perf_counter()
    candidates = [(n, k, gb.FitRequest(model, [windows[n][baseline_windows + k]],
                                       baseline=baselines[n][0], asset_id=n))
                  for n in names if n not in failed for k in range(nights)]
    fitted = gb.fit_signatures([request for _, _, request in candidates])
    clock["candidates"] = time.perf_counter() - began
    rows, by_tier, errors = [], collections.Counter(), {}
    for (name, night, _), candidate in zip(candidates, fitted):
        if isinstance(candidate, gb.GrayBoxError):
            errors[f"{name} night {night}"] = str(candidate)
            continue
        signature, calibration = baselines[name]
        drift = gb.compute_drift(candidate, signature, calibration)
        exceeded = [(e.channel, e.tier) for e in drift.entries if e.exceeded]
        by_tier.update(exceeded)
        rows.append({"asset": name, "night": night, "alarm": bool(exceeded),
                     "exceeded": ";".join(f"{c}/{t}" for c, t in exceeded),
                     "max_ratio": max(e.zeta / e.epsilon if e.epsilon > 0 else float("inf")
                                      for e in drift.entries)})
    alarms = sum(r["alarm"] for r in rows)
    return {"model": model, "assets": assets, "baseline_windows": baseline_windows,
            "nights": nights, "window_hours": window_hours, "seed": seed,
            "asset_nights": len(rows), "alarms": alarms,
            "rate": alarms / len(rows) if rows else float("nan"),
            "interval": clopper_pearson(alarms, len(rows)) if rows else (float("nan"),) * 2,
            "by_tier": dict(by_tier), "failed_baselines": failed, "failed_candidates": errors,
            "rows": rows, "clock": clock}


def markdown(result: dict, command: str) -> str:
    """The page section of one run."""
    low, high = result["interval"]
    model = result["model"]
    tiers = ", ".join(f"{c}/{t}: {n}" for (c, t), n in sorted(result["by_tier"].items())) or "none"
    clock = ", ".join(f"{k} {v:.0f} s" for k, v in result["clock"].items())
    failures = len(result["failed_baselines"]) + len(result["failed_candidates"])
    return f"""{BEGIN}
## ProgPy pump fleet: realized false alarms

A healthy fleet of ProgPy `CentrifugalPump`s (`{SPEC}`, columns `{COLUMNS}`), simulated by
ProgPy itself with its process and measurement noise; five channels per pump
({", ".join(model.states)}). {result["assets"]} pumps, baselines of {result["baseline_windows"]}
windows of {result["window_hours"]:g} h each (target 1 % false alarms per asset-night), then
{result["nights"]} nightly windows per pump; an asset-night alarms when any channel and tier
exceeds its epsilon.

- **Realized false-alarm rate: {result["alarms"]} of {result["asset_nights"]} asset-nights =
  {100 * result["rate"]:.2f} %** (95 % Clopper-Pearson interval {100 * low:.2f}-{100 * high:.2f} %);
  target <= 1 %.
- Exceedances by channel/tier: {tiers}.
- Failed fits: {failures}.
- Seconds: {clock} (seed {result["seed"]}).

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
    parser.add_argument("--baseline-windows", type=int, default=4)
    parser.add_argument("--nights", type=int, default=9)
    parser.add_argument("--window-hours", type=float, default=1.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=pathlib.Path, help="markdown page to write the section into")
    parser.add_argument("--csv", type=pathlib.Path, help="per-asset-night rows")
    args = parser.parse_args(argv)
    command = "python -m benchmarks.detection.progpy_false_alarms " + " ".join(
        argv if argv is not None else sys.argv[1:])
    result = run(args.assets, args.baseline_windows, args.nights, args.window_hours, args.seed)
    section = markdown(result, command.strip())
    print(section)
    for what, failures in (("baseline", result["failed_baselines"]),
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
