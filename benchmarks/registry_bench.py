"""Registry timings with 1,000 and 10,000 runs in the store.

Run from the repository root::

    python -m benchmarks.registry_bench                 # 1,000 and 10,000 runs
    python -m benchmarks.registry_bench --runs 1000     # quicker

The store (embedded SQLite, WAL) is filled with nightly-candidate-like records spread over
``--assets`` assets (a run with the registry's tags, params and zeta/epsilon metrics, and a
model version tagged with its idempotence key), then real fits are recorded and looked up:

* ``record``: :meth:`Registry.record_fit` of a new nightly candidate (run, artifacts, pyfunc
  model, version, alias), without and with the PNG plots;
* ``re-record``: the same fit again (idempotent: one key look-up, nothing written);
* ``watermark``: :meth:`Registry.watermark` (one read of the registered model's tags,
  without its versions: :mod:`registry.store.model_headers`);
* ``baseline``: :meth:`Registry.baseline` (alias look-up, download, verification);
* ``zeta history``: :meth:`Registry.zeta_history` of one asset.

Times are medians in milliseconds. Filling 10,000 runs takes a few minutes (three SQLite
transactions per filler record).

The nightly path, per asset-night (``--nightly``)::

    python -m benchmarks.registry_bench --nightly --assets 30 --nights 3
    python -m benchmarks.registry_bench --nightly --assets 30 --nights 3 --batch 10
    python -m benchmarks.registry_bench --nightly --assets 10 --nights 3 --history 365 --warmup 1

gives ``--assets`` assets a promoted baseline, then times, for every asset and night, the
calls a nightly batch makes (:func:`flows.nightly.plan_batch`, then
:func:`flows.pipeline.execute`): ``watermark``, ``baseline`` (load and
verify), ``record`` (the candidate with its drift, no plots), ``commit_watermark``; it prints
mean, median and 90th percentile in ms per asset-night, and their total, with the mean and
median CPU time of the calling thread (the median leaves out a rare long pause, e.g. a
garbage collection, that falls into one call). ``--batch N``
records each group of N assets with one ``record_fits``; ``--history N`` first gives every
asset N filler runs and versions (what a year of nights leaves is ``--history 365``);
``--group N`` commits each group of N assets as the nightly flow commits a memory group (one
``record_group``, then one ``commit_watermarks``: ``--group 10`` with ``--assets 10`` is a
night of one memory group); ``--warmup N`` first records N nights untimed: a process's first night also pays one-time
costs (imports, SQLAlchemy's compiled statements, SQLite's page cache) that filling a history
has already paid, so compare histories with a warm-up.
"""
from __future__ import annotations

import argparse
import logging
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import pandas as pd

FILL_BATCH = 500


def _median_ms(function, repeat: int) -> float:
    times = []
    for i in range(repeat):
        start = time.perf_counter()
        function(i)
        times.append(time.perf_counter() - start)
    return 1000 * statistics.median(times)


