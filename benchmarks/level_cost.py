"""``python -m benchmarks.level_cost``: seconds of the level tier per asset-day, against the
one-step residual, for one simulated gas-turbine day at 10 s and at 1 s (white box 20 % off).

The level tier runs at the analysis interval (every ``factor``-th telemetry sample, as
:func:`graybox.signature_fit.fit_signatures` does); the residual at the telemetry's rate.
"""
from __future__ import annotations

import time

from graybox.analysis_rate import choose_analysis_interval
from graybox.level_tier import fit_level, horizon_samples, level_data, start_stride
from graybox.models.gas_turbine import GasTurbineShaft
from graybox.residual import residual_frame
from graybox.simulation import FleetSpec, VehicleSpec, simulate_fleet, white_box_parameters


def main() -> None:
    model = GasTurbineShaft(white_box_parameters(0.2), columns={"omega": "shaft_speed"})
    for dt in (10.0, 1.0):
        spec = FleetSpec((VehicleSpec("V", seed=1),), days=1, sample_interval=dt)
        frame = simulate_fleet(spec)["V"].set_index("timestamp")
        step = choose_analysis_interval(model, [frame], dt)
        k = horizon_samples(step)
        start = time.perf_counter()
        errors, features, _ = level_data(model, [frame.iloc[::round(step / dt)]], step, k,
                                      start_stride(step, k))["omega"]
        fit_level(errors, features, k)
        level = time.perf_counter() - start
        start = time.perf_counter()
        residual_frame(model, frame, "one_step", dt)
        residual = time.perf_counter() - start
        print(f"telemetry every {dt:g} s, analysed every {step:g} s, k = {k}: level tier "
              f"{level:.3f} s per asset-day, one-step residual {residual:.3f} s")
    _pump()


def _pump() -> None:
    """The same for one hour of a 1-Hz ProgPy centrifugal pump (skipped without progpy)."""
    try:
        import progpy  # noqa: F401
    except ImportError:
        print("ProgPy pump: skipped (progpy not installed)")
        return
    import pandas as pd

    from graybox.models import load_model
    from graybox.models.progpy_simulation import pump_cycle_load, simulate_progpy_fleet

    model = load_model("graybox.models.progpy:CentrifugalPump", columns={"Q": "Qout"})
    frame = simulate_progpy_fleet(
        model, ["P-001"], pd.Timestamp("2026-03-01", tz="UTC"), 3600.0, pump_cycle_load,
        sample_interval=1.0, step=0.5,
        process_noise={"w": 0.5, "Q": 1e-4, "Tt": 0.01, "Tr": 0.01, "To": 0.001},
        measurement_noise={"w": 0.05, "Qout": 1e-5, "Tt": 0.01, "Tr": 0.01, "To": 0.01},
        initial={"w": 385.0, "Q": 0.117, "Tt": 336.0, "Tr": 329.0, "To": 318.0}, seed=11)["P-001"]
    if "timestamp" in frame:
        frame = frame.set_index("timestamp")
    start = time.perf_counter()
    level_data(model, [frame], 1.0, horizon_samples(1.0), start_stride(1.0, horizon_samples(1.0)))
    level = time.perf_counter() - start
    start = time.perf_counter()
    residual_frame(model, frame, "one_step", 1.0)
    residual = time.perf_counter() - start
    print(f"ProgPy pump, one hour at 1 s: level tier {level:.2f} s, one-step residual "
          f"{residual:.2f} s")


if __name__ == "__main__":
    main()
