"""Speed of a nightly run at scale: N healthy assets at 1 Hz, through the real flows.

    python -m benchmarks.nightly_scale --sizes 10,50,200 --out docs/performance.md
    python -m benchmarks.nightly_scale --quick          # 2 assets at 10 s, a smoke run

For each N, in a fresh work directory:

1. simulate N healthy gas-turbine vehicles (graybox.simulation, in-process, a few vehicles
   at a time) over ``--baseline-days`` + 1 days and write their telemetry and a fleet.toml;
2. ``fleet-health baseline fit --all --promote`` in a child process: wall, CPU, peak RSS
   and the summary's stages, per asset-day;
3. ``fleet-health run --json --as-of <end of the night>`` in a child process (Prefect's
   ephemeral server, MLflow on SQLite): wall, CPU, peak RSS, stages per asset-night; the
   same command again (nothing left to do) measures the fixed start-up;
4. the tables, the extrapolation to 1,000 assets, the targets and the compute floor
   (:mod:`benchmarks.scale_floor`) are printed and, with ``--out``, written as Markdown.

Every child gets its own ``PREFECT_HOME`` in the work directory and 180 s for Prefect's
server to start (the default 20 s is missed on a loaded machine). Raw results go to
``<workdir>/nightly_scale.json``; ``--rerender FILE`` renders a saved one again.

``--keep`` also keeps, in ``<workdir>/n<N>/after-baseline/``, the store as the baseline left
it; ``--reuse`` then starts each N from there (the telemetry and baselines of that earlier
run, its baseline figures reported) and measures only the nights: a 1,000-asset baseline
takes half an hour, and the night is best measured on a quiet machine. ``--prefect-server``
runs the nights on one Prefect server started for them (production's way, the ``serve``
deployment's server), so that their start-up does not include a temporary server's; the
server's CPU during each is recorded as ``prefect_cpu``.
"""
from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

from benchmarks.measured_process import run_measured
from benchmarks.prefect_server import PrefectServer, tree_cpu
from benchmarks.scale_floor import (Structure, candidate_structure, flops_per_asset_night,
                                    matmul_rate)
from benchmarks.scale_report import render_markdown, render_text
from flows.config.settings import NightlySettings

REPO = pathlib.Path(__file__).resolve().parents[1]
START = datetime.date(2026, 1, 1)
SIMULATION_CHUNK = 8        # vehicles simulated at once (bounds the parent's memory)
STARTUP_TIMEOUT = "180"
AFTER_BASELINE = "after-baseline"   # the store as the baseline left it (--keep, --reuse)


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.nightly_scale",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10,50,200",
                        help="fleet sizes N, comma-separated (default %(default)s)")
    parser.add_argument("--baseline-days", type=int, default=3,
                        help="healthy days per baseline, at least 3 (default %(default)s)")
    parser.add_argument("--sample-interval", type=float, default=1.0,
                        help="telemetry seconds per sample (default %(default)s: 1 Hz)")
    parser.add_argument("--batch-size", type=int, default=64,
                        help="[nightly] batch_size (default %(default)s)")
    parser.add_argument("--memory-budget", default="4GB",
                        help="[nightly] memory_budget (default %(default)s)")
    parser.add_argument("--candidate-nights", type=int,
                        default=NightlySettings().candidate_nights,
                        help="[nightly] candidate_nights (default: the product's, %(default)s); "
                             "the measured night is the first whose candidate spans them all")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workdir", help="where the fleets go (default: a temporary "
                                          "directory, removed afterwards)")
    parser.add_argument("--keep", action="store_true",
                        help="keep each N's work directory and its store right after the "
                             "baseline (for --reuse)")
    parser.add_argument("--reuse", action="store_true",
                        help="start each N from the baseline a --keep run left in the same "
                             "--workdir (its figures reported again); measure the nights only")
    parser.add_argument("--out", help="write the Markdown report here (docs/performance.md)")
    parser.add_argument("--prefect-server", action="store_true",
                        help="run the nights on one Prefect server (on SQLite) started here, "
                             "as production runs them (the serve deployment's server), instead "
                             "of a temporary server each; its CPU is recorded beside theirs")
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: N = 2, 3 baseline days at 10-s samples")
    parser.add_argument("--rerender", metavar="JSON[,JSON...]",
                        help="render saved nightly_scale.json files (no runs); the sizes of "
                             "several files are shown together")
    args = parser.parse_args(argv)
    if args.quick:
        args.sizes, args.baseline_days, args.sample_interval = "2", 3, 10.0
    args.sizes = [int(n) for n in str(args.sizes).split(",") if n.strip()]
    if args.baseline_days < 3:
        parser.error("--baseline-days must be at least 3 (epsilon is calibrated from them)")
    if args.candidate_nights < 1:
        parser.error("--candidate-nights must be at least 1")
    if not args.sizes or min(args.sizes) < 1:
        parser.error("--sizes: positive integers, e.g. 10,50,200")
    return args


