"""``python -m benchmarks.zoo.fleets``: the zoo's targets judged on several fleets at once.

One zoo run (``python -m benchmarks.zoo --seed S --json F``) gives each family 300 healthy
asset-nights, whose 95 % bound allows a single alarm; issue 18's targets are judged better on
the fleets of several seeds pooled. This reads the JSON of each run and prints, per family,
the healthy alarms over every fleet with their Clopper-Pearson interval, the faults found
within three nights at each magnitude, and whether each target holds: at most 1 % false
alarms per asset-night with the upper 95 % bound at most 2 %, and at least 95 % of the large
faults. Families are matched by name; a family missing from a run is pooled over the others.

Examples
--------
python -m benchmarks.zoo.fleets /tmp/zoo/seed1.json /tmp/zoo/seed2.json
"""
from __future__ import annotations

import argparse
import json
from dataclasses import dataclass

from benchmarks.detection.metrics import rate
from benchmarks.zoo.report import failure_counts, false_alarm_cell, share

#: issue 18's targets: false alarms per healthy asset-night, the bound's limit, large faults
RATE_TARGET, BOUND_TARGET, LARGE_TARGET = 0.01, 0.02, 0.95


@dataclass(frozen=True)
class PooledFamily:
    """One family's counts summed over the runs that hold it."""

    family: str
    title: str
    held_out: bool
    seeds: tuple[int, ...]
    alarms: int
    asset_nights: int
    small: tuple[int, int]
    large: tuple[int, int]
    failures: int
    #: days the product reports as ``not operating``, neither scored nor failed
    #: (:func:`benchmarks.zoo.report.failure_counts`)
    not_operating: int = 0

    @property
    def false_alarms(self) -> dict:
        """The alarms, asset-nights, rate and 95 % Clopper-Pearson interval."""
        return rate(self.alarms, self.asset_nights)

    @property
    def false_alarms_met(self) -> bool:
        """At most 1 % per asset-night and the upper 95 % bound at most 2 %."""
        figure = self.false_alarms
        return bool(self.asset_nights) and (figure["rate"] <= RATE_TARGET
                                            and figure["interval"][1] <= BOUND_TARGET)

    @property
    def large_met(self) -> bool:
        """At least 95 % of the large faults alarmed within three nights."""
        found, assets = self.large
        return bool(assets) and found >= LARGE_TARGET * assets


def pool(runs: list[list[dict]]) -> list[PooledFamily]:
    """Each family's counts summed over ``runs`` (each a zoo run's JSON), in first-seen order."""
    order: list[str] = []
    parts: dict[str, list[dict]] = {}
    for run in runs:
        for result in run:
            if result["family"] not in parts:
                order.append(result["family"])
            parts.setdefault(result["family"], []).append(result)
    out = []
    for name in order:
        results = parts[name]
        failures, not_operating = map(sum, zip(*(failure_counts(r) for r in results)))
        out.append(PooledFamily(
            family=name, title=results[0]["title"], held_out=results[0]["held_out"],
            seeds=tuple(r["seed"] for r in results),
            alarms=sum(r["false_alarms"]["alarms"] for r in results),
            asset_nights=sum(r["false_alarms"]["asset_nights"] for r in results),
            small=tuple(map(sum, zip(*(r["detected_small"] for r in results)))),
            large=tuple(map(sum, zip(*(r["detected_large"] for r in results)))),
            failures=failures, not_operating=not_operating))
    return out


def markdown(families: list[PooledFamily]) -> str:
    """A table, one row per family, tuning families first, and the totals per role."""
    rows = []
    ordered = sorted(families, key=lambda f: f.held_out)
    for f in ordered:
        rows.append(
            f"| {f.title} | {'held out' if f.held_out else 'tuning'} | "
            f"{', '.join(map(str, f.seeds))} | {false_alarm_cell(f.false_alarms)} | "
            f"{'met' if f.false_alarms_met else 'NOT MET'} | {share(*f.small)} | "
            f"{share(*f.large)} | {'met' if f.large_met else 'NOT MET'} | {f.failures} | "
            f"{f.not_operating} |")
    totals = []
    for role, held_out in (("tuning", False), ("held out", True)):
        group = [f for f in families if f.held_out == held_out]
        if group:
            alarms = sum(f.alarms for f in group)
            nights = sum(f.asset_nights for f in group)
            small = (sum(f.small[0] for f in group), sum(f.small[1] for f in group))
            large = (sum(f.large[0] for f in group), sum(f.large[1] for f in group))
            totals.append(f"- {role}: healthy alarms {alarms}/{nights}, small faults "
                          f"{share(*small)}, large {share(*large)}; false-alarm target met in "
                          f"{sum(f.false_alarms_met for f in group)} of {len(group)} families, "
                          f"large-fault target in {sum(f.large_met for f in group)}")
    return "\n".join([
        "| family | role | seeds | false alarms per healthy asset-night (95 % CI) | "
        "<= 1 %, bound <= 2 % | small faults within 3 nights | large faults within 3 nights | "
        ">= 95 % large | failures | days not operating |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *rows, "", *totals])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.zoo.fleets",
                                     description=__doc__.split("\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="Examples" + __doc__.split("Examples", 1)[1])
    parser.add_argument("runs", nargs="+", help="JSON files of zoo runs (--json)")
    args = parser.parse_args(argv)
    runs = []
    for path in args.runs:
        with open(path) as handle:
            runs.append(json.load(handle))
    print(markdown(pool(runs)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
