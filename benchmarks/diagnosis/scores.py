"""The diagnosis scores of a run's rows: accuracy per cell, confusion, estimate errors,
"no single cause" counts, the false-cause rate and the cost.

*Detected* asset-nights are the faulty ones after the onset whose drift alarmed; only they
are diagnosed. *Top-1*: the diagnosis explains the night (its best scores above 0) and its
first hypothesis is the expected one. *Top-3*: the expected hypothesis is among the first
three and scores above 0 (a hypothesis the diagnosis itself calls no better than healthy is
not an answer). A noise fault counts only when its noise level rose.
"""
from __future__ import annotations

import collections
import math

import numpy as np


NO_CAUSE = "no single cause"


def first_label(row: dict) -> str:
    """What the diagnosis said first: its first hypothesis, or "no single cause"; a noise
    level says whether it went up or down."""
    if not row.get("explained"):
        return NO_CAUSE
    if row["first_kind"] == "noise":
        return f"{row['first']} {'up' if row['first_estimate'] > 1 else 'down'}"
    return row["first"]


def first_if_noise_only_rises(row: dict) -> str | None:
    """The first hypothesis (``"kind target"``) if a noise hypothesis could only explain a
    rise of the errors' spread (a fall scoring as healthy), read from the kept first five;
    None when no kept hypothesis would score above 0. A re-reading of the ranking, not the
    product's answer."""
    for h in row.get("top", ()):
        if h["hypothesis"].endswith("noise level") and h["estimate"] < 1:
            continue
        return h["hypothesis"] if h["score"] > 0 else None
    return None


def _detected(rows: list[dict]) -> list[dict]:
    return [r for r in rows if r["fault"] != "healthy" and r.get("alarm") and r["diagnosed"]]


def _right_way(row: dict, field: str) -> bool:
    """A noise fault is found by a noise level that rose: a fall is not its answer."""
    return not (row["expected"] or "").startswith("noise ") or row[field] > 1


def _hypothesis_name(expected: str) -> str:
    """``"bias omega"`` -> ``"omega sensor bias"``, as :class:`graybox.Hypothesis` names it."""
    kind, target = expected.split(" ", 1)
    return {"parameter": f"parameter {target}", "bias": f"{target} sensor bias",
            "gain": f"{target} sensor gain", "noise": f"{target} noise level"}[kind]


def accuracy(rows: list[dict]) -> list[dict]:
    """One record per (fault kind, magnitude, model error): nights scored, detected
    (alarmed and diagnosed), top-1, top-3, "no single cause", the most frequent first answer
    and the implied magnitude of the expected hypothesis (median, and its median absolute
    error against the truth, over the detected nights where it was ranked)."""
    cells = collections.defaultdict(list)
    for row in rows:
        if row["fault"] != "healthy" and row.get("alarm") is not None:
            cells[row["fault"], row["magnitude"], row["model_error"]].append(row)
    out = []
    for (fault, magnitude, error), mine in sorted(cells.items()):
        detected = _detected(mine)
        expected = mine[0].get("expected")
        top1 = sum(r["explained"] and r["expected_rank"] == 1 and _right_way(r, "first_estimate")
                   for r in detected)
        name = None if expected is None else _hypothesis_name(expected)
        rise_only = sum(first_if_noise_only_rises(r) == name for r in detected)
        top3 = sum(r.get("expected_rank") is not None and r["expected_rank"] <= 3
                   and r["expected_score"] > 0 and _right_way(r, "expected_estimate")
                   for r in detected)
        implied = [r["implied_magnitude"] for r in detected
                   if r.get("implied_magnitude") is not None
                   and math.isfinite(r["implied_magnitude"])]
        firsts = collections.Counter(first_label(r) for r in detected)
        out.append({
            "fault": fault, "magnitude": magnitude, "size": mine[0]["size"],
            "model_error": error, "nights": len(mine), "detected": len(detected),
            "expected": expected,
            "top1": top1 if expected else None, "top3": top3 if expected else None,
            "top1_noise_rise_only": rise_only if expected else None,
            "no_cause": sum(not r["explained"] for r in detected),
            "most_first": firsts.most_common(1)[0][0] if firsts else "",
            "implied_median": float(np.median(implied)) if implied else math.nan,
            "implied_abs_error": (float(np.median(np.abs(np.array(implied) - magnitude)))
                                  if implied else math.nan),
            "implied_n": len(implied)})
    return out


def confusion(rows: list[dict]) -> dict:
    """``{model_error: {fault kind: Counter(first answer)}}`` over the detected nights (all
    magnitudes), with ``"healthy"`` for the healthy nights (all of them, alarmed or not)."""
    table = collections.defaultdict(lambda: collections.defaultdict(collections.Counter))
    for row in _detected(rows):
        table[row["model_error"]][row["fault"]][first_label(row)] += 1
    for row in rows:
        if row["fault"] == "healthy" and row["diagnosed"]:
            table[row["model_error"]]["healthy"][first_label(row)] += 1
    return {error: {fault: dict(counter) for fault, counter in faults.items()}
            for error, faults in table.items()}


def false_causes(rows: list[dict]) -> list[dict]:
    """Per model error: healthy nights diagnosed, those given a cause (the false-cause rate),
    and the same over the healthy nights that alarmed (false alarms)."""
    out = []
    for error in sorted({r["model_error"] for r in rows}):
        healthy = [r for r in rows if r["model_error"] == error and r["fault"] == "healthy"
                   and r["diagnosed"]]
        alarmed = [r for r in healthy if r["alarm"]]
        causes = collections.Counter(first_label(r) for r in healthy if r["explained"])
        out.append({"model_error": error, "healthy_nights": len(healthy),
                    "with_cause": sum(r["explained"] for r in healthy),
                    "false_alarms": len(alarmed),
                    "false_alarms_with_cause": sum(r["explained"] for r in alarmed),
                    "causes": dict(causes)})
    return out


def cost(rows: list[dict]) -> dict:
    """Seconds per diagnosed asset-night: median, 90th percentile and largest; and the same
    of the process' CPU seconds (``cpu_*``, which the load of a shared machine moves less)
    when the rows hold them (runs before 2026-11-27 did not)."""
    diagnosed = [r for r in rows if r["diagnosed"]]
    seconds = np.array([r["seconds"] for r in diagnosed])
    if not len(seconds):
        return {"diagnosed": 0}
    out = {"diagnosed": int(len(seconds)), "median": float(np.median(seconds)),
           "p90": float(np.percentile(seconds, 90)), "max": float(seconds.max())}
    if all("cpu_seconds" in r for r in diagnosed):
        cpu = np.array([r["cpu_seconds"] for r in diagnosed])
        out.update(cpu_median=float(np.median(cpu)), cpu_p90=float(np.percentile(cpu, 90)),
                   cpu_max=float(cpu.max()))
    return out
