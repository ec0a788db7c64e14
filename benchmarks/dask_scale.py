"""A nightly run's wall time on Dask with K workers against the sequential runner.

    python -m benchmarks.dask_scale --assets 64 --batch-size 8 --workers 1,2 --repeats 3
    python -m benchmarks.dask_scale --family traction_drive --assets 24 --batch-size 2 \\
        --mlflow-postgres --prefect-postgres --idle --repeats 3

In one work directory: N healthy vehicles of ``--family`` simulated at 1 Hz over
``--baseline-days`` + 1 days (the gas turbine by :func:`benchmarks.nightly_scale.generate`, a
zoo family by :func:`benchmarks.zoo.export.export_fleet`), their baselines fitted once and the
store saved; then, for every runner and every repeat, in turn (sequential, Dask with each K,
sequential, ...) so that a drift of the machine's speed reaches them all alike: the saved
store is put back, the alerts file removed, ``fleet.toml`` given ``[nightly] task_runner``
and ``[dask] workers = K`` (1 thread each), and ``fleet-health run --json --as-of <end of the
night>`` is measured in a child process (the LocalCluster started by the run). With
``--idle`` the same command runs again right after (nothing left to do): the run's fixed
start-up, the workers' start included. Every run must process the same N windows with the
same alerts. Medians over the repeats are printed, with the speed-up of each K over K = 1,
and the cost model fitted from them (:func:`cost_model`); ``--json FILE`` keeps every run.

Stores and Prefect:

* MLflow on SQLite (``mlflow.db`` in the work directory, copied back before each run), or
  with ``--mlflow-postgres`` on a PostgreSQL server started here (``initdb`` + ``pg_ctl`` as
  ``tests/postgres_server.py`` does, data in ``<workdir>/postgres``): the baselines in the
  database ``baselined``, each run on a copy of it (``CREATE DATABASE ... TEMPLATE``),
  through a ``postgresql+psycopg://`` tracking URI.
* Prefect's temporary server started by each run; or with ``--prefect-server`` one
  ``prefect server start`` for the whole benchmark (on SQLite in the work directory), its
  address given to every run, as production runs on a running server; with
  ``--prefect-postgres`` that server on the same PostgreSQL server
  (``PREFECT_API_DATABASE_CONNECTION_URL``, asyncpg).

With a server, the CPU seconds its processes spent during each run are recorded too
(``postgres_cpu``, ``prefect_cpu``): on a machine of two cores the workers share the cores
with them.
"""
from __future__ import annotations

import argparse
import datetime
import json
import math
import pathlib
import re
import shutil
import sqlite3
import statistics
import sys
import tempfile
import time

from benchmarks.measured_process import stop_on_signals
from benchmarks.prefect_server import PrefectServer, tree_cpu
from benchmarks.nightly_scale import (START, child_environment, fleet_health, generate, run_stamp,
                                      say)
from flows.config.settings import NightlySettings

GAS_TURBINE = "gas_turbine"
PG_USER = "postgres"


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.dask_scale",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--assets", type=int, default=64, help="fleet size N (default %(default)s)")
    parser.add_argument("--family", default=GAS_TURBINE,
                        help="the gas turbine (default) or a zoo family (benchmarks/zoo/families)")
    parser.add_argument("--baseline-days", type=int, default=3, help="default %(default)s")
    parser.add_argument("--batch-size", type=int, default=8,
                        help="[nightly] batch_size: batches are what runs at once "
                             "(default %(default)s)")
    parser.add_argument("--workers", default="1,2",
                        help="Dask worker counts K, comma-separated (default %(default)s)")
    parser.add_argument("--no-sequential", action="store_true",
                        help="leave the sequential runner out")
    parser.add_argument("--repeats", type=int, default=3, help="runs per runner (default "
                                                               "%(default)s)")
    parser.add_argument("--idle", action="store_true",
                        help="after each night, the same run again with nothing to do (its "
                             "fixed start-up)")
    parser.add_argument("--mlflow-postgres", action="store_true",
                        help="MLflow on a PostgreSQL server started here")
    parser.add_argument("--prefect-server", action="store_true",
                        help="one Prefect server (on SQLite) for every run, instead of a "
                             "temporary one each")
    parser.add_argument("--prefect-postgres", action="store_true",
                        help="one Prefect server on PostgreSQL for every run")
    parser.add_argument("--sample-interval", type=float, default=1.0,
                        help="the gas turbine's sample interval (the zoo's are their own)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workdir", help="default: a temporary directory, removed after")
    parser.add_argument("--json", dest="json_out", help="write every run here")
    parser.add_argument("--reuse", action="store_true",
                        help="keep the fleet and baselines of an earlier run in --workdir")
    parser.add_argument("--report", metavar="FILE",
                        help="print the tables and the model of a saved --json FILE, run nothing")
    args = parser.parse_args(argv)
    args.workers = [int(k) for k in args.workers.split(",") if k.strip()]
    if not args.workers or min(args.workers) < 1 or args.repeats < 1 or args.assets < 1:
        parser.error("--assets, --workers and --repeats must be positive")
    if args.family != GAS_TURBINE:
        from benchmarks.zoo.families import discover

        if args.family not in discover():
            parser.error(f"--family: {GAS_TURBINE} or one of {sorted(discover())}")
    return args


