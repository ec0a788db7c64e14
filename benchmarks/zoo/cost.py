"""Cost of the fits on a zoo family: seconds per asset-day of baseline and per asset-night.

``python -m benchmarks.zoo.cost [--family hydraulic_level] [--assets 4] [--baseline-days 5]
[--nights 3]``

Simulates the family's healthy assets, reads their days through the store layout as the
flows do, then times, in this process and on the defaults: the calibrated baselines
(:func:`graybox.fit_baselines`, all assets batched) and the nightly candidates
(:func:`graybox.fit_signatures`, ``[nightly] candidate_nights`` each). Simulation, writing and
reading are not counted. Prints the figures (wall, then this process' CPU seconds, which a
shared machine moves less), the stages' wall and CPU seconds
(:class:`graybox.stage_clock.StageClock`) and the machine's load, as a markdown table row.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import pandas as pd

import graybox as gb
from graybox.stage_clock import StageClock
from graybox.telemetry.writing import write_telemetry

from benchmarks.detection.grid import trailing_nights
from benchmarks.zoo.families import discover
from benchmarks.zoo.run import START, plan_fleet
from flows.config.settings import NightlySettings


def day_windows(family, model, vehicles, days: int) -> dict[str, list]:
    """Each vehicle's ``days`` days from :data:`START`, simulated, written in the store layout
    and read back as one window a day (the family's grid policy)."""
    policy = gb.GridPolicy(**dict(family.grid))
    frames = family.simulate(vehicles, START, days)
    windows = {}
    with tempfile.TemporaryDirectory(prefix="zoo-days-") as root:
        for asset, frame in frames.items():
            write_telemetry(root, asset, frame)
            windows[asset] = [gb.read_window(root, asset, model.required_columns,
                                             START + pd.Timedelta(days=d),
                                             START + pd.Timedelta(days=d + 1), policy=policy,
                                             inputs=model.input_columns) for d in range(days)]
    return windows


def measure(family, assets: int, baseline_days: int, nights: int, seed: int = 1) -> dict:
    """Seconds per asset-day of baseline and per asset-night, with the stages'."""
    model = gb.load_model(family.spec, dict(family.parameters), dict(family.columns))
    vehicles, _ = plan_fleet(family, assets, 0, seed, baseline_days)
    windows = day_windows(family, model, vehicles, baseline_days + nights)
    requests = [gb.FitRequest(model, windows[v.asset_id][:baseline_days], asset_id=v.asset_id,
                              seed=i) for i, v in enumerate(vehicles)]
    baseline_clock, night_clock = StageClock(), StageClock()
    began, began_cpu = time.perf_counter(), time.process_time()
    fitted = gb.fit_baselines(requests, clock=baseline_clock)
    baseline_seconds = time.perf_counter() - began
    baseline_cpu = time.process_time() - began_cpu
    failures = [str(r) for r in fitted if isinstance(r, gb.GrayBoxError)]
    if failures:
        raise SystemExit(f"{family.name}: baselines failed: {failures}")
    span = NightlySettings().candidate_nights
    candidates = [gb.FitRequest(model, [windows[v.asset_id][d]
                                        for d in trailing_nights(baseline_days + night, span,
                                                                 baseline_days)],
                                baseline=signature, asset_id=v.asset_id)
                  for v, (signature, _) in zip(vehicles, fitted) for night in range(nights)]
    began, began_cpu = time.perf_counter(), time.process_time()
    gb.fit_signatures(candidates, clock=night_clock)
    night_seconds = time.perf_counter() - began
    night_cpu = time.process_time() - began_cpu
    signature = fitted[0][0]
    return {"family": family.name, "assets": assets, "states": len(model.states),
            "sample_interval": family.sample_interval, "analysis_interval": signature.analysis_step,
            "networks_needed": sum(c.structure.nonlinear_needed for s, _ in fitted
                                   for c in s.channels),
            "channels": sum(len(s.channels) for s, _ in fitted),
            "s_per_baseline_day": baseline_seconds / (assets * baseline_days),
            "s_per_night": night_seconds / len(candidates),
            "cpu_per_baseline_day": baseline_cpu / (assets * baseline_days),
            "cpu_per_night": night_cpu / len(candidates),
            "baseline_stages": {k: v["wall"] for k, v in baseline_clock.to_dict().items()},
            "night_stages": {k: v["wall"] for k, v in night_clock.to_dict().items()},
            "baseline_cpu_stages": {k: v["cpu"] for k, v in baseline_clock.to_dict().items()},
            "night_cpu_stages": {k: v["cpu"] for k, v in night_clock.to_dict().items()}}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.zoo.cost",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--family", default="hydraulic_level",
                        help="a zoo family (default hydraulic_level: 3 states at 1 Hz)")
    parser.add_argument("--assets", type=int, default=4)
    parser.add_argument("--baseline-days", type=int, default=5)
    parser.add_argument("--nights", type=int, default=3)
    args = parser.parse_args(argv)
    families = discover()
    if args.family not in families:
        parser.error(f"--family must be one of {sorted(families)}")
    load = os.getloadavg()[0]
    result = measure(families[args.family], args.assets, args.baseline_days, args.nights)
    result["load_before"], result["load_after"] = load, os.getloadavg()[0]
    print(f"| {result['family']} | {result['states']} | {result['sample_interval']:g} s | "
          f"{result['analysis_interval']:g} s | {result['networks_needed']} of "
          f"{result['channels']} | {result['s_per_baseline_day']:.2f} s | "
          f"{result['s_per_night']:.3f} s | {load:.1f} / {result['load_after']:.1f} |")
    stages = lambda d: ", ".join(f"{k} {v:.1f}" for k, v in sorted(d.items(), key=lambda kv: -kv[1]))
    print(f"CPU (this process): {result['cpu_per_baseline_day']:.2f} s per asset-day of "
          f"baseline, {result['cpu_per_night']:.3f} s per asset-night")
    print(f"baseline stages (s): {stages(result['baseline_stages'])}", file=sys.stderr)
    print(f"night stages (s): {stages(result['night_stages'])}", file=sys.stderr)
    print(f"baseline stages (CPU s): {stages(result['baseline_cpu_stages'])}", file=sys.stderr)
    print(f"night stages (CPU s): {stages(result['night_cpu_stages'])}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
