"""``python -m benchmarks.zoo``: the plant zoo with the product's defaults.

Examples
--------
python -m benchmarks.zoo --out docs/benchmarks.md              # every family, full fleets
python -m benchmarks.zoo --families thermal_room --healthy-assets 4 --nights 3
"""
from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import sys
import time

from benchmarks.zoo.families import discover
from graybox.calibration import DEFAULT_FALSE_ALARM_RATE
from benchmarks.zoo.report import markdown, write_section
from benchmarks.zoo.run import run_family


def _run(name: str, arguments: dict) -> dict:
    family = discover()[name]
    return run_family(family, progress=lambda line: print(line, file=sys.stderr, flush=True),
                      **arguments)


def main(argv=None) -> int:
    families = discover()
    parser = argparse.ArgumentParser(prog="python -m benchmarks.zoo", description=__doc__.split("\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--families", default=",".join(families),
                        help=f"comma-separated families (default all: {', '.join(families)})")
    parser.add_argument("--healthy-assets", type=int, default=20,
                        help="healthy vehicles per family (default 20)")
    parser.add_argument("--baseline-days", type=int, default=5, help="baseline days (default 5)")
    parser.add_argument("--nights", type=int, default=15,
                        help="scored nights per healthy vehicle (default 15: 300 asset-nights)")
    parser.add_argument("--faulty-per-cell", type=int, default=3,
                        help="faulty assets per fault kind and magnitude (default 3)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--false-alarm-rate", type=float, default=DEFAULT_FALSE_ALARM_RATE,
                        help="the baselines' calibration target per asset-night (default "
                             f"the product's, {DEFAULT_FALSE_ALARM_RATE:g})")
    parser.add_argument("--workers", type=int, default=1,
                        help="families run in parallel processes (default 1)")
    parser.add_argument("--out", help="write the section into this markdown page")
    parser.add_argument("--json", help="write every figure and row as JSON here")
    args = parser.parse_args(argv)
    names = [n for n in args.families.split(",") if n]
    unknown = sorted(set(names) - set(families))
    if unknown:
        parser.error(f"unknown families {unknown}; known: {', '.join(families)}")
    arguments = dict(healthy_assets=args.healthy_assets, baseline_days=args.baseline_days,
                     nights=args.nights, faulty_per_cell=args.faulty_per_cell, seed=args.seed,
                     false_alarm_rate=args.false_alarm_rate)
    began = time.time()
    load = os.getloadavg()
    with concurrent.futures.ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = list(pool.map(_run, names, [arguments] * len(names)))
    load_after = os.getloadavg()
    command = "python -m benchmarks.zoo " + " ".join(argv if argv is not None else sys.argv[1:])
    notes = (f"Wall time {time.time() - began:.0f} s on 2 cores with {args.workers} worker "
             f"process(es); load average {load[0]:.1f} before, {load_after[0]:.1f} (1 min) and "
             f"{load_after[1]:.1f} (5 min) after.")
    section = markdown(results, command.strip(), notes)
    print(section)
    if args.out:
        write_section(args.out, section)
    if args.json:
        with open(args.json, "w") as handle:
            json.dump([{k: v for k, v in r.items() if k != "detection"}
                       | {"detection": {f"{k}/{s}": d for (k, s), d in r["detection"].items()}}
                       for r in results], handle, indent=1, default=str)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
