"""``python -m benchmarks.zoo.estimate_probe``: would a test on the white box's own parameters
see the faults the tiers miss? An experiment, not a product feature.

Every scored night of a zoo family (a two-night candidate, as the nightly flow scores it)
is diagnosed against its vehicle's baseline (:func:`graybox.diagnosis.diagnose`: each
parameter of the white box and each channel's bias, gain and noise fitted alone on the
window). Each hypothesis' estimate is then compared with the same hypothesis' estimates on
the vehicle's *healthy scored nights*: ``z = |estimate - mean| / sd`` (a healthy night
against its vehicle's other healthy nights, leave one out; a faulty night against all of
them), and a night's statistic is the largest ``z`` over the hypotheses. A faulty night far
above every healthy night is a fault such a test would see.

The spread comes from the healthy nights after the baseline (about ten), not from the
baseline's five days as a product would have to: the probe is the optimistic case. The
tiers' own verdict (alarm, largest zeta/epsilon) is printed beside it.

Examples
--------
python -m benchmarks.zoo.estimate_probe --family thermal_room --healthy-assets 8 --nights 10
"""
from __future__ import annotations

import argparse
import collections
import json
import os
import sys
import time

import numpy as np

import graybox as gb
from graybox.diagnosis import diagnose

from benchmarks.zoo.families import family_option
from benchmarks.zoo.run import HORIZON, START, asset_nights, plan_fleet, write_and_read

#: seconds a night's diagnosis may take (the product's default is 10; a 1-Hz plant with
#: hidden states needs more on a loaded machine)
TIME_BUDGET = 120.0


def probe_family(family, healthy_assets: int, nights: int, seed: int,
                 baseline_days: int = 5, candidate_nights: int = 2, say=print) -> list[dict]:
    """Diagnose every scored night; one row per asset-night with every hypothesis' estimate."""
    model = gb.load_model(family.spec, dict(family.parameters), dict(family.columns))
    policy = gb.GridPolicy(**dict(family.grid))
    vehicles, faulty = plan_fleet(family, healthy_assets, 1, seed, baseline_days)
    frames = family.simulate(vehicles, START, baseline_days + nights)
    frames.update(family.simulate(faulty, START, baseline_days + HORIZON,
                                  first_day=baseline_days))
    windows, _ = write_and_read(family, model, policy, frames, {v.asset_id for v in vehicles},
                                baseline_days, nights)
    ready = [v for v in vehicles
             if all((v.asset_id, d) in windows for d in range(baseline_days))]
    fitted = gb.fit_baselines([gb.FitRequest(model, [windows[v.asset_id, d]
                                                     for d in range(baseline_days)],
                                             asset_id=v.asset_id, seed=i)
                               for i, v in enumerate(ready)])
    baselines = {v.asset_id: r for v, r in zip(ready, fitted)
                 if not isinstance(r, gb.GrayBoxError)}
    rows = []
    for plan, vehicle, candidates in asset_nights(vehicles, faulty, nights, baselines, windows,
                                                  baseline_days, candidate_nights):
        signature, calibration = baselines[vehicle]
        for night, days in candidates:
            if (plan.asset_id, baseline_days + night) not in windows:
                continue
            span = [windows[plan.asset_id, d] for d in days]
            candidate = gb.fit_signatures([gb.FitRequest(model, span, baseline=signature,
                                                         asset_id=plan.asset_id)])[0]
            row = {"asset": plan.asset_id, "vehicle": vehicle, "night": night,
                   "fault": plan.fault.name if plan.fault else "", "size": plan.size}
            if not isinstance(candidate, gb.GrayBoxError):
                drift = gb.compute_drift(candidate, signature, calibration)
                row["alarm"] = any(e.exceeded for e in drift.entries)
                row["max_ratio"] = drift.largest.ratio if drift.largest else 0.0
            try:
                diagnosis = diagnose(signature, span, time_budget=TIME_BUDGET)
                row["estimates"] = {h.hypothesis: h.estimate for h in diagnosis.hypotheses}
            except gb.GrayBoxError as error:
                row["error"] = str(error)
            rows.append(row)
        say(f"{family.name}: {plan.asset_id} diagnosed")
    return rows


def largest_z(row: dict, pool: list[dict]) -> tuple[float, str | None]:
    """The largest ``|estimate - mean| / sd`` over the hypotheses, against ``pool``'s
    estimates of each (at least 3 finite ones with a spread), and its hypothesis."""
    best = (0.0, None)
    for name, value in row.get("estimates", {}).items():
        values = [p["estimates"][name] for p in pool
                  if np.isfinite(p.get("estimates", {}).get(name, np.nan))]
        if len(values) < 3 or not np.isfinite(value):
            continue
        spread = np.std(values, ddof=1)
        if spread > 0 and abs(value - np.mean(values)) / spread > best[0]:
            best = (float(abs(value - np.mean(values)) / spread), name)
    return best


def summary(rows: list[dict]) -> dict:
    """Healthy nights' largest z (leave one out) and each fault's largest over its nights."""
    healthy = collections.defaultdict(list)
    for row in rows:
        if not row["fault"] and "estimates" in row:
            healthy[row["vehicle"]].append(row)
    healthy_z = [largest_z(row, [p for p in pool if p is not row])
                 for pool in healthy.values() for row in pool]
    faults = collections.defaultdict(list)
    for row in rows:
        if row["fault"] and "estimates" in row:
            z, name = largest_z(row, healthy[row["vehicle"]])
            faults[row["fault"], row["size"]].append((z, name, row.get("alarm"),
                                                      row.get("max_ratio")))
    values = np.array([z for z, _ in healthy_z])
    return {"healthy_nights": len(values),
            "healthy_z": {"median": float(np.median(values)),
                          "p95": float(np.percentile(values, 95)), "max": float(values.max())},
            "healthy_z_max_hypothesis": max(healthy_z, key=lambda z: z[0])[1],
            "faults": {f"{kind}/{size}": {"largest_z": max(n[0] for n in nights),
                                          "hypothesis": max(nights, key=lambda n: n[0])[1],
                                          "tiers_alarmed": any(n[2] for n in nights),
                                          "tiers_largest_ratio": max(n[3] or 0 for n in nights)}
                       for (kind, size), nights in faults.items()}}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.zoo.estimate_probe",
                                     description=__doc__.split("\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    families = family_option(parser)
    parser.add_argument("--healthy-assets", type=int, default=8)
    parser.add_argument("--nights", type=int, default=10)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", help="write the rows and the summary here")
    args = parser.parse_args(argv)
    began, load = time.time(), os.getloadavg()[0]
    rows = probe_family(families[args.family], args.healthy_assets, args.nights, args.seed,
                        say=lambda line: print(line, file=sys.stderr, flush=True))
    result = summary(rows)
    result["wall_s"], result["load_before"] = time.time() - began, load
    print(json.dumps(result, indent=1))
    if args.json:
        with open(args.json, "w") as handle:
            json.dump({"summary": result, "rows": rows}, handle, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
