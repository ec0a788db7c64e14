"""Whether a family's healthy alarms come on nights outside the baseline's operating range.

``python -m benchmarks.zoo.envelope --json zoo.json --family compressor --column ambient_temp``
re-simulates the family's healthy fleet exactly as ``python -m benchmarks.zoo`` did (same
seed, assets and days), takes each day's mean of ``column``, and for every scored healthy
night (a candidate of its ``candidate_nights`` days) how far those days' means lie outside the
range of the baseline days' means. It prints the healthy nights and their alarms by that
distance, and which channel/tier alarmed.
"""
from __future__ import annotations

import argparse
import json

import numpy as np
import pandas as pd

from benchmarks.zoo.families import discover
from benchmarks.zoo.run import START, plan_fleet


def outside_distances(family, result: dict, column: str) -> pd.DataFrame:
    """Per healthy asset-night of ``result`` (one family of the zoo's JSON): the alarm, the
    tiers that alarmed and how far the candidate's days' means of ``column`` lie outside the
    baseline days' range."""
    days, nights = result["baseline_days"], result["nights"]
    span = result["candidate_nights"]
    vehicles, _ = plan_fleet(family, result["healthy_assets"], 0, result["seed"], days)
    frames = family.simulate(vehicles, START, days + nights)
    scored = {(r["asset"], r["night"]): r for r in result["rows"] if not r["fault"]}
    out = []
    for vehicle in vehicles:
        frame = frames[vehicle.asset_id]
        stamps = pd.DatetimeIndex(frame.index)
        day = np.asarray((stamps - START) // pd.Timedelta(days=1))
        means = pd.Series(frame[column].to_numpy()).groupby(day).mean()
        low, high = means.loc[0:days - 1].min(), means.loc[0:days - 1].max()
        for night in range(nights):
            row = scored.get((vehicle.asset_id, night))
            if row is None:
                continue
            window = means.loc[days + night - span + 1:days + night]
            out.append({"asset": vehicle.asset_id, "night": night, "alarm": row["alarm"],
                        "exceeded": row["exceeded"],
                        "outside": max(0.0, window.max() - high, low - window.min())})
    return pd.DataFrame(out)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", required=True, help="the zoo's --json output")
    parser.add_argument("--family", default="compressor")
    parser.add_argument("--column", default="ambient_temp",
                        help="the telemetry column whose range is compared")
    parser.add_argument("--bins", default="0,2,5",
                        help="distances outside the range that split the table")
    args = parser.parse_args(argv)
    family = discover()[args.family]
    result = next(r for r in json.load(open(args.json)) if r["family"] == args.family)
    frame = outside_distances(family, result, args.column)
    edges = [-np.inf] + [float(b) for b in args.bins.split(",")] + [np.inf]
    frame["distance"] = pd.cut(frame["outside"], edges)
    tiers = frame.assign(tier=frame["exceeded"].str.split(";")).explode("tier")
    tiers = tiers[tiers["tier"].fillna("") != ""]
    print(f"{args.family}: healthy nights by how far the candidate's daily mean {args.column} "
          f"lies outside the baseline days' range")
    print(frame.groupby("distance", observed=False).agg(
        nights=("alarm", "size"), alarmed=("alarm", "sum")).to_string())
    print(tiers.groupby(["distance", "tier"], observed=True).size().unstack(fill_value=0)
          .to_string())


if __name__ == "__main__":
    main()