# -- the fleet.toml ----------------------------------------------------------------------------

def set_runner(config: pathlib.Path, workers: int | None) -> None:
    """``[nightly] task_runner`` and ``[dask]`` of the fleet.toml: sequential for None."""
    text = re.sub(r"\ntask_runner = [^\n]*", "", config.read_text())
    text = re.sub(r"\n\[dask\]\n(?:[a-z_]+ = .*\n)*", "\n", text)
    runner = "sequential" if workers is None else "dask"
    text = text.replace("\n[nightly]\n", f'\n[nightly]\ntask_runner = "{runner}"\n')
    if workers is not None:
        text = text.replace("\n[schedule]", f"\n[dask]\nworkers = {workers}\n"
                                            f"threads_per_worker = 1\n\n[schedule]")
    config.write_text(text)


def set_line(config: pathlib.Path, key: str, value: str) -> None:
    """Replace the (first) ``key = ...`` line of the fleet.toml."""
    text, count = re.subn(rf"\n{key} = [^\n]*", f"\n{key} = {value}", config.read_text(), 1)
    if not count:
        raise RuntimeError(f"{config} has no {key} line")
    config.write_text(text)


# -- servers -----------------------------------------------------------------------------------

class Postgres:
    """A PostgreSQL server with its data in ``<root>/postgres`` (kept for ``--reuse``), run as
    ``tests/postgres_server.py`` runs its throw-away ones (as the ``postgres`` user when this
    is root; trust authentication on 127.0.0.1; fsync off)."""

    def __init__(self, root: pathlib.Path):
        from tests.postgres_server import PostgresServer, find_initdb

        bin_dir = find_initdb()
        if bin_dir is None:
            raise RuntimeError("PostgreSQL's initdb and pg_ctl are not installed")
        self.server = PostgresServer(bin_dir)
        shutil.rmtree(self.server.base, ignore_errors=True)     # its own temporary directory
        self.server.base = root / "postgres"
        self.server.data = self.server.base / "data"
        self.server.socket_dir = self.server.base / "socket"

    def start(self) -> "Postgres":
        self.server.start()    # a --reuse work directory's cluster starts again as it was
        return self

    @property
    def pid(self) -> int:
        return int((self.server.data / "postmaster.pid").read_text().split()[0])

    def uri(self, database: str, driver: str = "psycopg") -> str:
        return f"postgresql+{driver}://{PG_USER}@127.0.0.1:{self.server.port}/{database}"

    def execute(self, statement: str) -> None:
        import psycopg

        with psycopg.connect(self.server.uri(), autocommit=True) as connection:
            connection.execute(statement)

    def exists(self, database: str) -> bool:
        import psycopg

        with psycopg.connect(self.server.uri(), autocommit=True) as connection:
            return connection.execute("SELECT 1 FROM pg_database WHERE datname = %s",
                                      (database,)).fetchone() is not None

    def copy(self, template: str, name: str) -> str:
        """A fresh database ``name`` copied from ``template``; its tracking URI."""
        self.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
        self.server.create_database(name, template=template)
        return self.uri(name)

    def stop(self) -> None:
        server = self.server
        if server.started:
            server._run(str(server.bin_dir / "pg_ctl"), "-D", str(server.data), "-m", "fast",
                        "-w", "stop")
            server.started = False


