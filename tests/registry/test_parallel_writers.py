"""Concurrent writers on one SQLite store: every run recorded, no "database is locked"."""
from __future__ import annotations

import pathlib
import subprocess
import sys
import threading

import pandas as pd

from registry.store import naming

WORKER = pathlib.Path(__file__).with_name("parallel_worker.py")


def _check_store(registry, n_runs: int, assets: list[str]) -> None:
    client = registry.backend.client
    experiment = client.get_experiment_by_name("fleet-health/turbine")
    runs = list(registry.backend.paged(client.search_runs, [experiment.experiment_id], ""))
    assert len(runs) == n_runs
    assert all(r.info.status == "FINISHED" and r.data.tags[naming.TAG_COMPLETE] == "true"
               for r in runs)
    assert len({r.data.tags[naming.TAG_FIT_KEY] for r in runs}) == n_runs
    versions = 0
    for asset in assets:
        numbers = [v.version for v in registry.history(asset)]
        assert numbers == list(range(1, len(numbers) + 1))      # no gap, no duplicate
        versions += len(numbers)
        model = client.get_registered_model(naming.model_name(asset))
        assert int(model.aliases["candidate"]) == len(numbers)
    assert versions == n_runs


def test_eight_writer_processes_record_every_run(tmp_path, store_uri, fits, registry):
    processes, fits_each, assets = 8, 3, 4
    signature = tmp_path / "signature.json"
    signature.write_text(fits.baseline.to_json())
    calibration = tmp_path / "calibration.json"
    calibration.write_text(fits.calibration.to_json())
    done = subprocess.run([sys.executable, str(WORKER), store_uri, str(signature),
                           str(calibration), str(processes), str(fits_each), str(assets)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr[-5000:]
    assert "Traceback" not in done.stderr, done.stderr[-5000:]
    lines = [line for line in done.stdout.splitlines() if "retries=" in line]
    assert len(lines) == processes
    retries = sum(int(line.split("retries=")[1]) for line in lines)
    print(f"\n{processes} processes x {fits_each} fits: {retries} 'database is locked' retries")
    asset_ids = [f"P-{a:02d}" for a in range(assets)]
    _check_store(registry, processes * fits_each, asset_ids)
    last = pd.Timestamp("2026-02-01", tz="UTC") + pd.Timedelta(days=processes * fits_each)
    assert max(registry.watermark(a) for a in asset_ids) == last


def test_eight_writer_threads_record_every_run(registry, fits):
    record_from_threads(registry, fits, threads_n=8, fits_each=2)


def record_from_threads(registry, fits, threads_n: int, fits_each: int) -> None:
    """``threads_n`` threads record ``fits_each`` baselines each, all at once, over three
    assets; then every run is in the store once and the versions have no gap."""
    barrier = threading.Barrier(threads_n)
    errors = []

    def write(worker):
        barrier.wait()
        try:
            for k in range(fits_each):
                start = pd.Timestamp("2026-03-01", tz="UTC") + pd.Timedelta(days=worker * fits_each + k)
                registry.record_fit(f"Q-{worker % 3}", "turbine", fits.baseline, role="baseline",
                                    calibration=fits.calibration, window_start=start,
                                    window_end=start + pd.Timedelta(days=1),
                                    data_hash=f"t{worker}-{k}", plots=False)
        except Exception as error:     # reported by the assertion below
            errors.append(error)

    threads = [threading.Thread(target=write, args=(w,)) for w in range(threads_n)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors, errors
    _check_store(registry, threads_n * fits_each, ["Q-0", "Q-1", "Q-2"])
