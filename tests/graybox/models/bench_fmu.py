"""Time an FMU white box (graybox.models.fmu) against the same plant written in Python.

Not collected by pytest (no ``test_`` prefix); run it by hand from the repository root::

    .venv/bin/python tests/graybox/models/bench_fmu.py [--repeat 5]

It builds plant_fmu.py's FMU (plant.c, with the system's ``cc``) in a temporary directory and
prints the best wall time of ``derivatives`` and ``output`` on 86,400 random rows (one day
at 1 Hz) over ``--repeat`` calls, then the wall time of a baseline (``fit_baselines`` with the
defaults on three 1,800-s windows simulated by plant_fmu.py) and of one with ``tau``
estimated, each for the FMU and for the Python plant.
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).parent))

import graybox as gb  # noqa: E402
import plant_fmu  # noqa: E402
import test_fmu  # noqa: E402


def best_time(function, repeat: int) -> float:
    function()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    repeat = parser.parse_args().repeat
    with tempfile.TemporaryDirectory() as directory:
        plant = test_fmu.fmu_class(plant_fmu.build_fmu(pathlib.Path(directory)))
        models = {"FMU": plant, "Python": plant_fmu.TwinPlant}
        x, u = test_fmu.random_rows(86_400, 0)
        for name, cls in models.items():
            model = cls()
            for method in ("derivatives", "output"):
                seconds = best_time(lambda: getattr(model, method)(x, u), repeat)
                print(f"{name:6s} {method:11s} 86,400 rows: {seconds:.3f} s "
                      f"({seconds / 86_400 * 1e6:.2f} us a row)")
        windows = [plant_fmu.simulate(1800, seed, start, 0.01, tau=26.0)[0]
                   for seed, start in enumerate(([4.0, 3.0], [8.0, 6.0], [2.0, 5.0]))]
        for estimate in ((), ("tau",)):
            for name, cls in models.items():
                request = gb.FitRequest(cls(), windows, asset_id="F-1", seed=0,
                                        estimate=estimate)
                start = time.perf_counter()
                [fitted] = gb.fit_baselines([request])
                seconds = time.perf_counter() - start
                tuned = f", tau = {fitted[0].model.parameters['tau']:.3f}" if estimate else ""
                print(f"{name:6s} baseline of 3 x 1,800 s, estimate={list(estimate)}: "
                      f"{seconds:.1f} s{tuned}")


if __name__ == "__main__":
    main()