# -- the runs ----------------------------------------------------------------------------------

class Bench:
    """The work directory, its stores and servers, and how each run is made."""

    def __init__(self, root: pathlib.Path, args: argparse.Namespace):
        self.root, self.args = root, args
        self.postgres: Postgres | None = None
        self.prefect: PrefectServer | None = None
        self.env = child_environment(root)
        self.counter = 0

    def start_servers(self) -> None:
        if self.args.mlflow_postgres or self.args.prefect_postgres:
            say("PostgreSQL ...")
            self.postgres = Postgres(self.root).start()
        if self.args.prefect_postgres:
            if not self.postgres.exists("prefect"):
                self.postgres.execute('CREATE DATABASE "prefect"')
            say("Prefect server on PostgreSQL ...")
            self.prefect = PrefectServer(self.root, self.postgres.uri("prefect", "asyncpg"))
        elif self.args.prefect_server:
            say("Prefect server on SQLite ...")
            self.prefect = PrefectServer(
                self.root, f"sqlite+aiosqlite:///{self.root / 'prefect-server.db'}")
        if self.prefect is not None:
            self.prefect.start()
            self.env = dict(self.env, PREFECT_API_URL=self.prefect.api_url)

    def stop_servers(self) -> None:
        if self.prefect is not None:
            self.prefect.stop()
        if self.postgres is not None:
            self.postgres.stop()

    def server_cpu(self) -> dict:
        cpu = {}
        if self.postgres is not None:
            cpu["postgres_cpu"] = tree_cpu(self.postgres.pid)
        if self.prefect is not None:
            cpu["prefect_cpu"] = tree_cpu(self.prefect.process.pid)
        return cpu

    def measured(self, name: str, *arguments: str) -> dict:
        before = self.server_cpu()
        data = fleet_health(self.root, name, *arguments, env=self.env)
        after = self.server_cpu()
        data.update({key: after[key] - before[key] for key in before})
        return data

    # the store
    def tracking_uri(self, database: str) -> str:
        return f'"{self.postgres.uri(database)}"'

    def saved(self) -> bool:
        if self.args.mlflow_postgres:
            return (self.root / "baselined.done").exists() and self.postgres.exists("baselined")
        return (self.root / "baselined.db").exists()

    def restore(self) -> None:
        """The baselined store, fresh, where the next run reads and writes it."""
        config = self.root / "fleet.toml"
        if self.args.mlflow_postgres:
            self.counter += 1
            self.postgres.copy("baselined", "night")
            set_line(config, "tracking_uri", self.tracking_uri("night"))
            return
        for name in ("mlflow.db", "mlflow.db-wal", "mlflow.db-shm"):
            (self.root / name).unlink(missing_ok=True)
        shutil.copy(self.root / "baselined.db", self.root / "mlflow.db")

    def save(self) -> None:
        if self.args.mlflow_postgres:
            (self.root / "baselined.done").write_text("")
            return
        connection = sqlite3.connect(self.root / "mlflow.db")
        connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        connection.close()
        shutil.copy(self.root / "mlflow.db", self.root / "baselined.db")


