"""The rough estimate behind :class:`~benchmarks.skab.white_box.SkabPump`'s defaults.

What a user does once, on the healthy file, before recording the defaults: the parameters the
single operating point cannot identify are set from physics (see the white box's docstring),
the rest from an energy balance at the mean operating point and one least-squares fit.
``python -m benchmarks.skab.estimate [--data DIR]`` prints them.
"""
from __future__ import annotations

import argparse
import pathlib

import numpy as np
import pandas as pd

from benchmarks.skab.data import dataset_dir, healthy_frame
from benchmarks.skab.white_box import SkabPump

#: the white box's parameters set from physics, not from the data
PHYSICAL_CHOICES = ("motor_capacity", "fluid_capacity", "loss_fraction",
                    "motor_fluid_conductance", "ambient_temp")


def energy_balance_defaults(frame: pd.DataFrame, physics: dict | None = None) -> dict[str, float]:
    """The data-dependent defaults from a healthy 1-s frame.

    Parameters
    ----------
    frame : pandas.DataFrame
        Healthy telemetry on a 1-s grid, with the white box's channel names and the
        electrical inputs averaged (:func:`benchmarks.skab.data.healthy_frame`).
    physics : dict, optional
        Values of :data:`PHYSICAL_CHOICES`; default the white box's defaults.

    Returns
    -------
    dict of str to float
        ``motor_ambient_conductance``, ``fluid_ambient_conductance``, ``flow_per_watt``,
        ``flow_time_constant``, ``vibration_1_level`` and ``vibration_2_level``.

    Notes
    -----
    Motor at steady state (its mean drift is a few mK per minute):
    ``G_ma = (lambda P - G_mf (T_m - T_f)) / (T_m - T_a)`` at the means. Fluid, warming at the
    slope ``s`` of a straight line through its record:
    ``G_fa = ((1 - lambda) P + G_mf (T_m - T_f) - C_f s) / (T_f - T_a)``. Flow:
    ``k_Q = mean Q / mean P``, and ``1 / tau_Q`` the least-squares slope of the 1-s changes
    ``Q(t+1) - Q(t)`` on ``k_Q P(t) - Q(t)`` (no intercept).
    """
    p = {name: SkabPump.default_parameters[name] for name in PHYSICAL_CHOICES}
    p.update(physics or {})
    power = (frame["current"] * frame["voltage"]).to_numpy()
    motor, fluid, flow = (frame[c].to_numpy() for c in ("motor_temp", "fluid_temp", "flow"))
    seconds = (frame.index - frame.index[0]).total_seconds().to_numpy()
    warming = np.polyfit(seconds, fluid, 1)[0]
    coupling = p["motor_fluid_conductance"] * (motor.mean() - fluid.mean())
    motor_loss = (p["loss_fraction"] * power.mean() - coupling) / (motor.mean() - p["ambient_temp"])
    fluid_loss = (((1 - p["loss_fraction"]) * power.mean() + coupling
                   - p["fluid_capacity"] * warming) / (fluid.mean() - p["ambient_temp"]))
    flow_per_watt = flow.mean() / power.mean()
    lag = flow_per_watt * power[:-1] - flow[:-1]
    rate = float(lag @ np.diff(flow) / (lag @ lag))
    return {"motor_ambient_conductance": float(motor_loss),
            "fluid_ambient_conductance": float(fluid_loss),
            "flow_per_watt": float(flow_per_watt), "flow_time_constant": 1.0 / rate,
            "vibration_1_level": float(frame["vibration_1"].mean()),
            "vibration_2_level": float(frame["vibration_2"].mean())}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    root = pathlib.Path(__file__).resolve().parents[2]
    parser.add_argument("--data", default=str(dataset_dir(root)), help="the SKAB folder")
    args = parser.parse_args(argv)
    estimates = energy_balance_defaults(healthy_frame(args.data))
    for name, value in estimates.items():
        print(f"{name:28s} {value:.4g}")


if __name__ == "__main__":
    main()
