"""Side experiment: would a two-night candidate window close the gap?

``python -m benchmarks.detection.window [--model-error 0.2] [--seeds 1,2,3]``

Same protocol as the benchmark (same fleets, baselines and calibration), but every night's
candidate is fitted on the trailing two nights (``[t-1, t]``, two windows of one request), so
it has twice the samples of the reference night. Zeta's sampling noise scales like 1 / n, so
epsilon is compared both as calibrated (``Calibration.epsilon`` only scales *up* for shorter
windows) and scaled by ``reference_samples / n`` (halved). "Within 3 nights" counts the
windows ending on the onset night (half healthy), onset + 1 and onset + 2. Prints the realized
false-alarm rate on healthy two-night windows and the detection rates of the middle and
smallest magnitudes of (a)-(c).
"""
from __future__ import annotations

import argparse
import sys
import time

import pandas as pd

from benchmarks.detection.grid import DEFAULT_MAGNITUDES, Grid, asset_id, simulate_seed
from benchmarks.detection.metrics import TIERS, clopper_pearson
from benchmarks.detection.run import CHANNEL, white_box

#: the smallest and middle magnitudes of (a)-(c) (``grid.DEFAULT_MAGNITUDES``)
MAGNITUDES = {kind: DEFAULT_MAGNITUDES[kind][:2] for kind in ("friction", "nonlinear", "noise")}


def run(model_error: float, seeds: tuple[int, ...],
        vehicles: int = Grid().vehicles) -> pd.DataFrame:
    import torch

    from graybox import FitRequest, GrayBoxSettings, compute_drift, fit_baselines, fit_signatures

    torch.set_num_threads(1)
    grid = Grid(magnitudes=MAGNITUDES, model_errors=(model_error,), seeds=seeds, vehicles=vehicles)
    model, settings = white_box(model_error), GrayBoxSettings()
    rows = []
    for seed in seeds:
        fleet = simulate_seed(grid, seed)
        baselines = fit_baselines([FitRequest(model, v.healthy[:grid.baseline_days],
                                              asset_id=asset_id(seed, v.vehicle), seed=v.vehicle)
                                   for v in fleet], settings, grid.false_alarm_rate)
        requests, keys = [], []
        for v, (signature, calibration) in zip(fleet, baselines):
            for t in range(grid.baseline_days + 1, grid.days):
                requests.append(FitRequest(model, [v.healthy[t - 1], v.healthy[t]], baseline=signature))
                keys.append((v.vehicle, "healthy", 0.0, t, signature, calibration))
            for (kind, magnitude), frames in v.faulty.items():
                days = {grid.onset_day - 1: v.healthy[grid.onset_day - 1]}
                days.update({grid.onset_day + j: f for j, f in enumerate(frames)})
                for t in range(grid.onset_day, grid.days):
                    requests.append(FitRequest(model, [days[t - 1], days[t]], baseline=signature))
                    keys.append((v.vehicle, kind, magnitude, t, signature, calibration))
        for (vehicle, kind, magnitude, t, signature, calibration), candidate in zip(
                keys, fit_signatures(requests, settings)):
            drift = compute_drift(candidate, signature, calibration)
            row = {"seed": seed, "vehicle": vehicle, "kind": kind, "magnitude": magnitude,
                   "night": t, "n_samples": candidate.n_samples,
                   "reference_samples": calibration.reference_samples}
            for tier in TIERS:
                entry = drift.get(CHANNEL, tier)
                row[f"{tier}_zeta"], row[f"{tier}_eps"] = entry.zeta, entry.epsilon
            rows.append(row)
        print(f"[window] seed {seed} done", file=sys.stderr, flush=True)
    return pd.DataFrame(rows)


def summary(table: pd.DataFrame) -> str:
    lines = []
    for name, scaled in (("epsilon as calibrated", False), ("epsilon x reference/n", True)):
        scale = table["reference_samples"] / table["n_samples"] if scaled else 1.0
        ratio = pd.concat([table[f"{t}_zeta"] / (table[f"{t}_eps"] * scale) for t in TIERS],
                          axis=1).max(axis=1)
        healthy = ratio[table.kind == "healthy"]
        k, n = int((healthy > 1).sum()), len(healthy)
        low, high = clopper_pearson(k, n)
        lines.append(f"{name}: false alarms {k}/{n} = {100 * k / n:.1f} % "
                     f"(CI {100 * low:.1f}-{100 * high:.1f} %)")
        for (kind, magnitude), cell in table[table.kind != "healthy"].groupby(["kind", "magnitude"]):
            detected = (ratio[cell.index] > 1).groupby([cell.seed, cell.vehicle]).any()
            lines.append(f"  {kind} {magnitude:g}: detected within 3 nights "
                         f"{100 * detected.mean():.0f} % of {len(detected)}")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.detection.window", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--model-error", type=float, default=0.2)
    p.add_argument("--seeds", default="1,2,3")
    p.add_argument("--vehicles", type=int, default=Grid().vehicles)
    p.add_argument("--csv", default=None, help="also write the raw rows here")
    args = p.parse_args(argv)
    start = time.perf_counter()
    table = run(args.model_error, tuple(int(s) for s in args.seeds.split(",")), args.vehicles)
    if args.csv:
        table.to_csv(args.csv, index=False)
    print(f"model error {args.model_error:g}, seeds {args.seeds}, {args.vehicles} vehicles per seed, "
          f"two-night windows ({time.perf_counter() - start:.0f} s)")
    print(summary(table))
    return 0


if __name__ == "__main__":
    sys.exit(main())
