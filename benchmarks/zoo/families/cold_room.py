"""A walk-in cold room (a wholesaler's chilled store at +2 C) with an on/off condensing unit,
logged every 60 s.

True plant (5-s substeps): the room's air with its racks and the evaporator's fins (``C_a``
about 250 kJ/K), the stock on the racks (``C_p`` 3-8 MJ/K by the day's stock, unmeasured,
coupled to the air by about 90 W/K) and the evaporator coil (``C_e`` 25 kJ/K). The coil takes
the air's heat through a conductance that falls as frost builds on it (``UA_e / (1 + frost /
f0)``: frost grows with run time and with the moist air the door lets in) and gives it to the
refrigerant: ``Q_ref = Q0 (1 + 0.03 (T_e + 8)) (1 - 0.012 (T_amb - 25))`` while the
compressor runs (ramping up over about 40 s after a start), with an electrical power ``P0 (1 +
0.015 (T_amb - 25)) (1 + 0.01 (T_e + 8))`` plus the condenser fan. A thermostat on the air
sensor (30-s sensor lag) switches the compressor on at setpoint + 1 K and off at setpoint -
1 K, with a 3-min minimum off time and a 1-min minimum on time. Four electric defrosts a day
(times fixed per room, 20-30 min, 1.5 kW into the coil, the compressor and evaporator fan off)
clear the frost (the heater cut by a termination thermostat at 10 C on the coil). Walls ``UA_w (T_amb - T_a)`` (about 45 W/K), the evaporator fan's 150 W, and
the door: during working hours (6-19 h) 5-35 openings a day (by the day's trade), each 15-180 s,
letting in about 250 W/K of warm air (x 0.7-1.3 by draughts); about a third of them bring a
pallet of 100-400 kg of goods at 5-12 C (mixed into the stock) and a fork-lift and lights
(400 W while open); picking takes stock out. The machine room's temperature (the condenser's
air and the walls' outside) follows the weather, a daily cycle and the building.

Telemetry at 60 s: room air temperature (the thermostat's sensor, 0.1 C resolution, 0.08 C
noise, instantaneous), compressor electrical power (kW, the minute's mean, 0.01 kW), the door
switch (the minute's open fraction), the defrost relay (the minute's on fraction) and the
machine room's temperature (a cheap sensor: 0.5 C resolution).

The white box a user writes (:class:`ColdRoomWhiteBox`): the air (measured) and the stock
(hidden), cooling ``COP x power`` with a constant COP, walls and door as constant conductances,
defrost heat and fan heat constant; no coil node, no frost, no start-up ramp, no goods brought
in; parameters 10-20 % off.

Faults and why these magnitudes (fixed from the physics before any detection run):

* ``refrigerant_leak``: refrigeration capacity down by m and compressor power by m/3 (less mass
  flow). 10 % is a slow leak nobody notices; 30 % is a unit running nearly twice as long, that
  cannot hold the room on a hot afternoon with the door busy.
* ``condenser_fouling``: capacity down by 0.4 m and compressor power up by 0.5 m (higher head
  pressure). 25 % is a dusty condenser; 60 % is a condenser matted with fluff and grease.
* ``door_seal``: a torn or frozen door gasket: m W/K more infiltration at all times. The walls
  are about 45 W/K: 8 W/K is a worn gasket; 30 W/K (another 600 W on a warm day) is a gasket
  torn along a side.
* ``sensor_drift``: the air sensor (telemetry and thermostat) drifts by m K a day from the
  onset. 0.3 K/day is slow ageing; 1 K/day (3 K in three nights: the stock held at -1 C) is
  a failing sensor.
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 60.0
SUBSTEPS = 12
H = DT / SUBSTEPS
#: samples of warm-up: the previous evening from 18:00
WARMUP = 6 * 60
SETPOINT = 2.0


class ColdRoomWhiteBox(WhiteBoxModel):
    """Room air ``air`` (measured) and stock ``stock`` (hidden) temperatures (C); inputs
    compressor power (kW), door open fraction, defrost fraction and machine-room temperature."""

    states = ("air", "stock")
    outputs = ("air",)
    inputs = ("power", "door", "defrost", "ambient")
    controlled_inputs = ("power",)  # the thermostat switches the compressor on the air sensor
    initial_state = {"stock": 2.0}
    default_parameters = {"c_air": 2.1e5, "c_stock": 5.0e6, "ua_wall": 52.0, "ua_door": 210.0,
                          "ua_stock": 75.0, "cop": 1.75, "fan_heat": 170.0,
                          "defrost_heat": 1300.0}

    def derivatives(self, x, u):
        p = self.parameters
        air, stock = x[..., 0], x[..., 1]
        power, door, defrost, ambient = (u[..., i] for i in range(4))
        gains = ((p["ua_wall"] + p["ua_door"] * door) * (ambient - air)
                 + p["ua_stock"] * (stock - air) + p["fan_heat"] * (1 - defrost)
                 + p["defrost_heat"] * defrost - 1000.0 * p["cop"] * power)
        return np.stack([gains / p["c_air"],
                         p["ua_stock"] * (air - stock) / p["c_stock"]], axis=-1)

    def output(self, x, u):
        return x[..., :1]


def _doors(rng: np.random.Generator, steps: int, warmup_steps: int):
    """One room-day's door (open flag per substep), the goods brought in (kg and their
    temperature per substep, 0 where none) and the stock picked (kg per substep)."""
    door = np.zeros(steps)
    goods = np.zeros(steps)
    goods_temp = np.zeros(steps)
    per_hour = 3600 / H
    openings = int(rng.uniform(5, 35))
    for _ in range(openings):
        at = warmup_steps + int(rng.uniform(6.0, 19.0) * per_hour)
        length = max(int(rng.uniform(15, 180) / H), 1)
        door[at:at + length] = 1.0
        if rng.random() < 0.35:
            goods[at] = rng.uniform(100.0, 400.0)
            goods_temp[at] = rng.uniform(5.0, 12.0)
    picked = np.where(door > 0, rng.uniform(0.0, 8.0), 0.0)     # kg per open substep
    return door, goods, goods_temp, picked


class ColdRoom(Family):
    name = "cold_room"
    title = "Walk-in cold room, on/off condensing unit (60 s)"
    description = ("air, stock, frosting evaporator coil, thermostat cycling with minimum "
                   "times, four defrosts a day, door openings with goods brought in; white box: "
                   "air + hidden stock, constant COP, no coil or frost, 10-20 % off")
    spec = "benchmarks.zoo.families.cold_room:ColdRoomWhiteBox"
    columns = {"air": "room_temp", "power": "compressor_power", "door": "door_open",
               "defrost": "defrost", "ambient": "machine_room_temp"}
    sample_interval = DT
    held_out = True
    channels = ("room_temp", "compressor_power", "door_open", "defrost", "machine_room_temp")
    faults = (
        FaultKind("refrigerant_leak", "refrigeration capacity down by m and compressor power "
                  "by m/3 (relative)", (0.10, 0.30)),
        FaultKind("condenser_fouling", "capacity down by 0.4 m and compressor power up by "
                  "0.5 m (relative)", (0.25, 0.60)),
        FaultKind("door_seal", "m W/K more infiltration at all times (torn gasket)",
                  (8.0, 30.0)),
        FaultKind("sensor_drift", "the air sensor (telemetry and thermostat) drifts by m K a "
                  "day from the onset", (0.3, 1.0)),
    )

    def true_parameters(self, rng):
        return {"c_air": spread(rng, 2.5e5, 0.06), "c_coil": spread(rng, 2.5e4, 0.05),
                "ua_coil": spread(rng, 900.0, 0.05), "frost_scale": spread(rng, 3.0, 0.1),
                "q0": spread(rng, 3200.0, 0.04), "p0": spread(rng, 1.35, 0.04),
                "ua_wall": spread(rng, 45.0, 0.08), "ua_door": spread(rng, 250.0, 0.1),
                "ua_stock": spread(rng, 90.0, 0.1), "stock_kg": spread(rng, 1500.0, 0.2),
                "defrost_at": float(rng.uniform(0.0, 6.0)),
                "building": float(rng.uniform(14.0, 26.0))}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        _, ts, hs, steps = self.clock(WARMUP, SUBSTEPS)
        events = [_doors(rng, steps, WARMUP * SUBSTEPS) for rng in batch.rngs]
        door = np.stack([e[0] for e in events])
        goods, goods_temp = np.stack([e[1] for e in events]), np.stack([e[2] for e in events])
        picked = np.stack([e[3] for e in events])
        draught = batch.uniform(0.7, 1.3)
        # defrosts every 6 h from the room's own time, 20-30 min each (the controller's clock)
        length = batch.uniform(20.0, 30.0) / 60.0
        phase = (hs[None, :] - p["defrost_at"][:, None]) % 6.0
        defrost = (phase < length[:, None]).astype(float)
        # the machine room: weather, a daily cycle, the building
        weather = (p["building"] + batch.uniform(-4.0, 4.0))[:, None]
        ambient = (weather + batch.uniform(1.0, 4.0)[:, None]
                   * np.sin(2 * np.pi * (hour - 10.0) / 24.0)[None, :]
                   + smooth_noise(batch, total, 90.0, 0.6))
        stock_kg = p["stock_kg"] * batch.uniform(0.5, 1.4)
        leak = batch.active("refrigerant_leak", t)
        fouling = batch.active("condenser_fouling", t)
        seal = batch.active("door_seal", t)
        drift = batch.active("sensor_drift", t) * np.maximum(t - batch.onset[:, None], 0.0) / 86400.0

        air = np.full(size, SETPOINT) + batch.uniform(-1.0, 1.0)
        stock = air.copy()
        coil = air - 5.0
        sensed = air.copy()
        frost = batch.uniform(0.0, 1.0)
        running = np.zeros(size, dtype=bool)
        ramp = np.zeros(size)
        since = np.full(size, 1e4)
        out = {k: np.zeros((size, n)) for k in ("air", "power", "door", "defrost")}
        c_stock_per_kg = 3600.0
        for k in range(total):
            amb = ambient[:, k]
            cap_scale = (1 - leak[:, k]) * (1 - 0.4 * fouling[:, k])
            pow_scale = (1 - leak[:, k] / 3) * (1 + 0.5 * fouling[:, k])
            power_sum = np.zeros(size)
            for j in range(SUBSTEPS):
                s = k * SUBSTEPS + j
                thawing = defrost[:, s] > 0
                reading = sensed + drift[:, k]
                on_now = np.where(running, ~((reading < SETPOINT - 1.0) & (since >= 60.0)),
                                  (reading > SETPOINT + 1.0) & (since >= 180.0))
                on_now &= ~thawing
                since = np.where(on_now == running, since + H, H)
                running = on_now
                ramp = np.where(running, ramp + (1 - ramp) * (1 - np.exp(-H / 40.0)),
                                ramp * np.exp(-H / 20.0))
                q_ref = (p["q0"] * (1 + 0.03 * (coil + 8.0)) * (1 - 0.012 * (amb - 25.0))
                         * cap_scale * ramp)
                power = np.where(running, p["p0"] * (1 + 0.015 * (amb - 25.0))
                                 * (1 + 0.01 * (coil + 8.0)) * pow_scale * (0.6 + 0.4 * ramp)
                                 + 0.12, 0.0)
                fan = np.where(thawing, 0.25, 1.0)                 # natural convection only
                ua_coil = p["ua_coil"] * fan / (1 + frost / p["frost_scale"])
                open_ = door[:, s]
                infil = p["ua_door"] * draught * open_ + seal[:, k] + p["ua_wall"]
                c_stock = stock_kg * c_stock_per_kg
                # goods in (mixed into the stock), stock out
                arriving = goods[:, s] * c_stock_per_kg
                stock = (c_stock * stock + arriving * goods_temp[:, s]) / (c_stock + arriving)
                stock_kg = np.maximum(stock_kg + goods[:, s] - picked[:, s], 200.0)
                to_coil = ua_coil * (air - coil)
                to_stock = p["ua_stock"] * (air - stock)
                d_air = (infil * (amb - air) - to_coil - to_stock + 150.0 * (~thawing)
                         + 400.0 * open_) / p["c_air"]
                heater = 1500.0 * (thawing & (coil < 10.0))     # the coil's termination thermostat
                d_coil = (to_coil - q_ref + heater) / p["c_coil"]
                air = air + H * d_air
                coil = coil + H * d_coil
                stock = stock + H * to_stock / c_stock
                frost = np.where(thawing & (coil > 5.0), 0.0,
                                 frost + H / 3600.0 * (0.08 * running + 2.0 * open_))
                sensed = sensed + (air - sensed) * (1 - np.exp(-H / 30.0))
                power_sum += power
            if k >= WARMUP:
                i = k - WARMUP
                out["air"][:, i] = sensed + drift[:, k]
                out["power"][:, i] = power_sum / SUBSTEPS
        day = slice(WARMUP * SUBSTEPS, steps)
        door_min = door[:, day].reshape(size, n, SUBSTEPS).mean(axis=2)
        defrost_min = defrost[:, day].reshape(size, n, SUBSTEPS).mean(axis=2)
        return {
            "room_temp": quantise(out["air"] + batch.normal((n,), 0.08), 0.1),
            "compressor_power": quantise(out["power"] * (1 + batch.normal((n,), 0.01)), 0.01),
            "door_open": quantise(door_min, 1 / 60),
            "defrost": quantise(defrost_min, 1 / 60),
            "machine_room_temp": quantise(ambient[:, WARMUP:] + batch.normal((n,), 0.1), 0.5)}


FAMILY = ColdRoom()
