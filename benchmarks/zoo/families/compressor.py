"""An air compressor that runs intermittently, logged every 2 s.

True plant: a fixed-speed screw compressor charges a receiver of volume ``V``; the plant's
consumers draw air through a flow meter (a demand that follows the shifts and differs by day).
The compressor starts when the receiver falls to 6.5 bar and stops at 7.5 bar, stands still
outside working hours, and its delivery falls with the pressure ratio (volumetric efficiency
``eta_v = 1 - e (p / p_atm - 1)``); the system leaks (``k_leak sqrt(p - p_atm)``). The discharge
air is cooled by an after-cooler whose effectiveness depends on the ambient temperature. The
logger writes rows while the compressor stands still (motor power 0). Telemetry: receiver
pressure (bar, 0.01 resolution), discharge temperature, motor power, demand flow, ambient
temperature.

The white box a user writes (:class:`ReceiverWhiteBox`): delivery proportional to motor power,
no leak, a first-order discharge temperature driven by power and ambient, parameters 10-20 %
off. The class's fleet.toml line makes the stops pauses between operating periods
(:data:`GRID`).
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 2.0
SUBSTEPS = 2
WARMUP = 1800
P_ATM = 1.013

#: the compressor runs while its motor draws power; a window needs 2 h of operation
GRID = {"running": {"motor_power": [5.0, 1000.0]}, "min_duration": "2h", "intermittent": True}


class ReceiverWhiteBox(WhiteBoxModel):
    """Receiver pressure ``p`` (bar) and discharge temperature ``T`` (C); inputs motor power
    (kW), demand flow (m^3/min of free air) and ambient temperature (C)."""

    states = ("p", "T")
    inputs = ("power", "demand", "ambient")
    controlled_inputs = ("power",)  # the pressure switch starts and stops the motor
    default_parameters = {"volume": 26.0, "delivery_per_kw": 0.15, "temp_rise_per_kw": 1.1,
                          "cooling_time": 110.0}

    def derivatives(self, x, u):
        p = self.parameters
        temp = x[..., 1]
        power, demand, ambient = u[..., 0], u[..., 1], u[..., 2]
        dp = P_ATM * (p["delivery_per_kw"] * power - demand) / (60.0 * p["volume"])
        dT = (ambient + p["temp_rise_per_kw"] * power - temp) / p["cooling_time"]
        return np.stack([dp, dT], axis=-1)


class Compressor(Family):
    name = "compressor"
    title = "Intermittent air compressor (2 s)"
    description = ("start/stop pressure control, stands still outside shifts, volumetric "
                   "efficiency falling with pressure, leaks, ambient-dependent after-cooler; "
                   "white box: delivery proportional to power, no leak, 10-20 % off")
    spec = "benchmarks.zoo.families.compressor:ReceiverWhiteBox"
    columns = {"p": "pressure", "T": "discharge_temp", "power": "motor_power",
               "demand": "demand_flow", "ambient": "ambient_temp"}
    sample_interval = DT
    grid = GRID
    # held out until 2026-11-26: its healthy alarms were read to find that a two-night
    # candidate's average hid a night beyond the baseline's range (docs/design.md 4.14)
    held_out = False
    channels = ("pressure", "discharge_temp", "motor_power", "demand_flow", "ambient_temp")
    faults = (
        FaultKind("valve_wear", "volumetric efficiency down by m (relative: worn inlet valve)",
                  (0.05, 0.12)),
        FaultKind("leak", "a new leak of m m^3/min at 7 bar", (0.3, 0.8)),
        FaultKind("cooler_fouling", "after-cooler conductance down by m (relative)", (0.2, 0.45)),
        FaultKind("pressure_bias", "pressure sensor reads m bar high", (0.05, 0.15)),
    )

    def true_parameters(self, rng):
        return {"volume": spread(rng, 30.0, 0.03), "free_air": spread(rng, 6.0, 0.03),
                "ratio_loss": spread(rng, 0.02, 0.1), "leak": spread(rng, 0.25, 0.1),
                "power_base": spread(rng, 32.0, 0.03), "power_slope": spread(rng, 1.2, 0.05),
                "cooler": spread(rng, 1.0, 0.03), "cooling_time": spread(rng, 90.0, 0.05)}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        n, t, hour, total = self.clock(WARMUP)
        start = batch.uniform(5.0, 7.0)[:, None]
        end = start + batch.uniform(10.0, 14.0)[:, None]
        shift = (hour[None, :] >= start) & (hour[None, :] < end)
        demand = np.where(shift, np.clip(batch.uniform(2.5, 4.5)[:, None]
                                         + 0.8 * smooth_noise(batch, total, 300 / DT), 0.5, None),
                          0.0)
        ambient = (batch.uniform(5.0, 30.0)[:, None]
                   + 5 * np.sin(2 * np.pi * (hour - 9) / 24)[None, :]
                   + smooth_noise(batch, total, 1800 / DT, 0.5))
        wear = 1 - batch.active("valve_wear", t)
        new_leak = batch.active("leak", t)
        cooler = p["cooler"][:, None] * (1 - batch.active("cooler_fouling", t))
        pressure = np.full(len(batch), 7.0)
        temp = ambient[:, 0] + 5.0
        running = np.zeros(len(batch), dtype=bool)
        out = {k: np.empty((len(batch), n)) for k in ("p", "T", "P")}
        h = DT / SUBSTEPS
        for k in range(total):
            running = shift[:, k] & np.where(running, pressure < 7.5, pressure < 6.5)
            ratio = pressure / P_ATM
            delivery = running * p["free_air"] * wear[:, k] * (1 - p["ratio_loss"] * (ratio - 1))
            power = running * (p["power_base"] + p["power_slope"] * (pressure - P_ATM))
            leak = (p["leak"] + new_leak[:, k]) * np.sqrt(np.maximum(pressure - P_ATM, 0) / 6.0)
            rise = power * 1.25 / (cooler[:, k] * (1 + 0.01 * (ambient[:, k] - 20)))
            for _ in range(SUBSTEPS):
                pressure = pressure + h * P_ATM * (delivery - demand[:, k] - leak) / (60 * p["volume"])
                temp = temp + h * (ambient[:, k] + rise - temp) / p["cooling_time"]
            if k >= WARMUP:
                out["p"][:, k - WARMUP], out["T"][:, k - WARMUP] = pressure, temp
                out["P"][:, k - WARMUP] = power
        day = slice(WARMUP, total)
        bias = batch.active("pressure_bias", t[day])
        return {"pressure": quantise(out["p"] + bias + batch.normal((n,), 0.01), 0.01),
                "discharge_temp": quantise(out["T"] + batch.normal((n,), 0.1), 0.01),
                "motor_power": quantise(out["P"] * (1 + batch.normal((n,), 0.005)), 0.01),
                "demand_flow": quantise(demand[:, day] * (1 + batch.normal((n,), 0.01)), 0.001),
                "ambient_temp": quantise(ambient[:, day] + batch.normal((n,), 0.1), 0.01)}


FAMILY = Compressor()
