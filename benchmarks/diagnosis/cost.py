"""``python -m benchmarks.diagnosis.cost [--families F,F] [--repeat N] [--nights K]
[--thinning M]``

What one alarmed night's diagnosis costs per plant-zoo family: one healthy vehicle, a 3-day
baseline of the family's coarse white box (untuned), then ``graybox.diagnose`` on the fourth
day without a time budget (with ``--nights 2``: on the fourth and fifth, the span of a
candidate of two nights, as the nightly flow diagnoses it; with ``--thinning M``: from every
M-th of the level tier's starting points, ``diagnose(..., thinning=M)``), timed (wall clock,
and the process' CPU time, which a machine shared with other work moves less); the median
of ``--repeat`` runs. Prints one line per family: states, hypotheses, samples per night,
seconds.
"""
from __future__ import annotations

import argparse
import statistics
import time

import graybox as gb
from benchmarks.zoo.families import discover
from benchmarks.zoo.cost import day_windows
from benchmarks.zoo.run import plan_fleet
from graybox.diagnosis import candidate_hypotheses, diagnose

DEFAULT_FAMILIES = ("hydraulic_level", "pendulum_crane", "traction_drive")


def measure(name: str, repeat: int = 1, nights: int = 1, thinning: int = 1) -> dict:
    """The diagnosis cost of family ``name`` on ``nights`` nights (see the module docstring)."""
    family = discover()[name]
    model = gb.load_model(family.spec, dict(family.parameters), dict(family.columns))
    vehicles, _ = plan_fleet(family, 1, 0, 1, 3)
    windows = day_windows(family, model, vehicles, 3 + nights)[vehicles[0].asset_id]
    baseline = gb.fit_signatures([gb.FitRequest(model, windows[:3])])[0]
    seconds, cpu = [], []
    for _ in range(repeat):
        began, began_cpu = time.perf_counter(), time.process_time()
        diagnosis = diagnose(baseline, windows[3:], model, time_budget=None,
                             thinning=thinning)
        seconds.append(time.perf_counter() - began)
        cpu.append(time.process_time() - began_cpu)
    return {"family": name, "states": len(model.states), "hidden": len(model.hidden_states),
            "hypotheses": len(candidate_hypotheses(model)), "samples": family.samples_per_day,
            "nights": nights, "seconds": statistics.median(seconds),
            "cpu_seconds": statistics.median(cpu), "summary": diagnosis.summary()}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.diagnosis.cost",
                                     description=__doc__.split("\n\n")[1])
    parser.add_argument("--families", default=",".join(DEFAULT_FAMILIES),
                        help=f"plant-zoo families (default {','.join(DEFAULT_FAMILIES)})")
    parser.add_argument("--repeat", type=int, default=1, help="runs per family (median)")
    parser.add_argument("--nights", type=int, default=1,
                        help="nights diagnosed together (2: a candidate of two nights)")
    parser.add_argument("--thinning", type=int, default=1,
                        help="predict from every M-th starting point only (default 1: all)")
    args = parser.parse_args(argv)
    for name in args.families.split(","):
        row = measure(name, args.repeat, args.nights, args.thinning)
        print(f"{row['family']}: {row['states']} states ({row['hidden']} hidden), "
              f"{row['hypotheses']} hypotheses, {row['samples']} samples a night, "
              f"{row['nights']} diagnosed: {row['seconds']:.2f} s an alarmed night, "
              f"{row['cpu_seconds']:.2f} s CPU "
              f"({row['summary']})", flush=True)


if __name__ == "__main__":
    main()
