"""The markdown section of a diagnosis run: the accuracy table, the confusion tables, the
false-cause rate and the cost."""
from __future__ import annotations

import math

from benchmarks.detection.grid import UNRECORDED_CANDIDATE_NIGHTS
from benchmarks.diagnosis import scores

TARGET = 0.8


def hit_share(hits: int | None, total: int) -> str:
    """A table cell ``hits/total (share)``: ``-`` when ``hits`` is None, ``0/0`` of none.

    >>> hit_share(3, 4), hit_share(None, 4), hit_share(0, 0)
    ('3/4 (75%)', '-', '0/0')
    """
    if hits is None:
        return "-"
    return f"{hits}/{total} ({hits / total:.0%})" if total else "0/0"


def _error(value) -> str:
    """A model error as a percentage, or its name (the zoo's "coarse" white boxes)."""
    return f"{value:.0%}" if isinstance(value, float) else str(value)


def _num(value: float, digits: int = 3) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.{digits}g}"


def accuracy_table(cells: list[dict]) -> list[str]:
    lines = ["| fault | magnitude | model error | nights | detected | expected first | top-1 | "
             "top-3 | top-1 if noise only rises | no single cause | most frequent first | "
             "implied magnitude (median) | its median abs. error |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in cells:
        lines.append(
            f"| {c['fault']} | {c['magnitude']:g} ({c['size']}) | {_error(c['model_error'])} | "
            f"{c['nights']} | {c['detected']} | {c['expected'] or '(none)'} | "
            f"{hit_share(c['top1'], c['detected'])} | {hit_share(c['top3'], c['detected'])} | "
            f"{hit_share(c['top1_noise_rise_only'], c['detected'])} | "
            f"{c['no_cause']} | {c['most_first']} | {_num(c['implied_median'])} "
            f"(n={c['implied_n']}) | {_num(c['implied_abs_error'])} |")
    return lines


def confusion_tables(confusion: dict) -> list[str]:
    lines = []
    for error, faults in sorted(confusion.items()):
        answers = sorted({a for counter in faults.values() for a in counter},
                         key=lambda a: (a == scores.NO_CAUSE, a))
        lines += ["", f"Model error {_error(error)} (rows: fault kind, all magnitudes, detected "
                      f"nights; healthy: every healthy night; columns: first answer)", "",
                  "| fault | " + " | ".join(answers) + " |",
                  "|---|" + "---|" * len(answers)]
        for fault in sorted(faults, key=lambda f: (f == "healthy", f)):
            counts = (str(faults[fault].get(a, "")) for a in answers)
            lines.append(f"| {fault} | " + " | ".join(counts) + " |")
    return lines


def headline(cells: list[dict]) -> str:
    """Top-1 at the middle magnitude with the white box 20 % off, against the target."""
    parts = []
    for c in cells:
        if (c["size"] == "middle" and c["model_error"] == 0.2 and c["expected"]):
            share = c["top1"] / c["detected"] if c["detected"] else math.nan
            parts.append(f"{c['fault']} {hit_share(c['top1'], c['detected'])}"
                         + ("" if not c["detected"] else (" (meets)" if share >= TARGET
                                                          else " (misses)")))
    return (f"Target (issue 19): top-1 >= {TARGET:.0%} for detected faults at the middle "
            f"magnitude with the white box 20 % off: " + ("; ".join(parts) or "not run") + ".")


def _episode(grid: dict) -> str:
    """The ``since-alarm`` experiment's protocol, said in the header ("" for the product's)."""
    if grid.get("evidence", "candidate") == "candidate":
        return ""
    return (f"; an alarmed night diagnosed instead on its alert episode ({grid['evidence']}: "
            f"from the span of the candidate that opened the alert, at most "
            f"{grid['episode_nights']} nights; an experiment, not the product)")


def _rate(sample_interval: float) -> str:
    """``"1 Hz"`` for 1-s samples (as the first zoo families' records, which do not store
    it), else ``"30 s samples"``."""
    return "1 Hz" if sample_interval == 1.0 else f"{sample_interval:g} s samples"


def scored(rows: list[dict], sample_interval: str) -> list[str]:
    """The accuracy table, the confusion tables, the false causes and the cost of ``rows``."""
    cost = scores.cost(rows)
    lines = [*accuracy_table(scores.accuracy(rows)), "",
             "**Confusion** (first answer per detected night):",
             *confusion_tables(scores.confusion(rows)), "",
             "**False causes** (healthy nights, every one diagnosed):", "",
             "| model error | healthy nights | given a cause | false alarms | false alarms given "
             "a cause | causes |", "|---|---|---|---|---|---|"]
    for f in scores.false_causes(rows):
        lines.append(f"| {_error(f['model_error'])} | {f['healthy_nights']} | "
                     f"{hit_share(f['with_cause'], f['healthy_nights'])} | {f['false_alarms']} | "
                     f"{f['false_alarms_with_cause']} | "
                     f"{', '.join(f'{k}: {v}' for k, v in f['causes'].items()) or '-'} |")
    if cost.get("diagnosed"):
        lines += ["", f"**Cost**: {cost['diagnosed']} diagnosed asset-nights at "
                      f"{sample_interval}: median {cost['median']:.2f} s, 90th percentile "
                      f"{cost['p90']:.2f} s, largest {cost['max']:.2f} s per asset-night (one "
                      "process)" + (f"; CPU median {cost['cpu_median']:.2f} s, 90th percentile "
                                    f"{cost['cpu_p90']:.2f} s, largest {cost['cpu_max']:.2f} s."
                                    if "cpu_median" in cost else ".")]
    return lines


def render(result: dict | None, command: str, wall_seconds: float, load: tuple[str, str],
           zoo: list[dict] = ()) -> str:
    """The section, from :func:`benchmarks.diagnosis.grid_run.run_grid`'s result (None when
    the grid did not run) and :func:`benchmarks.diagnosis.zoo_run.run_family`'s."""
    lines = [f"Command: `{command}`; wall time {wall_seconds:.0f} s; load before: `{load[0]}`; "
             f"after: `{load[1]}`."]
    if result is not None:
        grid = result["grid"]
        cells = scores.accuracy(result["rows"])
        lines += ["", f"Grid: seeds {grid['seeds']} x {grid['vehicles']} vehicles; magnitudes "
                      f"{grid['magnitudes']}; model errors {grid['model_errors']}; baseline "
                      f"{grid['baseline_days']} days, {grid['pre_nights']} healthy nights before "
                      f"the onset, {grid['post_nights']} nights from it; "
                      f"{grid['sample_interval']:g} s samples; candidates fitted and diagnosed "
                      f"on {grid.get('candidate_nights', UNRECORDED_CANDIDATE_NIGHTS)} night(s)"
                      + _episode(grid) + ". White box tuned on the "
                      f"baseline days when off: {result['tuned'] or 'no (untuned)'}.", "",
                  headline(cells), "",
                  *scored(result["rows"], f"{grid['sample_interval']:g} s samples")]
    for family in zoo:
        lines += ["", f"**Zoo: {family['family']}** ({family['healthy_assets']} vehicles, "
                      f"{family['baseline_days']} baseline days, {family['nights']} healthy "
                      f"nights each, {family['faulty_per_cell']} faulty assets per kind and "
                      f"magnitude scored on 3 nights, candidates on {family['candidate_nights']} "
                      f"night(s), diagnosed on {family.get('diagnosis_nights', 1)}; coarse white "
                      f"box tuned on {family['tuned']}):", "",
                  *scored(family["rows"], _rate(family.get("sample_interval", 1.0)))]
    return "\n".join(lines) + "\n"
