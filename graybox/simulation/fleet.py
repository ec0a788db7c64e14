"""Simulate a fleet's telemetry (and its hidden truth), and write it in the telemetry layout."""
from __future__ import annotations

import json
import pathlib

import numpy as np
import pandas as pd

from graybox.simulation.clock import Clock
from graybox.simulation.draws import Draws, draw
from graybox.simulation.plant import Plant, integrate_fleet
from graybox.simulation.specs import FleetSpec
from graybox.telemetry import write_telemetry

TRUTH_FILE = "fleet_truth.json"


def _measure(plant: Plant, omega, draws: Draws, clock: Clock):
    """Shaft speed and fuel rate at the (jittered) sampling instants, before sensor noise.

    ``omega`` is on the integration grid; so is the interpolation inside a step.
    """
    if not draws.jitter.any():
        return omega[::clock.stride], draws.fuel[::clock.stride]
    h = clock.h
    tau = np.arange(clock.n, dtype=float) * clock.stride + draws.jitter / h  # in steps
    q = np.clip(np.floor(tau).astype(int), 0, clock.n_int - 2)
    theta = tau - q
    fuel0, fuel1 = draws.fuel[q], draws.fuel[q + 1]
    moment, friction = draws.moment[q], draws.friction[q]
    with_friction = bool(np.any(friction != 0))
    w0, w1 = omega[q], omega[q + 1]
    f0 = plant.drift(w0, fuel0, *plant.forcing(fuel0, moment, friction, with_friction)) * h
    f1 = plant.drift(w1, fuel1, *plant.forcing(fuel1, moment, friction, with_friction)) * h
    # cubic Hermite inside the step, with the drift of that step at both ends
    t2, t3 = theta ** 2, theta ** 3
    speed = ((2 * t3 - 3 * t2 + 1) * w0 + (t3 - 2 * t2 + theta) * f0
             + (-2 * t3 + 3 * t2) * w1 + (t3 - t2) * f1)
    return speed, fuel0 + (fuel1 - fuel0) * theta


def simulate_fleet_with_truth(spec: FleetSpec) -> tuple[dict[str, pd.DataFrame],
                                                         dict[str, pd.DataFrame]]:
    """Simulate a fleet; return its telemetry and the hidden truth behind it.

    Parameters
    ----------
    spec : FleetSpec

    Returns
    -------
    telemetry : dict of str to DataFrame
        As :func:`simulate_fleet`.
    truth : dict of str to DataFrame
        Per asset, on the uniform grid (no jitter, no drops): ``timestamp``, ``omega`` (true
        shaft speed), ``fuel_rate`` (true ``mu``), ``moment`` (``Gamma_i`` of the 10-s moment
        step that ``timestamp`` lies in, held over that step), ``innovation`` (``u_i``) and
        ``shock`` (``e_i``) of that step, ``sensor_noise`` (shaft-speed sensor noise, bias
        excluded) and ``bias``. At 10 s a sample is a moment step.

    Notes
    -----
    The moment clock's streams (``Gamma``, flutter, fuel wander) and the fuel phase are
    shared by every sampling interval, so ``omega``, ``fuel_rate`` and ``moment`` of one
    vehicle agree across rates at the common instants (``omega`` up to integration error);
    ``sensor_noise``, the fuel-sensor noise, jitter and drops are drawn per sample.
    """
    return _simulate(spec, with_truth=True)


def _simulate(spec: FleetSpec, with_truth: bool):
    if not spec.vehicles:
        return {}, {}
    clock = Clock.of(spec)
    draws = [draw(v, spec) for v in spec.vehicles]
    models = [v.plant() for v in spec.vehicles]
    plant = Plant(models)

    def stack(name):
        return np.stack([getattr(d, name) for d in draws], axis=1)

    omega0 = np.array([float(m.equilibrium_speed(d.fuel[0])) for m, d in zip(models, draws)])
    omega = integrate_fleet(plant, omega0, stack("fuel"), stack("moment"), stack("friction"),
                             clock.h, spec.substeps)
    start = spec.start_timestamp
    grid_ns = np.round(np.arange(clock.n) * clock.dt * 1e9).astype(np.int64)
    grid = start + pd.to_timedelta(grid_ns, unit="ns")
    step = clock.step_of_sample()
    telemetry, truth = {}, {}
    for i, (vehicle, d) in enumerate(zip(spec.vehicles, draws)):
        speed, fuel = _measure(plant.subset(i), omega[:, i], d, clock)
        stamps = grid if not d.jitter.any() else start + pd.to_timedelta(
            grid_ns + np.round(d.jitter * 1e9).astype(np.int64), unit="ns")
        keep = slice(None) if d.keep.all() else d.keep
        telemetry[vehicle.asset_id] = pd.DataFrame({
            "timestamp": stamps[keep], "shaft_speed": (speed + d.sensor + d.bias)[keep],
            "fuel_rate": (fuel + d.fuel_sensor)[keep]})
        if with_truth:
            truth[vehicle.asset_id] = pd.DataFrame({
                "timestamp": grid, "omega": omega[::clock.stride, i],
                "fuel_rate": d.fuel[::clock.stride], "moment": d.moment_steps[step],
                "innovation": d.innovation[step], "shock": d.shock[step],
                "sensor_noise": d.sensor, "bias": d.bias})
    return telemetry, truth


def simulate_fleet(spec: FleetSpec) -> dict[str, pd.DataFrame]:
    """Simulate the telemetry of a fleet.

    Parameters
    ----------
    spec : FleetSpec

    Returns
    -------
    dict of str to DataFrame
        Asset id -> frame with columns ``timestamp`` (UTC), ``shaft_speed`` (rad/s) and
        ``fuel_rate`` (kg/s), in time order.

    Examples
    --------
    >>> frames = simulate_fleet(FleetSpec((VehicleSpec("T-001", seed=1),), days=1))
    >>> len(frames["T-001"])
    8640
    """
    return _simulate(spec, with_truth=False)[0]


def write_fleet(spec: FleetSpec, root) -> dict[str, pd.DataFrame]:
    """Simulate a fleet and write it in the telemetry layout, with its truth.

    Writes ``<root>/asset_id=<id>/date=<YYYY-MM-DD>/part-0.parquet`` through
    :func:`graybox.telemetry.write_telemetry` and ``<root>/fleet_truth.json``
    (``spec.to_dict()``: the faults, seeds and plant parameters).

    Parameters
    ----------
    spec : FleetSpec
    root : str or path-like
        Telemetry root (created if needed).

    Returns
    -------
    dict of str to DataFrame
        The frames written, as :func:`simulate_fleet`.
    """
    root = pathlib.Path(root)
    frames = simulate_fleet(spec)
    root.mkdir(parents=True, exist_ok=True)
    for asset_id, frame in frames.items():
        write_telemetry(root, asset_id, frame)
    (root / TRUTH_FILE).write_text(json.dumps(spec.to_dict(), indent=2) + "\n")
    return frames