# -- one fleet -----------------------------------------------------------------------------

def generate(root: pathlib.Path, n: int, days: int, seed: int, sample_interval: float,
             batch_size: int, memory_budget: str, candidate_nights: int) -> float:
    """Simulate ``n`` healthy vehicles over ``days`` days into ``root``; returns seconds."""
    from flows.config import render_config
    from flows.demo import simulated_fleet
    from graybox.simulation import simulate_fleet
    from graybox.telemetry import write_telemetry

    began = time.perf_counter()
    spec = simulated_fleet(n, days, seed, start=START.isoformat(),
                           sample_interval=sample_interval, healthy=True)
    for first in range(0, n, SIMULATION_CHUNK):
        chunk = dataclasses.replace(spec, vehicles=spec.vehicles[first:first + SIMULATION_CHUNK])
        for asset_id, frame in simulate_fleet(chunk).items():
            write_telemetry(root / "telemetry", asset_id, frame)
    config = render_config(telemetry_root="telemetry", batch_size=batch_size,
                           candidate_nights=candidate_nights)
    config = config.replace("\n[schedule]", f'memory_budget = "{memory_budget}"\n\n[schedule]')
    (root / "fleet.toml").write_text(config)
    return time.perf_counter() - began


def keep_baseline(workdir: pathlib.Path, generated: float, baseline: dict) -> None:
    """Copy the store (everything but the telemetry) and the baseline's figures into
    ``workdir/after-baseline``."""
    kept = workdir / AFTER_BASELINE
    shutil.copytree(workdir, kept, ignore=lambda d, names: [
        name for name in names if d == str(workdir) and name in ("telemetry", AFTER_BASELINE)])
    (kept / "baseline.json").write_text(json.dumps({"generate_seconds": generated,
                                                    "baseline": baseline}))


def restore_baseline(workdir: pathlib.Path) -> tuple[float, dict]:
    """Put back the store :func:`keep_baseline` kept; returns its generation seconds and
    baseline figures."""
    kept = workdir / AFTER_BASELINE
    saved = kept / "baseline.json"
    if not saved.exists():
        raise SystemExit(f"--reuse: {saved} does not exist; run with --keep and the same "
                         "--workdir and --sizes first")
    for path in workdir.iterdir():
        if path.name not in ("telemetry", AFTER_BASELINE):
            shutil.rmtree(path) if path.is_dir() else path.unlink()
    shutil.copytree(kept, workdir, dirs_exist_ok=True,
                    ignore=lambda d, names: ["baseline.json"] if d == str(kept) else [])
    figures = json.loads(saved.read_text())
    return figures["generate_seconds"], figures["baseline"]


def child_environment(workdir: pathlib.Path, prefect_api_url: str | None = None) -> dict:
    """The environment of every child: its own Prefect home, time for the server to start,
    this checkout first on the import path; the Prefect server at ``prefect_api_url`` if
    given, else none (each command starts its temporary one)."""
    env = dict(os.environ)
    env.pop("PREFECT_API_URL", None)
    if prefect_api_url:
        env["PREFECT_API_URL"] = prefect_api_url
    env.pop("FLEET_HEALTH_CONFIG", None)
    env.pop("FLEET_HEALTH_TRACKING_URI", None)
    env["PREFECT_HOME"] = str(workdir / ".prefect")
    env["PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS"] = STARTUP_TIMEOUT
    env["PYTHONPATH"] = os.pathsep.join([str(REPO)] + [p for p in env.get(
        "PYTHONPATH", "").split(os.pathsep) if p])
    return env


