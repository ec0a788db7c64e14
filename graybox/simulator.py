"""The fleet simulator's public names, as imported before it became the package
:mod:`graybox.simulation` (see there for the model); ``python -m graybox.simulator`` prints a
summary of the demo fleet.
"""
from graybox.simulation import (FAULT_KINDS, MOMENT_STEP, SECONDS_PER_DAY, TRUTH_FILE, Fault,
                                FleetSpec, VehicleSpec, demo_fleet, moment_ar_coefficients,
                                moment_steps_ratio, simulate_fleet, simulate_fleet_with_truth,
                                simulate_langevin, white_box_parameters, write_fleet)

__all__ = ["FAULT_KINDS", "MOMENT_STEP", "SECONDS_PER_DAY", "TRUTH_FILE", "Fault",
           "VehicleSpec", "FleetSpec", "simulate_fleet", "simulate_fleet_with_truth",
           "write_fleet", "demo_fleet", "simulate_langevin", "white_box_parameters",
           "moment_ar_coefficients", "moment_steps_ratio"]

if __name__ == "__main__":
    # sanity print: the demo fleet's faults and telemetry summary
    _spec = demo_fleet()
    for _vehicle, (_asset, _frame) in zip(_spec.vehicles, simulate_fleet(_spec).items()):
        print(f"{_asset}: {len(_frame)} rows, shaft_speed {_frame.shaft_speed.mean():8.2f} "
              f"+- {_frame.shaft_speed.std():6.2f} rad/s, fuel_rate {_frame.fuel_rate.mean():.3f} "
              f"kg/s, faults: {[f.to_dict() for f in _vehicle.faults] or 'none'}")
