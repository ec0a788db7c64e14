"""``python -m benchmarks.level_cost``: seconds of the level tier per asset-day, against the
one-step residual, for one simulated gas-turbine day at 10 s and at 1 s (white box 20 % off).

The level tier runs at the analysis interval (every ``factor``-th telemetry sample, as
:func:`graybox.fleet_fit.fit_signatures` does); the residual at the telemetry's rate.
"""
from __future__ import annotations

import time

from graybox.analysis_rate import choose_analysis_interval
from graybox.level_tier import fit_level, horizon_samples, level_data, start_stride
from graybox.models.gas_turbine import GasTurbineShaft
from graybox.residual import residual_frame
from graybox.simulator import FleetSpec, VehicleSpec, simulate_fleet, white_box_parameters


def main() -> None:
    model = GasTurbineShaft(white_box_parameters(0.2), columns={"omega": "shaft_speed"})
    for dt in (10.0, 1.0):
        spec = FleetSpec((VehicleSpec("V", seed=1),), days=1, sample_interval=dt)
        frame = simulate_fleet(spec)["V"].set_index("timestamp")
        step = choose_analysis_interval(model, [frame], dt)
        k = horizon_samples(step)
        start = time.perf_counter()
        errors, features = level_data(model, [frame.iloc[::round(step / dt)]], step, k,
                                      start_stride(step))["omega"]
        fit_level(errors, features, k)
        level = time.perf_counter() - start
        start = time.perf_counter()
        residual_frame(model, frame, "one_step", dt)
        residual = time.perf_counter() - start
        print(f"telemetry every {dt:g} s, analysed every {step:g} s, k = {k}: level tier "
              f"{level:.3f} s per asset-day, one-step residual {residual:.3f} s")


if __name__ == "__main__":
    main()
