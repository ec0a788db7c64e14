"""``python -m benchmarks.diagnosis.by_night A.json [B.json ...]``: the diagnosis runs' top-1
and top-3 split into the onset night and the later nights, side by side.

Reads the ``--json`` records of ``python -m benchmarks.diagnosis`` (the grid's rows) and
prints one markdown table: per fault kind, magnitude and model error, each record's detected
nights, top-1 and top-3 over all of them, over the onset nights (the first night of the
fault) and over the later ones; then the top-1 night by night from the onset; the score gap
of the expected hypothesis over its best rival night by night (its mean and spread, and how
much of it stays with the vehicle from night to night); then each record's healthy nights
given a cause and the CPU seconds per diagnosed night. The onset/later split the docs' diagnosis tables use
(docs/benchmarks.md, "One night, or the candidate's nights"), written once.
"""
from __future__ import annotations

import argparse
import collections
import json
import math
import pathlib

import numpy as np

from benchmarks.diagnosis import scores
from benchmarks.diagnosis.report import hit_share


def split(record: dict) -> dict:
    """``(fault, magnitude, model error) -> {"all"|"onset"|"later"|k: accuracy cell}`` of a
    ``--json`` record's grid rows (:func:`scores.accuracy` on each subset of nights; ``k``:
    the k-th night from the onset, the onset night 1)."""
    grid = record["grid"]
    onset = grid["grid"]["baseline_days"] + grid["grid"]["pre_nights"]
    subsets = {"all": lambda n: True, "onset": lambda n: n == onset, "later": lambda n: n > onset}
    subsets.update({k + 1: (lambda n, k=k: n == onset + k)
                    for k in range(grid["grid"]["post_nights"])})
    out: dict = {}
    for name, keep in subsets.items():
        for cell in scores.accuracy([r for r in grid["rows"] if keep(r["night"])]):
            out.setdefault((cell["fault"], cell["magnitude"], cell["model_error"]), {})[name] = cell
    return out


def _hits(cell: dict | None, field: str) -> str:
    if cell is None:
        return "0/0"
    return hit_share(cell[field], cell["detected"])


