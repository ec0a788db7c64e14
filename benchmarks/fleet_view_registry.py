"""Time to read the fleet view's ratios from an MLflow store (SQLite), at fleet scale.

    python -m benchmarks.fleet_view_registry --assets 200 --nights 14

Writes ``--assets`` x ``--nights`` complete candidate runs into a fresh SQLite store in a
temporary directory, shaped like the nightly's (the registry's tags, 25 metrics and 10
params per run, as a one-channel gas turbine's), then times
:func:`registry.fleet_nights.night_ratios` over the nights (one search per calendar month)
and checks it found every asset-night. Writing the store is not timed.
"""
from __future__ import annotations

import argparse
import pathlib
import tempfile
import time

import numpy as np
import pandas as pd
from mlflow.entities import Metric, Param

from flows.fleet_view import window_nights
from registry.store import naming
from registry.store.backend import Backend
from registry.fleet_nights import night_ratios
from registry.write.run_content import entry_metric

TIERS = ("linear", "nonlinear", "noise")


def fill(backend: Backend, assets: int, nights: tuple[str, ...], seed: int = 1) -> None:
    """Write the candidate runs (see the module docstring)."""
    rng = np.random.default_rng(seed)
    experiment = backend.experiment_id("turbine", create=True)
    client = backend.client
    stamp = int(time.time() * 1000)
    for i in range(assets):
        asset = f"T-{i:04d}"
        for night in nights:
            start = pd.Timestamp(night, tz="UTC")
            tags = {naming.TAG_ASSET_ID: asset, naming.TAG_VEHICLE_CLASS: "turbine",
                    naming.TAG_WINDOW_START: naming.iso_utc(start),
                    naming.TAG_WINDOW_END: naming.iso_utc(start + pd.Timedelta(days=1)),
                    naming.TAG_ROLE: naming.CANDIDATE, naming.TAG_COMPLETE: "true",
                    naming.TAG_ALARM: "false", naming.TAG_BASELINE_VERSION: "1",
                    naming.TAG_DATA_HASH: f"{i:08d}{night}", naming.TAG_FIT_KEY: f"{i}{night}",
                    naming.TAG_CODE_VERSION: "bench", naming.TAG_MODEL_ID: "m"}
            run = client.create_run(experiment, tags=tags)
            ratios = rng.lognormal(np.log(0.35), 0.35, 3)
            metrics = {"max_ratio": float(ratios.max()), "alarm": 0.0, "n_samples": 86400.0}
            for tier, ratio in zip(TIERS, ratios):
                metrics[entry_metric("zeta", "omega", tier)] = float(ratio * 0.5)
                metrics[entry_metric("epsilon", "omega", tier)] = 0.5
                metrics[entry_metric("ratio", "omega", tier)] = float(ratio)
            for k in range(25 - len(metrics)):
                metrics[f"fit.omega.m{k}"] = float(k)
            client.log_batch(run.info.run_id,
                             metrics=[Metric(k, v, stamp, 0) for k, v in metrics.items()],
                             params=[Param(f"channels.omega.p{k}", str(k)) for k in range(10)])
            client.set_terminated(run.info.run_id)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--assets", type=int, default=200)
    parser.add_argument("--nights", type=int, default=14)
    parser.add_argument("--last-night", default="2026-03-14")
    args = parser.parse_args(argv)
    nights = window_nights(args.last_night, args.nights)
    with tempfile.TemporaryDirectory(prefix="fleet-view-registry-") as work:
        backend = Backend(f"sqlite:///{pathlib.Path(work) / 'mlflow.db'}")
        started = time.perf_counter()
        fill(backend, args.assets, nights)
        filled = time.perf_counter() - started
        started = time.perf_counter()
        found = night_ratios(backend, nights)
        read = time.perf_counter() - started
    assert len(found) == args.assets * args.nights, len(found)
    print(f"{args.assets} assets x {args.nights} nights ({len(found)} runs; store written in "
          f"{filled:.0f} s): night_ratios {read:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