class Filler:
    """Writes nightly-candidate-like records fast (no artifacts, no plots)."""

    def __init__(self, registry, signature, drift, assets: int, prefix: str = "B"):
        from mlflow.entities import Metric, Param

        from registry.store import naming
        from registry.write.run_content import code_version, fit_metrics, structure_params

        self.registry, self.assets, self.naming, self.prefix = registry, assets, naming, prefix
        self.client = registry.backend.client
        self.experiment_id = registry.backend.experiment_id("turbine", create=True)
        self.params = [Param(k, v) for k, v in structure_params(signature).items()][:100]
        now = int(time.time() * 1000)
        self.metrics = [Metric(k, v, now, 0) for k, v in fit_metrics(signature, None, drift).items()]
        self.code = code_version()
        # every filler version points at the artifacts of one real recorded fit
        seed = registry.record_fit("FILL-SEED", "turbine", signature, role="candidate",
                                   drift=drift, window_start="2000-01-01",
                                   window_end="2000-01-02", data_hash="seed", plots=False)
        self.source = self.client.get_model_version(naming.model_name("FILL-SEED"),
                                                    str(seed.version)).source
        self.model_id = seed.model_id or None
        self.count = 1
        for a in range(assets):
            self.registry.backend.ensure_registered_model(self._asset(a), "turbine",
                                                          self.experiment_id)

    def _asset(self, a: int) -> str:
        return f"{self.prefix}-{a:04d}"

    def fill_to(self, total: int) -> None:
        naming = self.naming
        while self.count < total:
            k = self.count
            asset = self._asset(k % self.assets)
            start = pd.Timestamp("2020-01-01", tz="UTC") + pd.Timedelta(days=k // self.assets)
            end = start + pd.Timedelta(days=1)
            key = naming.fit_key(asset, start, end, "candidate", f"fill-{k}")
            tags = {naming.TAG_ASSET_ID: asset, naming.TAG_VEHICLE_CLASS: "turbine",
                    naming.TAG_WINDOW_START: start.isoformat(),
                    naming.TAG_WINDOW_END: end.isoformat(), naming.TAG_ROLE: "candidate",
                    naming.TAG_DATA_HASH: f"fill-{k}", naming.TAG_CODE_VERSION: self.code,
                    naming.TAG_FIT_KEY: key, naming.TAG_COMPLETE: "true",
                    naming.TAG_ALARM: "false"}
            run = self.client.create_run(self.experiment_id, tags=tags,
                                         run_name=f"{asset} candidate fill {k}")
            self.client.log_batch(run.info.run_id, metrics=self.metrics, params=self.params)
            self.client.create_model_version(
                naming.model_name(asset), source=self.source, run_id=run.info.run_id,
                model_id=self.model_id,
                tags={naming.TAG_FIT_KEY: key, naming.TAG_ROLE: "candidate",
                      naming.TAG_ASSET_ID: asset, naming.TAG_WINDOW_START: start.isoformat(),
                      naming.TAG_WINDOW_END: end.isoformat(), naming.TAG_CALIBRATED: "false"})
            self.count += 1
            if self.count % FILL_BATCH == 0:
                print(f"  filled {self.count} runs", flush=True)


def measure(registry, fits, level: int, repeat: int) -> dict[str, float]:
    """Timings with the store at its current size (``level`` is used to make fresh windows)."""
    asset = "B-0000"
    night0 = 10_000 + level

    def record(i, plots=False, offset=0):
        start = pd.Timestamp("2030-01-01", tz="UTC") + pd.Timedelta(days=night0 + offset + i)
        return registry.record_fit(asset, "turbine", fits["candidate"], role="candidate",
                                   drift=fits["drift"], window=fits["night"] if plots else None,
                                   window_start=start, window_end=start + pd.Timedelta(days=1),
                                   data_hash=f"bench-{level}-{offset}-{i}", plots=plots)

    out = {"record": _median_ms(lambda i: record(i), repeat),
           "record + plots": _median_ms(lambda i: record(i, plots=True, offset=1000), max(3, repeat // 3)),
           "re-record": _median_ms(lambda i: record(i % repeat), repeat),
           "watermark": _median_ms(lambda i: registry.watermark(asset), 10 * repeat),
           "baseline": _median_ms(lambda i: registry.baseline("BASE"), repeat),
           "zeta history": _median_ms(lambda i: registry.zeta_history(asset), max(3, repeat // 3))}
    return out


NIGHTLY_CALLS = ("watermark", "baseline", "record", "commit_watermark")


def nightly(registry, fits, assets: int, nights: int, batch: int = 0,
            history: int = 0, warmup: int = 0, group: int = 0, one_by_one: bool = False
            ) -> dict[str, list[tuple[float, float]]]:
    """Time every registry call of the nightly path, per asset-night.

    ``assets`` assets get a calibrated, promoted baseline and a watermark (and ``history``
    filler candidate runs and versions each, as if they had been running that many nights);
    then ``nights`` nights are recorded as :func:`flows.nightly` does, asset by asset:
    ``watermark``, ``baseline`` (load and verify), ``record`` (the candidate with its drift,
    no plots) and ``commit_watermark``. With ``batch``, each group of ``batch`` assets records
    its candidates with one :meth:`Registry.record_fits` (its time shared equally). With
    ``group``, each group of ``group`` assets is committed as the nightly flow commits a
    memory group: one :meth:`Registry.record_group`, then one
    :meth:`Registry.commit_watermarks` (each time shared equally); with ``one_by_one`` too,
    the group's reads come first as well but each asset is recorded and committed alone (the
    flow's commit before ``record_group``).
    ``warmup`` nights are recorded first the same way, untimed.

    Returns (wall, CPU) seconds per call, one per asset-night: the CPU time of this thread
    shows what other load on the machine does not.
    """
    from registry import FitSubmission

    names = [f"N-{a:04d}" for a in range(assets)]
    day0 = pd.Timestamp("2026-01-05", tz="UTC")
    for asset in names:
        base = registry.record_fit(asset, "turbine", fits["baseline"], role="baseline",
                                   calibration=fits["calibration"],
                                   window_start=day0 - pd.Timedelta(days=4), window_end=day0,
                                   data_hash=f"baseline-{asset}", plots=False)
        registry.promote(asset, base.version, reason="benchmark")
        registry.commit_watermark(asset, day0)
    if history:
        started = time.perf_counter()
        Filler(registry, fits["candidate"], fits["drift"], assets, prefix="N").fill_to(
            1 + history * assets)
        print(f"filled {history} runs and versions per asset in "
              f"{time.perf_counter() - started:.0f} s", flush=True)
    times: dict[str, list[tuple[float, float]]] = {name: [] for name in NIGHTLY_CALLS}

    def timed(name, call, share: int = 1):
        wall, cpu = time.perf_counter(), time.thread_time()
        value = call()
        spent = ((time.perf_counter() - wall) / share, (time.thread_time() - cpu) / share)
        if night >= warmup:       # the night being recorded (the loop below)
            times[name].extend([spent] * share)
        return value

    size = group or batch or 1
    for night in range(warmup + nights):
        start = day0 + pd.Timedelta(days=night)
        end = start + pd.Timedelta(days=1)
        for first in range(0, assets, size):
            chunk = names[first:first + size]
            submissions = []
            for asset in chunk:
                timed("watermark", lambda: registry.watermark(asset))
                loaded = timed("baseline", lambda: registry.baseline(asset))
                submissions.append(FitSubmission(
                    asset, "turbine", fits["candidate"], role="candidate", drift=fits["drift"],
                    window=fits["night"], window_start=start, window_end=end,
                    baseline_version=loaded.version, plots=False))
                if not batch and not group:
                    timed("record", lambda: registry.record_fit(submissions[-1]))
            if group and one_by_one:      # the flow's commit of a group before record_group
                for submission in submissions:
                    timed("record", lambda: registry.record_fit(submission))
                for asset in chunk:
                    timed("commit_watermark", lambda: registry.commit_watermark(asset, end))
                continue
            if group:
                records = timed("record", lambda: registry.record_group(submissions),
                                share=len(chunk))
                failed = [r for r in records if not getattr(r, "created", False)]
                if failed:
                    raise RuntimeError(f"the group's records failed: {failed}")
                timed("commit_watermark",
                      lambda: registry.commit_watermarks({asset: end for asset in chunk}),
                      share=len(chunk))
                continue
            if batch:
                timed("record", lambda: registry.record_fits(submissions), share=len(chunk))
            for asset in chunk:
                timed("commit_watermark", lambda: registry.commit_watermark(asset, end))
    return times


def print_nightly(times: dict[str, list[tuple[float, float]]], args) -> None:
    n = len(times[NIGHTLY_CALLS[0]])
    print()
    how = (f"groups of {args.group} assets, each recorded and committed alone"
           if args.group and args.one_by_one
           else f"record_group + commit_watermarks of {args.group} assets" if args.group
           else f"record_fits of {args.batch} assets" if args.batch
           else "record_fit and commit_watermark per asset")
    store = "embedded SQLite store (WAL)" if not args.tracking_uri else \
        args.tracking_uri.split("://")[0]
    path = "client path" if args.client_path else "SQL writes where the store allows"
    print(f"nightly path, {store}, {path}: {args.assets} assets x {args.nights} "
          f"nights = {n} asset-nights, {how}, {args.history} nights of history, "
          f"{args.warmup} untimed night(s) first; ms per "
          f"asset-night (wall, and CPU of the calling thread)")
    print(f"| {'call':<16} | {'mean':>7} | {'median':>7} | {'p90':>7} | {'CPU mean':>8} | "
          f"{'CPU median':>10} |")
    print(f"|{'-' * 18}|{'-' * 9}|{'-' * 9}|{'-' * 9}|{'-' * 10}|{'-' * 12}|")
    total = [(sum(w for w, _ in parts), sum(c for _, c in parts))
             for parts in zip(*times.values())]
    for name, values in [*times.items(), ("total", total)]:
        walls = sorted(w for w, _ in values)
        print(f"| {name:<16} | {1000 * statistics.fmean(walls):7.1f} | "
              f"{1000 * statistics.median(walls):7.1f} | "
              f"{1000 * walls[int(0.9 * (len(walls) - 1))]:7.1f} | "
              f"{1000 * statistics.fmean(c for _, c in values):8.1f} | "
              f"{1000 * statistics.median(c for _, c in values):10.1f} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.registry_bench",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, nargs="+", default=[1000, 10000],
                        help="store sizes to measure at (default: 1000 10000)")
    parser.add_argument("--assets", type=int, default=100, help="assets the runs spread over")
    parser.add_argument("--repeat", type=int, default=10, help="repetitions per timing")
    parser.add_argument("--workdir", type=Path, help="keep the store here (default: a temp dir)")
    parser.add_argument("--nightly", action="store_true",
                        help="time the nightly path per asset-night instead")
    parser.add_argument("--nights", type=int, default=3, help="nights of --nightly")
    parser.add_argument("--batch", type=int, default=0,
                        help="--nightly: record each group of this many assets with one "
                             "record_fits (default: record_fit per asset, as the flow does)")
    parser.add_argument("--group", type=int, default=0,
                        help="--nightly: commit each group of this many assets as the nightly "
                             "flow commits a memory group (record_group, then "
                             "commit_watermarks); 0: per asset, as the flow did before")
    parser.add_argument("--one-by-one", action="store_true",
                        help="--group: the group's reads first, then each asset recorded and "
                             "committed alone (record_fit, commit_watermark: the flow before "
                             "record_group)")
    parser.add_argument("--history", type=int, default=0,
                        help="--nightly: filler runs and versions per asset before timing")
    parser.add_argument("--warmup", type=int, default=0,
                        help="--nightly: nights recorded untimed before the timed ones")
    parser.add_argument("--tracking-uri",
                        help="--nightly: the store to time (e.g. postgresql://host/db, an "
                             "empty database; default an embedded SQLite store in the "
                             "work directory)")
    parser.add_argument("--postgres", action="store_true",
                        help="--nightly: on a throw-away PostgreSQL server started for the "
                             "run (tests/postgres_server.py: initdb + pg_ctl, fsync off)")
    parser.add_argument("--client-path", action="store_true",
                        help="record through MlflowClient's calls only (no one-transaction "
                             "SQL writes: registry/store/sql_writes.py), for A/B")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)

    workdir = args.workdir or Path(tempfile.mkdtemp(prefix="registry-bench-"))
    workdir.mkdir(parents=True, exist_ok=True)
    server = None
    if args.postgres:
        import sys

        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
        from postgres_server import PostgresServer, find_initdb

        server = PostgresServer(find_initdb()).start()
        args.tracking_uri = server.create_database("registry_bench")
    try:
        return _run(args, workdir)
    finally:
        if server is not None:
            server.stop()


def _run(args, workdir: Path) -> int:
    from benchmarks.langevin_fits import fit_langevin
    from registry import Registry

    uri = args.tracking_uri or f"sqlite:///{workdir}/mlflow.db"
    print(f"store: {uri}")
    fitted = fit_langevin()
    fits = {"candidate": fitted.candidate, "drift": fitted.drift, "night": fitted.night}

    registry = Registry(uri, workdir=workdir, user="bench")
    if args.client_path:
        registry.backend.sql_writes = False
    if args.nightly:
        fits.update(baseline=fitted.baseline, calibration=fitted.calibration)
        print_nightly(nightly(registry, fits, args.assets, args.nights, args.batch,
                              args.history, args.warmup, args.group, args.one_by_one), args)
        if args.workdir is None:
            shutil.rmtree(workdir, ignore_errors=True)
        return 0
    base = registry.record_fit("BASE", "turbine", fitted.baseline, role="baseline",
                               calibration=fitted.calibration, window=fitted.days, plots=False)
    registry.promote("BASE", base.version, reason="benchmark")
    filler = Filler(registry, fitted.candidate, fitted.drift, args.assets)
    registry.commit_watermark("B-0000", "2026-01-01")
    rows = []
    for level in sorted(args.runs):
        started = time.perf_counter()
        filler.fill_to(level)
        print(f"store holds {filler.count} filler runs (filled in "
              f"{time.perf_counter() - started:.0f} s); measuring", flush=True)
        rows.append((level, measure(registry, fits, level, args.repeat)))
    columns = list(rows[0][1])
    print()
    print("median ms per call, embedded SQLite store (WAL), "
          f"{args.assets} assets, {args.repeat} repetitions")
    header = f"| {'runs in store':>13} | " + " | ".join(f"{c:>14}" for c in columns) + " |"
    print(header)
    print("|" + "|".join("-" * (len(part) + 0) for part in header.split("|")[1:-1]) + "|")
    for level, timings in rows:
        print(f"| {level:>13,} | " + " | ".join(f"{timings[c]:>14.1f}" for c in columns) + " |")
    if args.workdir is None:
        shutil.rmtree(workdir, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
