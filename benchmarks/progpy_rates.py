"""Cost of a ProgPy white box's derivatives over one window: ProgPy's pump on its duty cycle.

``python -m benchmarks.progpy_rates [--seconds 3000] [--repeats 5]``

Simulates one pump of ProgPy's catalogue (``CentrifugalPump``) with ProgPy's own simulator
over its ramped duty cycle (:func:`graybox.models.progpy_simulation.pump_cycle_load`), then
times the white box's ``derivatives`` over those samples (CPU seconds, median of the
repeats) and counts the ProgPy calls it makes and the window's distinct rows of inputs.
"""
from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np
import pandas as pd

from graybox.models import load_model
from graybox.models.progpy_simulation import pump_cycle_load, simulate_progpy_fleet

PUMP = "graybox.models.progpy:CentrifugalPump"
WARM = {"w": 385.0, "Q": 0.117, "Tt": 336.0, "Tr": 329.0, "To": 318.0}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.progpy_rates",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3000.0)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore", UserWarning)
    model = load_model(PUMP, {}, {"Q": "Qout"})
    frame = simulate_progpy_fleet(model, ["P-1"], pd.Timestamp("2026-01-01", tz="UTC"),
                                  args.seconds, pump_cycle_load, step=0.05,
                                  initial=WARM)["P-1"]
    x = frame[list(model.state_columns)].to_numpy()
    u = frame[list(model.input_columns)].to_numpy()
    model.derivatives(x, u)                       # the first window probes what a batch takes
    calls = []
    progpy = model.progpy
    original = progpy.next_state
    progpy.next_state = lambda *a, **k: calls.append(1) or original(*a, **k)
    model.derivatives(x, u)
    progpy.next_state = original
    seconds = []
    for _ in range(args.repeats):
        began = time.process_time()
        model.derivatives(x, u)
        seconds.append(time.process_time() - began)
    print(f"{len(x)} samples, {len(np.unique(u, axis=0))} distinct rows of inputs: "
          f"{len(calls)} ProgPy call(s), {statistics.median(seconds) * 1e3:.2f} ms of CPU "
          f"(median of {args.repeats})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
