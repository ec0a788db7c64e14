"""``python -m benchmarks.detection [--quick] [--seeds N] [--out docs/benchmarks.md]``

Runs the scenario grid, writes the markdown report, its PNG plots and the raw CSV. Progress
goes to stderr; the paths written and the headline go to stdout.
"""
from __future__ import annotations

import argparse
import datetime as dt
import os
import pathlib
import platform
import shlex
import subprocess
import sys
import threading
import time

from benchmarks.comma_floats import comma_floats
from benchmarks.detection.grid import DEFAULT_MAGNITUDES, KINDS, Grid, fault_summary

DISCUSSION = pathlib.Path(__file__).with_name("discussion.md")
#: the full grid, whose settings are the options' defaults
FULL = Grid()


def _magnitudes(text: str) -> dict:
    """``friction=0.1,0.2,0.35;noise=0.05,0.1`` (kinds not named keep their defaults)."""
    out = dict(DEFAULT_MAGNITUDES)
    for part in text.split(";"):
        if not part.strip():
            continue
        kind, _, values = part.partition("=")
        kind = kind.strip()
        if kind not in KINDS:
            raise argparse.ArgumentTypeError(f"unknown fault kind {kind!r}; known: {list(KINDS)}")
        out[kind] = comma_floats(values)
    return out


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m benchmarks.detection", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true",
                   help="reduced grid: one seed, two vehicles per seed (a smoke run)")
    p.add_argument("--seeds", type=int, default=None,
                   help=f"number of seeds, 1..N (default {len(FULL.seeds)}; 1 with --quick)")
    p.add_argument("--vehicles", type=int, default=None,
                   help=f"vehicles per seed (default {FULL.vehicles}; 2 with --quick)")
    p.add_argument("--model-errors", type=comma_floats, default=FULL.model_errors,
                   metavar="E,E,...")
    p.add_argument("--magnitudes", type=_magnitudes, default=None,
                   metavar="KIND=M,M,M;...", help="override magnitudes of some fault kinds")
    p.add_argument("--sample-interval", type=float, default=FULL.sample_interval,
                   help=f"seconds (default {FULL.sample_interval:g})")
    p.add_argument("--baseline-days", type=int, default=FULL.baseline_days)
    p.add_argument("--candidate-nights", type=int, default=FULL.candidate_nights,
                   metavar="N", help="gray-box candidates fitted on the night and the N - 1 before "
                   "it, as [nightly] candidate_nights (default: the product's default, %(default)s)")
    p.add_argument("--estimate", type=lambda text: tuple(n for n in text.split(",") if n),
                   default=FULL.estimate, metavar="NAME,NAME,...",
                   help="white-box parameters each gray-box baseline tunes to its vehicle "
                        "first, as a class's estimate = [...] (default none)")
    p.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    p.add_argument("--threads", type=int, default=1, help="torch threads per worker (default 1)")
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("docs/benchmarks.md"))
    p.add_argument("--rerender", action="store_true",
                   help="do not run: re-render the report at --out from the raw CSV and run "
                        "record saved next to it (e.g. after editing the discussion)")
    p.add_argument("--discussion", type=pathlib.Path, default=DISCUSSION,
                   help="markdown appended to the report as the discussion (default: the "
                        "package's discussion.md, if present)")
    return p.parse_args(argv)


def grid_from_args(args: argparse.Namespace) -> Grid:
    seeds = args.seeds if args.seeds is not None else (1 if args.quick else len(FULL.seeds))
    vehicles = args.vehicles if args.vehicles is not None else (2 if args.quick else FULL.vehicles)
    return Grid(magnitudes=args.magnitudes or dict(DEFAULT_MAGNITUDES),
                model_errors=tuple(args.model_errors), seeds=tuple(range(1, seeds + 1)),
                vehicles=vehicles, baseline_days=args.baseline_days,
                sample_interval=args.sample_interval, candidate_nights=args.candidate_nights,
                estimate=tuple(args.estimate))


class LoadMonitor:
    """Samples the 1-minute load average while the benchmark runs."""

    def __init__(self, every: float = 10.0):
        self.samples = [os.getloadavg()[0]]
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(every,), daemon=True)

    def _run(self, every):
        while not self._stop.wait(every):
            self.samples.append(os.getloadavg()[0])

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self.samples.append(os.getloadavg()[0])

    def note(self, processes: int) -> str:
        cpus = os.cpu_count() or 1
        mean = sum(self.samples) / len(self.samples)
        text = (f"1-minute load average during the run: mean {mean:.1f} (min {min(self.samples):.1f}, "
                f"max {max(self.samples):.1f}) on {cpus} CPUs")
        others = mean - min(processes, cpus)
        if others > 0.5:
            text += (f": the machine was shared with other jobs (about {others:.1f} CPUs busy "
                     f"besides this run), so wall times are inflated")
        return text


def _commit() -> str:
    try:
        root = pathlib.Path(__file__).resolve().parents[2]
        sha = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, text=True,
                             capture_output=True, check=True).stdout.strip()
        # only the code the numbers depend on
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "graybox", "benchmarks/detection"],
                               cwd=root, text=True, capture_output=True).stdout.strip()
        return sha + ("+uncommitted changes to graybox/ or benchmarks/detection/" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _versions() -> str:
    import numpy
    import pandas
    import scipy

    try:
        from importlib.metadata import version

        torch = version("torch")
    except Exception:  # pragma: no cover - torch missing
        torch = "?"
    return (f"Python {platform.python_version()}, numpy {numpy.__version__}, scipy "
            f"{scipy.__version__}, pandas {pandas.__version__}, torch {torch}")


def main(argv=None) -> int:
    args = parse_args(argv)
    grid = grid_from_args(args)
    from benchmarks.detection.report import headline, load_results, summarize, write_report

    discussion = args.discussion.read_text() if args.discussion and args.discussion.exists() else None
    if args.rerender:
        results = load_results(args.out.with_suffix(""))
        for path in write_report(results, args.out, discussion):
            print(path)
        return 0
    from benchmarks.detection.run import run_grid

    command = shlex.join(["python", "-m", "benchmarks.detection"]
                         + (list(argv) if argv is not None else sys.argv[1:]))
    print(f"[detection] {fault_summary(grid)}; {args.workers} workers", file=sys.stderr, flush=True)
    commit = _commit()   # the code that runs (another commit may land while it runs)
    start = time.perf_counter()
    with LoadMonitor() as load:
        table, info = run_grid(grid, workers=args.workers, threads=args.threads)
    run = {"command": command, "date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
           "commit": commit, "commit_at_end": _commit(), "workers": min(args.workers, len(grid.seeds)), "threads": args.threads,
           "cpus": os.cpu_count(), "load_note": load.note(min(args.workers, len(grid.seeds))),
           "versions": _versions(),
           "timings": info["timings"], "structures": info["structures"]}
    results = summarize(table, grid, run)
    run["wall_seconds"] = time.perf_counter() - start   # all but writing the report (seconds)
    written = write_report(results, args.out, discussion)
    for path in written:
        print(path)
    head = headline(results)
    print(f"[detection] wall time {time.perf_counter() - start:.0f} s; target met in "
          f"{int(head[head.in_scope].met.sum())} of {int(head.in_scope.sum())} in-scope cells; "
          f"{run['load_note']}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