def prepare(bench: Bench) -> dict:
    """Simulate the fleet into the work directory, fit its baselines, save the store."""
    args, root = bench.args, bench.root
    days = args.baseline_days + 1
    say(f"simulating {args.assets} {args.family} x {days} days in {root} ...")
    if args.family == GAS_TURBINE:
        generate(root, args.assets, days, args.seed, args.sample_interval, args.batch_size, "4GB",
                 NightlySettings().candidate_nights)
        start = START.isoformat()
        end = (START + datetime.timedelta(days=args.baseline_days)).isoformat()
        as_of = (START + datetime.timedelta(days=days)).isoformat()
    else:
        from benchmarks.zoo.export import export_fleet
        from benchmarks.zoo.families import discover

        written = export_fleet(discover()[args.family], root, assets=args.assets,
                               baseline_days=args.baseline_days, nights=1, seed=args.seed + 1)
        (start, end), as_of = written["baseline"], written["as_of"]
        set_line(root / "fleet.toml", "batch_size", str(args.batch_size))
    config = root / "fleet.toml"
    if args.mlflow_postgres:
        bench.postgres.execute('DROP DATABASE IF EXISTS "baselined" WITH (FORCE)')
        bench.postgres.execute('CREATE DATABASE "baselined"')
        set_line(config, "tracking_uri", bench.tracking_uri("baselined"))
    else:
        set_line(config, "tracking_uri", '"sqlite:///mlflow.db"')
    # the baselines on every worker the machine has: the benchmark times the nights only (one
    # worker is no faster than the sequential runner, and its cluster takes seconds to start)
    set_runner(config, max(args.workers) if max(args.workers) > 1 else None)
    say("baseline fit ...")
    baseline = bench.measured("baseline", "baseline", "fit", "--all", "--start", start,
                              "--end", end, "--promote", "--reason", "dask_scale")
    say(f"baseline fit: {baseline['wall']:.1f} s wall")
    bench.save()
    plan = {"start": start, "end": end, "as_of": as_of, "baseline_wall": baseline["wall"]}
    (root / "plan.json").write_text(json.dumps(plan))
    return plan


def one_night(bench: Bench, workers: int | None, as_of: str, repeat: int) -> list[dict]:
    """The night from the saved store with one runner (and, with ``--idle``, the same run
    again with nothing to do); their measurements and outcomes."""
    root = bench.root
    bench.restore()
    (root / "alerts.jsonl").unlink(missing_ok=True)
    set_runner(root / "fleet.toml", workers)
    label = "sequential" if workers is None else f"dask-{workers}"
    data = bench.measured(f"nightly-{label}-{repeat}", "run", "--as-of", as_of)
    alerts = (root / "alerts.jsonl").read_text() if (root / "alerts.jsonl").exists() else ""
    data["runner"] = label
    data["alert_lines"] = len([line for line in alerts.splitlines() if line.strip()])
    data["batch_wall"] = sum(s["wall"] for s in data["stages"].values())
    runs = [data]
    if bench.args.idle:
        idle = bench.measured(f"idle-{label}-{repeat}", "run", "--as-of", as_of)
        idle["runner"] = label
        idle["idle"] = True
        runs.append(idle)
    return runs


def run(args: argparse.Namespace, argv: list[str]) -> dict:
    root = pathlib.Path(args.workdir or tempfile.mkdtemp(prefix="dask-scale-")).resolve()
    if not args.reuse and root.exists():
        shutil.rmtree(root)
    root.mkdir(parents=True, exist_ok=True)
    bench = Bench(root, args)
    try:
        bench.start_servers()
        if args.reuse and bench.saved() and (root / "plan.json").exists():
            plan = json.loads((root / "plan.json").read_text())
        else:
            plan = prepare(bench)
        runners = ([] if args.no_sequential else [None]) + list(args.workers)
        runs = []
        for repeat in range(args.repeats):
            for workers in runners:
                for data in one_night(bench, workers, plan["as_of"], repeat):
                    runs.append(data)
                    what = "idle" if data.get("idle") else "night"
                    servers = "".join(f", {key} {data[key]:.1f} s" for key in
                                      ("postgres_cpu", "prefect_cpu") if key in data)
                    say(f"repeat {repeat + 1}: {data['runner']} {what}: {data['wall']:.1f} s "
                        f"wall, CPU {data['user'] + data['system']:.1f} s{servers}, "
                        f"{data['windows']} windows, load {median_load(data):.1f}")
    finally:
        bench.stop_servers()
    nights = [r for r in runs if not r.get("idle")]
    outcomes = {(r["windows"], r["alert_lines"], json.dumps(r["counts"], sort_keys=True))
                for r in nights}
    if len(outcomes) != 1:
        raise RuntimeError(f"the runners disagree on the night's outcome: {outcomes}")
    result = {**run_stamp("benchmarks.dask_scale", argv), "family": args.family, "assets": args.assets, "batch_size": args.batch_size,
              "mlflow": "postgresql" if args.mlflow_postgres else "sqlite",
              "prefect": ("server on postgresql" if args.prefect_postgres
                          else "server on sqlite" if args.prefect_server else "temporary"),
              "baseline_wall": plan.get("baseline_wall"), "runs": runs}
    if not args.workdir:
        shutil.rmtree(root, ignore_errors=True)
    return result