def fleet_health(workdir: pathlib.Path, name: str, *arguments: str,
                 env: dict | None = None) -> dict:
    """Run ``fleet-health ARGUMENTS --json`` measured; returns the measurement and summary
    (``env``: the child's environment, :func:`child_environment` by default)."""
    command = [sys.executable, "-m", "flows.cli", "--config", "fleet.toml", *arguments,
               "--json"]
    measured = run_measured(command, workdir, env or child_environment(workdir),
                            workdir / "logs", name)
    try:
        summary = json.loads(measured.stdout)
    except json.JSONDecodeError:
        raise RuntimeError(f"`{' '.join(command[2:])}` exited {measured.returncode} without "
                           f"a summary:\n{measured.stderr_tail}") from None
    if measured.returncode != 0:
        failed = [a for a in summary.get("assets", []) if a.get("status") == "failed"]
        raise RuntimeError(f"`{' '.join(command[2:])}` exited {measured.returncode}; "
                           f"{len(failed)} asset(s) failed, e.g. {failed[:1]}")
    data = measured.to_dict()
    del data["stdout"]
    data["stages"] = summary.get("extra", {}).get("stages", {})
    data["counts"] = summary.get("counts", {})
    data["windows"] = sum(len(a.get("windows", [])) for a in summary.get("assets", []))
    return data


def run_size(workdir: pathlib.Path, n: int, args: argparse.Namespace) -> dict:
    """Generate, baseline and run one night for ``n`` assets in ``workdir``. With
    ``--candidate-nights K`` > 1 the K - 1 nights after the baseline run first (not measured),
    so that the measured night's candidates span K nights."""
    warmup = args.candidate_nights - 1
    days = args.baseline_days + warmup + 1
    base_end = START + datetime.timedelta(days=args.baseline_days)
    as_of = START + datetime.timedelta(days=days)
    kept = workdir / AFTER_BASELINE
    if args.reuse:
        say(f"N = {n}: the store as the baseline left it, from {kept} ...")
        generated, baseline = restore_baseline(workdir)
    else:
        say(f"N = {n}: simulating {n} x {days} days at {args.sample_interval:g} s ...")
        generated = generate(workdir, n, days, args.seed, args.sample_interval,
                             args.batch_size, args.memory_budget, args.candidate_nights)
        say(f"N = {n}: baseline fit ({n} x {args.baseline_days} asset-days) ...")
        baseline = fleet_health(workdir, "baseline", "baseline", "fit", "--all",
                                "--start", START.isoformat(), "--end", base_end.isoformat(),
                                "--promote", "--reason", "nightly_scale benchmark")
        if args.keep:
            keep_baseline(workdir, generated, baseline)
    # the nights only: the baseline fit is measured as a user's first command runs it
    server = None
    if args.prefect_server:
        say(f"N = {n}: a Prefect server for the nights ...")
        server = PrefectServer(workdir, f"sqlite+aiosqlite:///{workdir / 'prefect-server.db'}")
    try:
        nightly, startup = _nights(workdir, n, warmup, base_end, as_of, baseline, server)
    finally:
        if server is not None:
            server.stop()
    structure = (candidate_structure(workdir / "mlflow.db", as_of.isoformat())
                 or Structure.assumed())
    return {"n": n, "baseline_days": args.baseline_days,
            "candidate_nights": args.candidate_nights,
            "sample_interval": args.sample_interval, "generate_seconds": generated,
            "baseline": baseline, "nightly": nightly, "startup": startup,
            "structure": dataclasses.asdict(structure),
            "flops": flops_per_asset_night(structure, args.sample_interval)}