def table(records: list[dict], names: list[str]) -> list[str]:
    """The side-by-side markdown table of ``records`` (columns named ``names``)."""
    splits = [split(r) for r in records]
    keys = sorted({k for s in splits for k in s})
    head = ["fault", "magnitude", "model error"]
    for name in names:
        head += [f"{name}: top-1 (all / onset / later)", f"{name}: top-3 (all / onset / later)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for key in keys:
        fault, magnitude, error = key
        cells = [f"{fault}", f"{magnitude:g}", f"{error:.0%}"]
        for s in splits:
            parts = s.get(key, {})
            for field in ("top1", "top3"):
                if parts.get("all", {}).get("expected") is None:
                    cells.append("-")
                    continue
                cells.append(" / ".join(_hits(parts.get(n), field)
                                        for n in ("all", "onset", "later")))
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def night_by_night(records: list[dict], names: list[str]) -> list[str]:
    """Top-1 on the k-th night from the onset (the onset night 1), per record and cell."""
    splits = [split(r) for r in records]
    nights = max(r["grid"]["grid"]["post_nights"] for r in records)
    head = ["fault", "magnitude", "model error", "run"] + [f"night {k}" for k in
                                                          range(1, nights + 1)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for key in sorted({k for s in splits for k in s}):
        for name, parts in ((n, s.get(key, {})) for n, s in zip(names, splits)):
            if parts.get("all", {}).get("expected") is None:
                continue
            fault, magnitude, error = key
            lines.append(f"| {fault} | {magnitude:g} | {error:.0%} | {name} | " + " | ".join(
                _hits(parts.get(k), "top1") for k in range(1, nights + 1)) + " |")
    return lines


def gap(row: dict) -> float:
    """The expected hypothesis' score minus its best rival's among the kept first five (its
    lead when first, its deficit otherwise); NaN when it is not among them."""
    name = scores._hypothesis_name(row["expected"])
    mine = [h["score"] for h in row["top"] if h["hypothesis"] == name]
    others = [h["score"] for h in row["top"] if h["hypothesis"] != name]
    return mine[0] - max(others) if mine and others else math.nan


def gaps(record: dict) -> dict:
    """``(fault, magnitude, model error) -> {"nights": {k: [gap, ...]}, "between": sd,
    "within": sd, "vehicles": n}`` over the detected nights: the gaps on the k-th night from
    the onset, and over the vehicles detected on every night, the spread of a vehicle's mean
    gap (between) and of its gaps about that mean (within, averaged)."""
    grid = record["grid"]
    onset = grid["grid"]["baseline_days"] + grid["grid"]["pre_nights"]
    nights = grid["grid"]["post_nights"]
    per = collections.defaultdict(lambda: collections.defaultdict(dict))
    for row in grid["rows"]:
        if not row["expected"] or not row.get("alarm") or not row["diagnosed"]:
            continue
        key = (row["fault"], row["magnitude"], row["model_error"])
        per[key][row["seed"], row["vehicle"]][row["night"] - onset + 1] = gap(row)
    out = {}
    for key, vehicles in per.items():
        by_night = {k: [v[k] for v in vehicles.values() if k in v and math.isfinite(v[k])]
                    for k in range(1, nights + 1)}
        full = np.array([[v[k] for k in range(1, nights + 1)] for v in vehicles.values()
                         if all(math.isfinite(v.get(k, math.nan)) for k in range(1, nights + 1))])
        out[key] = {"nights": by_night, "vehicles": len(full),
                    "between": float(full.mean(axis=1).std(ddof=1)) if len(full) > 1 else math.nan,
                    "within": (float(full.std(axis=1, ddof=1).mean())
                               if len(full) > 1 and nights > 1 else math.nan)}
    return out


def gap_table(records: list[dict], names: list[str], faults=("bias",)) -> list[str]:
    """The gaps of ``faults``' cells night by night: mean, standard deviation and share
    positive; and the between- and within-vehicle spreads."""
    nights = max(r["grid"]["grid"]["post_nights"] for r in records)
    head = ["fault", "magnitude", "model error", "run"] + [
        f"night {k}: gap mean / sd (positive)" for k in range(1, nights + 1)] + [
        "vehicle's mean gap: sd between vehicles / within (vehicles)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, record in zip(names, records):
        for (fault, magnitude, error), cell in sorted(gaps(record).items()):
            if fault not in faults:
                continue
            parts = []
            for k in range(1, nights + 1):
                g = np.array(cell["nights"].get(k, []))
                parts.append(f"{g.mean():.2f} / {g.std(ddof=1):.2f} ({int((g > 0).sum())}/{len(g)})"
                             if len(g) > 1 else "-")
            lines.append(f"| {fault} | {magnitude:g} | {error:.0%} | {name} | " + " | ".join(parts)
                         + f" | {cell['between']:.2f} / {cell['within']:.2f} "
                           f"({cell['vehicles']}) |")
    return lines


def summary(records: list[dict], names: list[str]) -> list[str]:
    """Per record and model error: healthy nights given a cause (and of those that alarmed),
    and the CPU seconds per diagnosed night."""
    lines = ["| run | model error | healthy nights given a cause | false alarms given a cause | "
             "diagnosed nights | CPU s per diagnosed night (median / 90th pct. / largest) | "
             "diagnosis errors |", "|---|---|---|---|---|---|---|"]
    for name, record in zip(names, records):
        rows = record["grid"]["rows"]
        for f in scores.false_causes(rows):
            mine = [r for r in rows if r["model_error"] == f["model_error"]]
            cost = scores.cost(mine)
            errors = sum("diagnosis_error" in r for r in mine)
            lines.append(
                f"| {name} | {f['model_error']:.0%} | "
                f"{hit_share(f['with_cause'], f['healthy_nights'])}"
                f" | {f['false_alarms_with_cause']}/{f['false_alarms']} | {cost['diagnosed']} | "
                f"{cost.get('cpu_median', float('nan')):.2f} / {cost.get('cpu_p90', float('nan')):.2f}"
                f" / {cost.get('cpu_max', float('nan')):.2f} | {errors} |")
    return lines


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m benchmarks.diagnosis.by_night",
                                description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("records", nargs="+", type=pathlib.Path, metavar="F.json")
    p.add_argument("--names", help="the columns' names, comma-separated (default the files')")
    args = p.parse_args(argv)
    records = [json.loads(path.read_text()) for path in args.records]
    names = args.names.split(",") if args.names else [path.stem for path in args.records]
    print("\n".join(table(records, names) + [""] + night_by_night(records, names) + [""]
                    + gap_table(records, names) + [""] + summary(records, names)))


if __name__ == "__main__":
    main()
