"""Heated room at 60 s: a slow thermal plant under a modulating thermostat.

True plant (three nodes): the room air ``Ta`` (with furniture, ``C_a``), the building's
internal mass ``Tm`` and the envelope ``Tw``::

    C_a dTa/dt = (Tm - Ta)/R_am + (Tw - Ta)/R_aw + (To - Ta) U_inf + eta P + f_a S + G
    C_m dTm/dt = (Ta - Tm)/R_am + (1 - f_a) S
    C_w dTw/dt = (Ta - Tw)/R_aw + (To - Tw)/R_wo

``P`` the heater's electrical power (a PI thermostat, 21 C by day and 18 C at night, up to
``P_max``), ``To`` the outdoor temperature (a daily cycle around a mean that changes from day to
day, plus weather), ``S`` sunshine through the windows (a cloudiness drawn per day), ``G``
occupancy gains on working hours. Telemetry: air and wall-surface temperature (0.01 K
resolution), heater power, outdoor temperature.

The white box a user writes (:class:`RoomWhiteBox`): two nodes, air and envelope, driven by the
measured heater power and outdoor temperature; the internal mass, the sun, the occupants and the
heater's efficiency are left out, and the parameters are 10-20 % off the fleet's mean.
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 60.0
SUBSTEPS = 2
WARMUP_DAYS = 2


class RoomWhiteBox(WhiteBoxModel):
    """Two-node room: air (with its furniture) and envelope, heater power and outdoor
    temperature as inputs. Temperatures in C, power in W, capacities in J/K, conductances in
    W/K."""

    states = ("air", "wall")
    inputs = ("heater", "outdoor")
    controlled_inputs = ("heater",)  # the thermostat sets it
    default_parameters = {"c_air": 2.6e6, "c_wall": 2.6e7, "ua_air_wall": 380.0,
                          "ua_infiltration": 50.0, "ua_wall_out": 250.0}

    def derivatives(self, x, u):
        p = self.parameters
        air, wall = x[..., 0], x[..., 1]
        heater, outdoor = u[..., 0], u[..., 1]
        to_wall = p["ua_air_wall"] * (wall - air)
        d_air = (to_wall + p["ua_infiltration"] * (outdoor - air) + heater) / p["c_air"]
        d_wall = (-to_wall + p["ua_wall_out"] * (outdoor - wall)) / p["c_wall"]
        return np.stack([d_air, d_wall], axis=-1)


class ThermalRoom(Family):
    name = "thermal_room"
    title = "Heated room (60 s)"
    description = ("three thermal nodes (air, internal mass, envelope), PI thermostat with night "
                   "setback, weather, sun and occupants; white box: two nodes, no sun, no "
                   "occupants, no internal mass, parameters 10-20 % off")
    spec = "benchmarks.zoo.families.thermal_room:RoomWhiteBox"
    columns = {"air": "air_temp", "wall": "wall_temp", "heater": "heater_power",
               "outdoor": "outdoor_temp"}
    sample_interval = DT
    held_out = False
    channels = ("air_temp", "wall_temp", "heater_power", "outdoor_temp")
    faults = (
        FaultKind("insulation", "envelope conductance to outside up by m (relative)", (0.2, 0.5)),
        FaultKind("heater", "heater delivers a fraction m less heat than it draws", (0.1, 0.25)),
        FaultKind("window", "a window left ajar: m W/K more infiltration", (30.0, 80.0)),
        FaultKind("sensor_bias", "air-temperature sensor reads m K high", (0.3, 1.0)),
    )

    def true_parameters(self, rng):
        return {"c_air": spread(rng, 2.2e6, 0.05), "c_mass": spread(rng, 1.5e7, 0.05),
                "c_wall": spread(rng, 3.0e7, 0.05), "ua_air_mass": spread(rng, 1200.0, 0.05),
                "ua_air_wall": spread(rng, 450.0, 0.05), "ua_inf": spread(rng, 60.0, 0.1),
                "ua_wall_out": spread(rng, 300.0, 0.05), "eta": spread(rng, 0.97, 0.01),
                "p_max": spread(rng, 9000.0, 0.03), "window_area": spread(rng, 4.0, 0.1)}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        warm = WARMUP_DAYS * self.samples_per_day
        n, t, hour, total = self.clock(warm)
        # weather: the day's mean and swing, hours-long fluctuations
        mean = batch.uniform(-5.0, 10.0)[:, None]
        swing = batch.uniform(2.0, 6.0)[:, None]
        outdoor = (mean + swing * np.cos(2 * np.pi * (hour - 15.0) / 24.0)[None, :]
                   + smooth_noise(batch, total, 3 * 3600 / DT, 1.0))
        clear = batch.uniform(0.0, 1.0)[:, None]
        sun = (np.clip(np.sin(np.pi * (hour - 8.0) / 8.0), 0.0, None)[None, :]
               * (150.0 * p["window_area"])[:, None] * clear
               * np.clip(1 + 0.5 * smooth_noise(batch, total, 20 * 60 / DT), 0.0, None))
        working = ((hour >= 8.0) & (hour < 18.0)).astype(float)[None, :]
        occupants = working * batch.uniform(100.0, 500.0)[:, None]
        setpoint = np.where((hour >= 6.0) & (hour < 22.0), 21.0, 18.0)

        ua_out = p["ua_wall_out"][:, None] * (1 + batch.active("insulation", t))
        eta = p["eta"][:, None] * (1 - batch.active("heater", t))
        ua_inf = p["ua_inf"][:, None] + batch.active("window", t)

        ta = np.full(len(batch), 19.0)
        tm, tw = ta.copy(), ta - 5.0
        integral = np.full(len(batch), 0.3)
        h = DT / SUBSTEPS
        air, wall, power = (np.empty((len(batch), n)) for _ in range(3))
        for k in range(total):
            error = setpoint[k] - ta
            integral = np.clip(integral + error * DT / 3600.0 * 0.5, 0.0, 1.0)
            draw = np.clip(0.6 * error + integral, 0.0, 1.0) * p["p_max"]
            for _ in range(SUBSTEPS):
                d_air = ((tm - ta) * p["ua_air_mass"] + (tw - ta) * p["ua_air_wall"]
                         + (outdoor[:, k] - ta) * ua_inf[:, k] + eta[:, k] * draw
                         + 0.3 * sun[:, k] + occupants[:, k]) / p["c_air"]
                d_mass = ((ta - tm) * p["ua_air_mass"] + 0.7 * sun[:, k]) / p["c_mass"]
                d_wall = ((ta - tw) * p["ua_air_wall"]
                          + (outdoor[:, k] - tw) * ua_out[:, k]) / p["c_wall"]
                ta, tm, tw = ta + h * d_air, tm + h * d_mass, tw + h * d_wall
            if k >= warm:
                air[:, k - warm], wall[:, k - warm], power[:, k - warm] = ta, tw, draw
        day = slice(warm, total)
        bias = batch.active("sensor_bias", t[day])
        return {"air_temp": quantise(air + bias + batch.normal((n,), 0.03), 0.01),
                "wall_temp": quantise(wall + batch.normal((n,), 0.03), 0.01),
                "heater_power": np.round(power * (1 + batch.normal((n,), 0.005))),
                "outdoor_temp": quantise(outdoor[:, day] + batch.normal((n,), 0.1), 0.01)}


FAMILY = ThermalRoom()