def _nights(workdir: pathlib.Path, n: int, warmup: int, base_end, as_of, baseline: dict,
            server: PrefectServer | None) -> tuple[dict, dict]:
    """The nights before the measured one, the measured night and the run with nothing to
    do, on ``server`` when given (its CPU during each measured run as ``prefect_cpu``)."""
    env = child_environment(workdir, server.start().api_url if server else None)

    def measured(name: str) -> dict:
        before = tree_cpu(server.process.pid) if server else 0.0
        data = fleet_health(workdir, name, "run", "--as-of", as_of.isoformat(), env=env)
        if server:
            data["prefect_cpu"] = tree_cpu(server.process.pid) - before
        return data

    if warmup:
        say(f"N = {n}: baseline {baseline['wall']:.1f} s wall; {warmup} night(s) before the "
            "measured one ...")
        fleet_health(workdir, "warmup", "run", "--as-of",
                     (base_end + datetime.timedelta(days=warmup)).isoformat(), env=env)
    say(f"N = {n}: baseline {baseline['wall']:.1f} s wall; nightly run ...")
    nightly = measured("nightly")
    say(f"N = {n}: nightly {nightly['wall']:.1f} s wall; again, nothing to do ...")
    return nightly, measured("startup")


# -- the whole benchmark ---------------------------------------------------------------------

def commit() -> str:
    try:
        described = subprocess.run(["git", "-C", str(REPO), "describe", "--always", "--dirty"],
                                   capture_output=True, text=True, timeout=10)
        return described.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def run_stamp(module: str, argv: list[str]) -> dict:
    """What a benchmark's JSON records of its run: the command, the commit, the date (UTC)
    and the machine's CPUs."""
    return {"command": f"python -m {module} " + " ".join(argv), "commit": commit(),
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "cpus": os.cpu_count()}


def say(text: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {text}", file=sys.stderr, flush=True)


def run(args: argparse.Namespace, argv: list[str]) -> dict:
    """Every size in turn; returns the raw results (also saved as JSON in the work dir)."""
    began = time.perf_counter()
    root = pathlib.Path(args.workdir or tempfile.mkdtemp(prefix="nightly-scale-")).resolve()
    root.mkdir(parents=True, exist_ok=True)
    say(f"work directory {root}; measuring numpy's matmul rate ...")
    results = {**run_stamp("benchmarks.nightly_scale", argv), "quick": args.quick, "batch_size": args.batch_size,
               "memory_budget": args.memory_budget, "matmul": matmul_rate().to_dict(),
               "sizes": []}
    for n in args.sizes:
        workdir = root / f"n{n}"
        if workdir.exists() and not args.reuse:
            shutil.rmtree(workdir)
        workdir.mkdir(exist_ok=True)
        results["sizes"].append(run_size(workdir, n, args))
        if not (args.keep or args.reuse):    # a reused baseline is never thrown away
            shutil.rmtree(workdir)
        (root / "nightly_scale.json").write_text(json.dumps(results, indent=1))
    results["matmul_after"] = matmul_rate().to_dict()
    results["wall_seconds"] = time.perf_counter() - began
    (root / "nightly_scale.json").write_text(json.dumps(results, indent=1))
    say(f"raw results: {root / 'nightly_scale.json'}")
    if not args.workdir and not args.keep:
        shutil.rmtree(root)
    return results


def merge(runs: list[dict]) -> dict:
    """Several saved runs as one: their sizes in order of N, their commands joined (the
    first run's machine figures are kept, and each size keeps its own load samples)."""
    merged = dict(runs[0])
    merged["sizes"] = sorted((s for r in runs for s in r["sizes"]), key=lambda s: s["n"])
    merged["command"] = "; ".join(r["command"] for r in runs)
    merged["wall_seconds"] = sum(r.get("wall_seconds", 0.0) for r in runs)
    return merged


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv)
    if args.rerender:
        results = merge([json.loads(pathlib.Path(p).read_text())
                         for p in args.rerender.split(",")])
    else:
        results = run(args, argv)
    print(render_text(results))
    if args.out:
        pathlib.Path(args.out).write_text(render_markdown(results))
        say(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
