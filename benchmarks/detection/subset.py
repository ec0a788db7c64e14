"""``python -m benchmarks.detection.subset [--kinds bias] [--seeds 3] [--vehicles 8]``

A subset of the detection grid (some fault kinds, seeds ``1..N``), run exactly as the full
grid (:func:`benchmarks.detection.run.run_grid`) and summarized as markdown on stdout, for a
section of docs/benchmarks.md without regenerating the whole page: per model error and
magnitude, the detection rate within 3 nights of the best classic detector, of the gray
box's level tier and of the gray box (any tier); then the realized false-alarm rate per
asset-night on the healthy assets. Progress goes to stderr; ``--csv`` keeps the raw rows.
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

from benchmarks.comma_floats import comma_floats
from benchmarks.detection import metrics
from benchmarks.detection.classic import DETECTORS
from benchmarks.detection.grid import DEFAULT_MAGNITUDES, KINDS, Grid
from benchmarks.detection.run import run_grid


def parse_args(argv=None) -> argparse.Namespace:
    defaults = Grid()
    p = argparse.ArgumentParser(prog="python -m benchmarks.detection.subset", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--kinds", default="bias", help="comma-separated fault kinds (default bias)")
    p.add_argument("--seeds", type=int, default=3, help="seeds 1..N (default 3)")
    p.add_argument("--vehicles", type=int, default=defaults.vehicles,
                   help="vehicles per seed (default %(default)s)")
    p.add_argument("--model-errors", type=comma_floats, default=defaults.model_errors,
                   metavar="E,E,...")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--csv", type=pathlib.Path, default=None, help="write the raw rows here")
    args = p.parse_args(argv)
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        p.error(f"unknown fault kind(s) {unknown}; known: {list(KINDS)}")
    args.kinds = kinds
    return args


def _pct(x: float) -> str:
    return f"{100 * x:.0f} %"


def summary(table, false_alarm_rate: float) -> str:
    """The markdown tables of a subset run."""
    level, anytier = "graybox.level", metrics.GRAYBOX
    found = metrics.detection(table, false_alarm_rate=false_alarm_rate,
                              detectors=DETECTORS + (anytier, level))
    lines = ["| model error | fault | magnitude | assets | best classic detector | "
             "gray box: level tier | gray box (any tier) |", "|---|---|---|---|---|---|---|"]
    for (error, kind, magnitude), cell in found.groupby(["model_error", "kind", "magnitude"]):
        rates = cell.set_index("detector")["rate"]
        classic = rates.loc[list(DETECTORS)]
        best = classic.idxmax()
        lines.append(f"| {_pct(error)} | {KINDS[kind]} | {magnitude:g} | "
                     f"{int(cell['assets'].iloc[0])} | {metrics.LABELS[best]} "
                     f"{_pct(classic[best])} | {_pct(rates[level])} | {_pct(rates[anytier])} |")
    alarms = metrics.false_alarms(table, false_alarm_rate, detectors=(anytier, level))
    lines += ["", "| model error | detector | healthy asset-nights | alarms | rate (95 % CI) |",
              "|---|---|---|---|---|"]
    for _, row in alarms.iterrows():
        lines.append(f"| {_pct(row['model_error'])} | {metrics.LABELS[row['detector']]} | "
                     f"{row['nights']} | {row['alarms']} | {100 * row['rate']:.1f} % "
                     f"({100 * row['ci_low']:.1f}-{100 * row['ci_high']:.1f} %) |")
    return "\n".join(lines)


def main(argv=None) -> int:
    args = parse_args(argv)
    grid = Grid(magnitudes={k: DEFAULT_MAGNITUDES[k] for k in args.kinds},
                model_errors=args.model_errors, seeds=tuple(range(1, args.seeds + 1)),
                vehicles=args.vehicles)
    start = time.perf_counter()
    table, info = run_grid(grid, workers=args.workers)
    if args.csv is not None:
        table.to_csv(args.csv, index=False)
    print(summary(table, grid.false_alarm_rate))
    print(f"\n{len(grid.seeds)} seeds x {grid.vehicles} vehicles, wall "
          f"{time.perf_counter() - start:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
