"""A nightly run's wall time on Dask with K workers against the sequential runner.

    python -m benchmarks.dask_scale --assets 64 --batch-size 8 --workers 1,2 --repeats 3

In one work directory: N healthy gas-turbine vehicles simulated at 1 Hz over 3 + 1 days
(:func:`benchmarks.nightly_scale.generate`), their baselines fitted once (sequential) and
the store saved; then, for every runner and every repeat, in turn (sequential, Dask with
each K, sequential, ...) so that a drift of the machine's speed reaches them all alike:
the saved store is put back, the alerts file removed, ``fleet.toml`` given ``[nightly]
task_runner`` and ``[dask] workers = K`` (1 thread each), and ``fleet-health run --json
--as-of <end of the night>`` is measured in a child process (Prefect's ephemeral server,
MLflow on SQLite, the LocalCluster started by the run). Every run must process the same
N windows with the same alerts. Medians over the repeats are printed, with the speed-up of
each K over K = 1; ``--json FILE`` keeps every run.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import pathlib
import re
import shutil
import sqlite3
import statistics
import sys
import tempfile
import time

from benchmarks.nightly_scale import START, commit, fleet_health, generate, say

BASELINE_DAYS = 3


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.dask_scale",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--assets", type=int, default=64, help="fleet size N (default %(default)s)")
    parser.add_argument("--batch-size", type=int, default=8,
                        help="[nightly] batch_size: batches are what runs at once "
                             "(default %(default)s)")
    parser.add_argument("--workers", default="1,2",
                        help="Dask worker counts K, comma-separated (default %(default)s)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per runner (default "
                                                               "%(default)s)")
    parser.add_argument("--sample-interval", type=float, default=1.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workdir", help="default: a temporary directory, removed after")
    parser.add_argument("--json", dest="json_out", help="write every run here")
    parser.add_argument("--reuse", action="store_true",
                        help="keep the fleet and baselines of an earlier run in --workdir")
    args = parser.parse_args(argv)
    args.workers = [int(k) for k in args.workers.split(",") if k.strip()]
    if not args.workers or min(args.workers) < 1 or args.repeats < 1 or args.assets < 1:
        parser.error("--assets, --workers and --repeats must be positive")
    return args


def set_runner(config: pathlib.Path, workers: int | None) -> None:
    """``[nightly] task_runner`` and ``[dask]`` of the fleet.toml: sequential for None."""
    text = re.sub(r'\ntask_runner = "[a-z]+"\n', "\n", config.read_text())
    text = re.sub(r"\n\[dask\]\n(?:[a-z_]+ = .*\n)*", "\n", text)
    runner = "sequential" if workers is None else "dask"
    text = text.replace("\n[nightly]\n", f'\n[nightly]\ntask_runner = "{runner}"\n')
    if workers is not None:
        text = text.replace("\n[schedule]", f"\n[dask]\nworkers = {workers}\n"
                                            f"threads_per_worker = 1\n\n[schedule]")
    config.write_text(text)


def checkpoint(db: pathlib.Path) -> None:
    connection = sqlite3.connect(db)
    connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    connection.close()


def one_night(workdir: pathlib.Path, saved: pathlib.Path, workers: int | None,
              as_of: str) -> dict:
    """The night from the saved store with one runner; its measurement and outcome."""
    for name in ("mlflow.db", "mlflow.db-wal", "mlflow.db-shm", "alerts.jsonl"):
        (workdir / name).unlink(missing_ok=True)
    shutil.copy(saved, workdir / "mlflow.db")
    set_runner(workdir / "fleet.toml", workers)
    label = "sequential" if workers is None else f"dask-{workers}"
    data = fleet_health(workdir, f"nightly-{label}", "run", "--as-of", as_of)
    alerts = (workdir / "alerts.jsonl").read_text() if (workdir / "alerts.jsonl").exists() \
        else ""
    data["runner"] = label
    data["alert_lines"] = len([line for line in alerts.splitlines() if line.strip()])
    data["batch_wall"] = sum(s["wall"] for s in data["stages"].values())
    return data


def prepare(root: pathlib.Path, args: argparse.Namespace) -> None:
    """Simulate the fleet into ``root``, fit its baselines, save the store as baselined.db."""
    if root.exists():
        shutil.rmtree(root)
    root.mkdir(parents=True)
    days = BASELINE_DAYS + 1
    base_end = START + datetime.timedelta(days=BASELINE_DAYS)
    say(f"simulating {args.assets} x {days} days at {args.sample_interval:g} s in {root} ...")
    generate(root, args.assets, days, args.seed, args.sample_interval, args.batch_size, "4GB")
    say("baseline fit (sequential) ...")
    set_runner(root / "fleet.toml", None)
    fleet_health(root, "baseline", "baseline", "fit", "--all", "--start", START.isoformat(),
                 "--end", base_end.isoformat(), "--promote", "--reason", "dask_scale")
    checkpoint(root / "mlflow.db")
    shutil.copy(root / "mlflow.db", root / "baselined.db")


def run(args: argparse.Namespace, argv: list[str]) -> dict:
    root = pathlib.Path(args.workdir or tempfile.mkdtemp(prefix="dask-scale-")).resolve()
    days = BASELINE_DAYS + 1
    as_of = (START + datetime.timedelta(days=days)).isoformat()
    saved = root / "baselined.db"
    if not (args.reuse and saved.exists()):
        prepare(root, args)
    runners = [None] + list(args.workers)
    runs = []
    for repeat in range(args.repeats):
        for workers in runners:
            data = one_night(root, saved, workers, as_of)
            say(f"repeat {repeat + 1}: {data['runner']}: {data['wall']:.1f} s wall, "
                f"{data['windows']} windows, {data['alert_lines']} alert lines")
            runs.append(data)
    outcomes = {(r["windows"], r["alert_lines"], json.dumps(r["counts"], sort_keys=True))
                for r in runs}
    if len(outcomes) != 1:
        raise RuntimeError(f"the runners disagree on the night's outcome: {outcomes}")
    result = {"command": "python -m benchmarks.dask_scale " + " ".join(argv),
              "commit": commit(), "cpus": os.cpu_count(),
              "date": datetime.datetime.now(datetime.timezone.utc).strftime(
                  "%Y-%m-%d %H:%M UTC"),
              "assets": args.assets, "batch_size": args.batch_size, "runs": runs}
    if not args.workdir:
        shutil.rmtree(root)
    return result


def summarize(result: dict) -> str:
    """Medians per runner and the speed-up over one Dask worker, as a Markdown table."""
    by_runner: dict[str, list[dict]] = {}
    for data in result["runs"]:
        by_runner.setdefault(data["runner"], []).append(data)
    one = statistics.median(r["wall"] for r in by_runner.get("dask-1", by_runner["sequential"]))
    lines = ["| runner | runs | wall s (median) | min - max | CPU s (median) | "
             "batch stages s (median) | load (median) | speed-up over 1 worker |",
             "|---|---|---|---|---|---|---|---|"]
    for runner, runs in by_runner.items():
        walls = [r["wall"] for r in runs]
        cpu = statistics.median(r["user"] + r["system"] for r in runs)
        load = statistics.median(x for r in runs for x in r.get("load", [0.0]) or [0.0])
        stages = statistics.median(r["batch_wall"] for r in runs)
        median = statistics.median(walls)
        lines.append(f"| {runner} | {len(runs)} | {median:.1f} | {min(walls):.1f} - "
                     f"{max(walls):.1f} | {cpu:.1f} | {stages:.1f} | {load:.1f} | "
                     f"{one / median:.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv)
    began = time.perf_counter()
    result = run(args, argv)
    result["wall_seconds"] = time.perf_counter() - began
    if args.json_out:
        pathlib.Path(args.json_out).write_text(json.dumps(result, indent=1))
    print(f"{result['command']}  ({result['date']}, commit {result['commit']}, "
          f"{result['cpus']} CPUs, {result['assets']} assets, batch_size "
          f"{result['batch_size']})")
    print(summarize(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
