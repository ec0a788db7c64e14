"""``python -m benchmarks.diagnosis [--sizes middle] [--model-errors 0,0.2] [--zoo F,F]
[--out F.md] [--json F.json]``

Runs :func:`graybox.diagnose` on the alarmed asset-nights of the gas-turbine detection grid
(and on every healthy night), each on its candidate's nights as the nightly flow does
(``--candidate-nights``, default the product's), and scores which cause comes first; with
``--zoo``, the same on two plant-zoo families with their coarse white boxes. Progress goes to stderr; the
markdown section to ``--out`` (or stdout), the rows and settings to ``--json``.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import shlex
import sys
import time
from dataclasses import replace

from benchmarks.comma_floats import comma_floats
from benchmarks.detection.grid import DEFAULT_MAGNITUDES
from benchmarks.diagnosis.episode import EPISODE_NIGHTS, EVIDENCE
from benchmarks.diagnosis.expected_zoo import ZOO
from benchmarks.diagnosis.grid_run import DETECTION, SIZES, DiagnosisGrid, run_grid
from benchmarks.diagnosis.report import render

KINDS = tuple(DEFAULT_MAGNITUDES)


def _names(known: tuple[str, ...]):
    def parse(text: str) -> tuple[str, ...]:
        names = tuple(x.strip() for x in text.split(",") if x.strip())
        wrong = [n for n in names if n not in known]
        if wrong:
            raise argparse.ArgumentTypeError(f"unknown {wrong}; known: {', '.join(known)}")
        return names
    return parse


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m benchmarks.diagnosis", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--kinds", type=_names(KINDS), default=KINDS, metavar="K,K",
                   help=f"fault kinds (default all: {', '.join(KINDS)})")
    p.add_argument("--sizes", type=_names(SIZES), default=("middle",), metavar="S,S",
                   help="the detection grid's magnitudes to run: small, middle, large "
                        "(default middle)")
    errors = ",".join(f"{e:g}" for e in DETECTION.model_errors)
    p.add_argument("--model-errors", type=comma_floats, default=DETECTION.model_errors,
                   metavar="E,E",
                   help=f"white-box errors (default {errors}); a white box off is tuned first")
    p.add_argument("--untuned", action="store_true",
                   help="do not tune a white box that is off (the known weakness, for comparison)")
    p.add_argument("--seeds", type=int, default=len(DETECTION.seeds),
                   help="seeds 1..N (default %(default)s)")
    p.add_argument("--vehicles", type=int, default=DETECTION.vehicles,
                   help="vehicles per seed (default %(default)s)")
    p.add_argument("--baseline-days", type=int, default=DETECTION.baseline_days)
    p.add_argument("--pre-nights", type=int, default=DETECTION.pre_nights,
                   help="healthy nights between the baseline and the onset (default %(default)s)")
    p.add_argument("--post-nights", type=int, default=DETECTION.post_nights,
                   help="nights from the onset (default %(default)s)")
    p.add_argument("--candidate-nights", type=int, default=DETECTION.candidate_nights,
                   help="nights a candidate is fitted and diagnosed on (default the product's "
                        "[nightly] candidate_nights: %(default)s)")
    p.add_argument("--evidence", choices=EVIDENCE, default=EVIDENCE[0],
                   help="what an alarmed night is diagnosed on: its candidate's nights (default, "
                        "the product) or, an experiment the product does not run, every night "
                        "since its alert opened (since-alarm)")
    p.add_argument("--episode-nights", type=int, default=EPISODE_NIGHTS,
                   help="with --evidence since-alarm, the alert episode's nights at most "
                        "(default %(default)s; at least --candidate-nights)")
    p.add_argument("--zoo", type=_names(tuple(ZOO)), default=(), metavar="F,F",
                   help=f"also the plant-zoo families ({', '.join(ZOO)}), reduced")
    p.add_argument("--zoo-vehicles", type=int, default=3, help="healthy vehicles per family")
    p.add_argument("--zoo-faulty", type=int, default=2,
                   help="faulty assets per fault kind and magnitude (default 2)")
    p.add_argument("--no-grid", action="store_true", help="the zoo families only")
    p.add_argument("--rerender", type=pathlib.Path, metavar="FILE.json",
                   help="do not run: render the section again from a --json record")
    p.add_argument("--out", type=pathlib.Path, help="write the markdown section here")
    p.add_argument("--json", type=pathlib.Path, help="write the settings, rows and clock here")
    args = p.parse_args(argv)
    if args.episode_nights < args.candidate_nights:
        p.error(f"--episode-nights {args.episode_nights} is below --candidate-nights "
                f"{args.candidate_nights}")
    return args


def grid_from_args(args: argparse.Namespace) -> DiagnosisGrid:
    magnitudes, sizes = {}, {}
    for kind in args.kinds:
        chosen = [(size, m) for size, m in zip(SIZES, DEFAULT_MAGNITUDES[kind])
                  if size in args.sizes]
        magnitudes[kind] = tuple(m for _, m in chosen)
        sizes.update({(kind, m): size for size, m in chosen})
    detection = replace(DETECTION, magnitudes=magnitudes, model_errors=tuple(args.model_errors),
                        seeds=tuple(range(1, args.seeds + 1)), vehicles=args.vehicles,
                        baseline_days=args.baseline_days, pre_nights=args.pre_nights,
                        post_nights=args.post_nights, candidate_nights=args.candidate_nights)
    return DiagnosisGrid(detection, sizes, tune=not args.untuned, evidence=args.evidence,
                         episode_nights=args.episode_nights)


def _load_now() -> str:
    """The clock and the load averages as ``uptime`` words them (``12:55:50 load average:
    2.02, 1.70, 1.69``), the part of its line the section quotes."""
    return (time.strftime("%H:%M:%S") + " load average: "
            + ", ".join(f"{x:.2f}" for x in os.getloadavg()))


def _finite(value):
    """JSON has no NaN or infinity: None instead."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def main(argv=None) -> int:
    args = parse_args(argv)
    if args.rerender:
        record = json.loads(args.rerender.read_text())
        section = render(record["grid"], record["command"], record["wall_seconds"],
                         tuple(record["load"]), record["zoo"])
        if args.out:
            args.out.write_text(section)
        else:
            print(section)
        return 0
    command = "python -m benchmarks.diagnosis " + " ".join(
        shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv))
    load_before = _load_now()
    began = time.perf_counter()
    def say(line: str) -> None:
        print(f"[diagnosis] {line}", file=sys.stderr, flush=True)

    result = None if args.no_grid else run_grid(grid_from_args(args), say)
    zoo = []
    if args.zoo:
        from benchmarks.diagnosis.zoo_run import run_family
        from benchmarks.zoo.families import discover
        families = discover()
        zoo = [run_family(families[name], healthy_assets=args.zoo_vehicles,
                          faulty_per_cell=args.zoo_faulty, progress=say) for name in args.zoo]
    wall = time.perf_counter() - began
    load_after = _load_now()
    section = render(result, command.strip(), wall, (load_before, load_after), zoo)
    if args.out:
        args.out.write_text(section)
        print(f"wrote {args.out}")
    else:
        print(section)
    if args.json:
        record = {"grid": result, "zoo": zoo, "command": command.strip(),
                  "wall_seconds": wall, "load": [load_before, load_after]}
        args.json.write_text(json.dumps(_finite(record), indent=1, default=str))
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
