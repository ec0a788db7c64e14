"""Time ``read_window`` (read Parquet + validate + grid) on one asset-day at 1 Hz.

Not collected by pytest (no ``test_`` prefix); run it by hand::

    .venv/bin/python tests/graybox/bench_telemetry_read.py [--columns 3] [--repeat 30]

It writes 86,400 rows (timestamps jittered by up to 0.2 s; an input setpoint that holds for
10 minutes and random-walk sensors) with :func:`graybox.telemetry.write_telemetry` into a
temporary directory and prints the best and median wall time and the median CPU time (all
threads; steadier on a shared machine) of ``read_window`` over ``--repeat`` calls (the first
call is a warm-up).
"""
from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np
import pandas as pd

from graybox.telemetry import GridPolicy, read_window, write_telemetry


def one_day_at_1hz(n_columns: int, seed: int = 0) -> pd.DataFrame:
    """86,400 rows at 1 s with small timestamp jitter; column 0 is a held setpoint."""
    rng = np.random.default_rng(seed)
    n = 86_400
    seconds = np.arange(n) + rng.uniform(-0.2, 0.2, n)
    seconds[0] = 0.0
    data = {"timestamp": pd.Timestamp("2026-01-01", tz="UTC")
            + pd.to_timedelta(seconds, unit="s")}
    data["setpoint"] = np.repeat(rng.uniform(0.5, 1.0, n // 600 + 1), 600)[:n]
    for j in range(1, n_columns):
        data[f"sensor{j}"] = np.cumsum(rng.normal(size=n)) + rng.normal(size=n)
    return pd.DataFrame(data)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--columns", type=int, default=3)
    parser.add_argument("--repeat", type=int, default=30)
    args = parser.parse_args(argv)
    frame = one_day_at_1hz(args.columns)
    columns = [c for c in frame.columns if c != "timestamp"]
    policy = GridPolicy(sample_interval=1.0)
    with tempfile.TemporaryDirectory() as root:
        write_telemetry(root, "A-1", frame)
        kwargs = {"policy": policy, "inputs": ["setpoint"]}
        read_window(root, "A-1", columns, **kwargs)  # warm-up
        times, cpu = [], []
        for _ in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            window = read_window(root, "A-1", columns, **kwargs)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
    print(f"read_window, 1 asset-day at 1 Hz ({window.n_samples} grid points, "
          f"{len(columns)} columns): wall best {1e3 * min(times):.1f} ms, "
          f"median {1e3 * float(np.median(times)):.1f} ms; CPU median "
          f"{1e3 * float(np.median(cpu)):.1f} ms over {args.repeat} calls")


if __name__ == "__main__":
    main()
