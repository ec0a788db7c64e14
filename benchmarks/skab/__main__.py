"""``python -m benchmarks.skab``: the gray box on SKAB through the product's flows, scored
against PCA T2+Q, Isolation forest and the project's classic detectors on the same windows.

Examples
--------
The whole dataset (about 30 experiments)::

    python -m benchmarks.skab --data ../shared/datasets/skab --out /tmp/skab.md

Two experiments (CI's smoke run)::

    python -m benchmarks.skab --experiments other/5,valve1/4
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import tempfile
import time
from dataclasses import asdict

import pandas as pd

from benchmarks.skab.classic import CLASSIC, classic_alarms
from benchmarks.skab.data import dataset_dir
from benchmarks.skab.detectors import DETECTORS, WindowDetector
from benchmarks.skab.protocol import (RECENT_WINDOWS, baseline_plan, experiments,
                                      healthy_file_rows,
                                      point_labels, window_labels)
from benchmarks.skab.run import MIN_DURATION, WINDOW, Conditioned, prepare, run_gray_box
from benchmarks.skab.scoring import (HEADER, PointCounts, point_counts, score_experiment,
                                     summarise)

REPO = pathlib.Path(__file__).resolve().parents[2]
#: every detector run beside the gray box on the same windows
COMPARED = (*DETECTORS, *CLASSIC)


def _recent(text: str) -> int | None:
    return None if text == "all" else int(text)


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.skab", description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=pathlib.Path, default=dataset_dir(REPO),
                        help="the SKAB folder (default: ../shared/datasets/skab beside the "
                             "checkout)")
    parser.add_argument("--experiments", default="",
                        help="comma-separated experiments such as other/5,valve1/4 (default: "
                             "all)")
    parser.add_argument("--window", default=WINDOW, help=f"[nightly] window (default {WINDOW})")
    parser.add_argument("--recent-windows", type=_recent, default=RECENT_WINDOWS,
                        help="each baseline takes its session's latest N whole healthy "
                             "windows before the experiment; \"all\": every one of them "
                             f"(default {RECENT_WINDOWS})")
    parser.add_argument("--later", action="store_true",
                        help="an experiment with too few earlier healthy windows is baselined "
                             "on its session's earliest healthy windows after it (not causal; "
                             "listed in the report)")
    parser.add_argument("--candidate-nights", type=int, default=1,
                        help="[nightly] candidate_nights (default 1)")
    parser.add_argument("--workdir", type=pathlib.Path,
                        help="where the telemetry, stores and exports go (default: a "
                             "temporary folder, removed)")
    parser.add_argument("--out", type=pathlib.Path, help="write the Markdown report here")
    parser.add_argument("--json", type=pathlib.Path, help="write every window's result here")
    return parser.parse_args(argv)


def run(args: argparse.Namespace, workdir: pathlib.Path) -> dict:
    """The whole benchmark in ``workdir``; returns the results (see :func:`report`)."""
    began = time.perf_counter()
    window, cover = pd.Timedelta(args.window), pd.Timedelta(MIN_DURATION)
    every = experiments(args.data)
    chosen = [e for e in every if not args.experiments
              or e.name in args.experiments.split(",")]
    healthy = healthy_file_rows(args.data)
    plans, unplanned, later = {}, {}, {}
    for experiment in chosen:
        plan = baseline_plan(experiment, every, healthy, window, cover, args.recent_windows,
                             args.later)
        if plan.usable:
            plans[experiment.asset] = (experiment, plan)
            if plan.later:
                later[experiment.name] = ", ".join(plan.sources)
        else:
            unplanned[experiment.name] = plan.reason
    data = {asset: Conditioned.of(*planned) for asset, planned in plans.items()}
    prepare(workdir, data, args.window, args.candidate_nights)
    gray = run_gray_box(workdir, plans, args.window,
                        progress=lambda line: print(line, file=sys.stderr, flush=True))
    scores = {name: [] for name in ("gray_box", *COMPARED)}
    points = {name: PointCounts() for name in scores}
    windows = []
    for asset in sorted(plans, key=lambda a: plans[a][0].name):
        experiment, _ = plans[asset]
        labels = window_labels(experiment, window)
        analysed = {w.start: w for w in gray[asset] if w.alarm is not None}
        alarms = {"gray_box": pd.Series({s: w.alarm for s, w in analysed.items()}, dtype=object)}
        rows, training = data[asset].rows, data[asset].training()
        found = {name: WindowDetector.fit(name, training, window).windows(rows, window)["alarm"]
                 for name in DETECTORS}
        found.update(classic_alarms(training, rows, window))
        for name, series in found.items():
            alarms[name] = series[series.index.isin(list(analysed))].astype(object)
        for name, series in alarms.items():
            scores[name].append(score_experiment(experiment.name, labels, series,
                                                 experiment.onset))
            points[name] += point_counts(experiment.rows["timestamp"], point_labels(experiment),
                                         series, window)
        for start, label in labels.items():
            entry = analysed.get(start)
            windows.append({"experiment": experiment.name, "session": experiment.session,
                            "window_start": start.isoformat(), "label": label,
                            "gray_box": None if entry is None else entry.alarm,
                            "ratio": None if entry is None else entry.ratio,
                            "tiers": [] if entry is None else list(entry.alarms),
                            "cause": "" if entry is None else entry.cause,
                            **{n: (None if start not in alarms[n].index else
                                   bool(alarms[n][start])) for n in COMPARED}})
        failed = [w.status for w in gray[asset] if w.alarm is None]
        if failed:
            print(f"{experiment.name}: not analysed: {failed[0]}", file=sys.stderr)
    summaries = [summarise(name, scores[name], points[name]) for name in scores]
    return {"window": args.window, "candidate_nights": args.candidate_nights,
            "recent_windows": args.recent_windows,
            "seconds": time.perf_counter() - began, "summaries": [asdict(s) for s in summaries],
            "summary_rows": [s.row() for s in summaries],
            "experiments": {name: [asdict(s) for s in scores[name]] for name in scores},
            "not_baselined": unplanned, "baselined_on_later_windows": later,
            "windows": windows}


def report(results: dict) -> str:
    """The Markdown tables of a run."""
    lines = [f"SKAB, `[nightly] window = \"{results['window']}\"`, candidate_nights = "
             f"{results['candidate_nights']}, baselines on "
             + (f"the latest {results['recent_windows']}" if results.get("recent_windows")
                else "all the") + " earlier whole healthy windows; "
             f"{results['seconds']:.0f} s.", "",
             "| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    lines += ["| " + " | ".join(row) + " |" for row in results["summary_rows"]]
    if results.get("baselined_on_later_windows"):
        lines += ["", "Baselined on later healthy windows (not causal):", ""]
        lines += [f"- {name}: {sources}"
                  for name, sources in results["baselined_on_later_windows"].items()]
    if results["not_baselined"]:
        lines += ["", "Not baselined (not scored):", ""]
        lines += [f"- {name}: {why}" for name, why in results["not_baselined"].items()]
    lines += ["", "| experiment | window | label | gray box (tiers) | ratio | likely cause | "
              + " | ".join(COMPARED) + " |", "|---|---|---|---|---|---|" + "---|" * len(COMPARED)]
    mark = {True: "alarm", False: "-", None: "n/a"}
    for w in results["windows"]:
        tiers = ", ".join(sorted(set(w["tiers"])))
        ratio = "" if w["ratio"] is None else f"{w['ratio']:.3g}"
        lines.append(f"| {w['experiment']} | {w['window_start'][11:16]} | {w['label']} | "
                     f"{mark[w['gray_box']]}{' (' + tiers + ')' if tiers else ''} | {ratio} | "
                     f"{w['cause']} | "
                     + " | ".join(mark[w[n]] for n in COMPARED) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    args = parse_args(argv)
    if not (args.data / "data").is_dir():
        print(f"no SKAB data at {args.data} (expected {args.data}/data/...)", file=sys.stderr)
        return 2
    if args.workdir is None:
        with tempfile.TemporaryDirectory(prefix="skab-") as folder:
            results = run(args, pathlib.Path(folder))
    else:
        results = run(args, args.workdir)
    text = report(results)
    print(text)
    if args.out:
        args.out.write_text(text)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