# -- the report --------------------------------------------------------------------------------

def median_load(data: dict) -> float:
    load = data.get("load") or [0.0]
    return statistics.median(load) if isinstance(load, list) else float(load)


def by_runner(result: dict, idle: bool = False) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for data in result["runs"]:
        if bool(data.get("idle")) == idle:
            out.setdefault(data["runner"], []).append(data)
    return out


def summarize(result: dict) -> str:
    """Medians per runner and the speed-up over one Dask worker, as a Markdown table."""
    nights, idles = by_runner(result), by_runner(result, idle=True)
    one = statistics.median(r["wall"] for r in nights.get("dask-1", next(iter(nights.values()))))
    lines = ["| runner | runs | wall s (median) | min - max | CPU s (median) | "
             "batch stages s (median) | registry s | idle run s | servers' CPU s | "
             "load (median) | speed-up over 1 worker |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for runner, runs in nights.items():
        walls = [r["wall"] for r in runs]
        cpu = statistics.median(r["user"] + r["system"] for r in runs)
        load = statistics.median(median_load(r) for r in runs)
        stages = statistics.median(r["batch_wall"] for r in runs)
        registry = statistics.median(r["stages"].get("registry", {}).get("wall", 0.0)
                                     for r in runs)
        idle = (f"{statistics.median(r['wall'] for r in idles[runner]):.1f}"
                if runner in idles else "-")
        servers = statistics.median(r.get("postgres_cpu", 0.0) + r.get("prefect_cpu", 0.0)
                                    for r in runs)
        median = statistics.median(walls)
        lines.append(f"| {runner} | {len(runs)} | {median:.1f} | {min(walls):.1f} - "
                     f"{max(walls):.1f} | {cpu:.1f} | {stages:.1f} | {registry:.1f} | {idle} | "
                     f"{servers:.1f} | {load:.1f} | {one / median:.2f} |")
    return "\n".join(lines)


def cost_model(result: dict) -> dict | None:
    """The costs of a night, fitted from the measured runs (needs ``--idle`` and the
    sequential runner), and its prediction of each measured K.

    ``wall(K) = F + w(K) + (N (c + r) + B o) / K``, with N assets in B batches:

    * ``c``, ``r``: compute and registry seconds per asset (the batch stages of the
      sequential runs, summed over the batches, divided by N);
    * ``F``: the fixed start-up (the sequential runner's idle run: nothing to do);
    * ``w(K)``: starting K workers (the Dask runner's idle run minus F);
    * ``o``: per batch, the rest of the sequential night (task runs, the registry opened per
      batch, the flow's bookkeeping): ``(wall_seq - F - N (c + r)) / B``.

    Every term comes from the sequential runner or an idle run, none from a Dask night: the
    measured Dask nights check the prediction.
    """
    nights, idles = by_runner(result), by_runner(result, idle=True)
    if "sequential" not in nights or "sequential" not in idles:
        return None
    n = result["assets"]
    batches = math.ceil(n / result["batch_size"])
    med = statistics.median
    seq = nights["sequential"]
    registry = med(r["stages"].get("registry", {}).get("wall", 0.0) for r in seq)
    compute = med(r["batch_wall"] for r in seq) - registry
    fixed = med(r["wall"] for r in idles["sequential"])
    per_batch = (med(r["wall"] for r in seq) - fixed - compute - registry) / batches
    model = {"assets": n, "batch_size": result["batch_size"], "batches": batches,
             "compute_per_asset": compute / n, "registry_per_asset": registry / n,
             "per_batch": per_batch, "fixed": fixed, "worker_start": {}, "check": {}}
    # the servers' CPU: PostgreSQL per asset, Prefect's server per batch (a night's minus an
    # idle run's)
    for key, per, count in (("postgres_cpu", "postgres_cpu_per_asset", n),
                            ("prefect_cpu", "prefect_cpu_per_batch", batches)):
        if all(key in r for r in seq + idles["sequential"]):
            model[per] = (med(r[key] for r in seq)
                          - med(r[key] for r in idles["sequential"])) / count
    work = compute + registry + batches * per_batch
    for runner, runs in nights.items():
        if not runner.startswith("dask-") or runner not in idles:
            continue
        k = int(runner.split("-")[1])
        start = med(r["wall"] for r in idles[runner]) - fixed
        model["worker_start"][k] = start
        predicted = fixed + start + work / min(k, batches)
        model["check"][k] = {"predicted": predicted, "measured": med(r["wall"] for r in runs)}
    return model


def projection(model: dict, assets: int, machines: int, server_cores: float = 1.0) -> float:
    """Predicted wall seconds of a night of ``assets`` on ``machines`` workers (one per
    machine, started at once: one worker's start), with the model's batch size; a server
    (PostgreSQL, Prefect's) of ``server_cores`` cores bounds the work from below by its CPU."""
    batches = math.ceil(assets / model["batch_size"])
    work = assets * (model["compute_per_asset"] + model["registry_per_asset"]) \
        + batches * model["per_batch"]
    floors = [assets * model.get("postgres_cpu_per_asset", 0.0) / server_cores,
              batches * model.get("prefect_cpu_per_batch", 0.0) / server_cores]
    start = model["worker_start"].get(1, 0.0)
    return model["fixed"] + start + max([work / min(machines, batches)] + floors)


def model_table(model: dict) -> str:
    lines = [f"per asset: compute {model['compute_per_asset']:.3f} s, registry "
             f"{model['registry_per_asset']:.3f} s; per batch {model['per_batch']:.2f} s; "
             f"fixed start-up {model['fixed']:.1f} s; worker start "
             + ", ".join(f"K={k}: {s:.1f} s" for k, s in model["worker_start"].items()),
             "| K | predicted s | measured s | measured / predicted |", "|---|---|---|---|"]
    for k, check in model["check"].items():
        lines.append(f"| {k} | {check['predicted']:.1f} | {check['measured']:.1f} | "
                     f"{check['measured'] / check['predicted']:.2f} |")
    servers = [f"{label} {model[key]:.3f} s" for key, label in
               (("postgres_cpu_per_asset", "PostgreSQL CPU per asset"),
                ("prefect_cpu_per_batch", "Prefect server CPU per batch")) if key in model]
    if servers:
        lines.append("servers: " + ", ".join(servers))
    machines = (1, 2, 4, 8, 16, 32, 64)
    lines += ["10,000 assets on K machines (one worker each), predicted:",
              "| K | " + " | ".join(str(k) for k in machines) + " |",
              "|---|" + "---|" * len(machines),
              "| wall s | " + " | ".join(f"{projection(model, 10_000, k):.0f}"
                                      for k in machines) + " |"]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv)
    if args.report:
        result = json.loads(pathlib.Path(args.report).read_text())
    else:
        began = time.perf_counter()
        result = run(args, argv)
        result["wall_seconds"] = time.perf_counter() - began
    model = cost_model(result)
    if model is not None:
        result["model"] = model
    if args.json_out and not args.report:
        pathlib.Path(args.json_out).write_text(json.dumps(result, indent=1))
    setup = (f"{result['cpus']} CPUs, {result.get('family', GAS_TURBINE)}, "
             f"{result['assets']} assets, batch_size {result['batch_size']}, MLflow on "
             f"{result.get('mlflow', 'sqlite')}, Prefect {result.get('prefect', 'temporary')}")
    print(f"{result['command']}  ({result['date']}, commit {result['commit']}, {setup})")
    print(summarize(result))
    if model is not None:
        print(model_table(model))
    return 0


if __name__ == "__main__":
    stop_on_signals()   # the servers it starts are stopped in run()'s finally
    sys.exit(main())
