"""A drinking-water booster station filling a district's elevated tank, exported from SCADA
every 15 minutes.

True plant (1-min substeps): two identical fixed-speed pumps lift water from a clear well
(its level 1 m +- 0.6 m by the treatment works' schedule, unmeasured) to a tank (a cylinder,
350-450 m^2, overflow at 6.2 m) on a hill 48 m above. Each pump's curve ``H = H0 - k q^2``
(``H0`` 76 m, 60 m at 200 m^3/h), its efficiency ``0.76 (1 - 0.8 ((q - 210) / 210)^2)``
and the motor's 0.93; the system curve ``z + level + clear-well drop + r Q^2`` (``r``: 7 m at
400 m^3/h); with ``n`` pumps running the flow solves ``H0 - k (Q / n)^2 = z(level) + r Q^2``.
Each start ramps over a minute (a soft starter). The level controller (on the level sensor)
starts the duty pump below 2.6 m and stops it above 5.4 m, the assist pump below 2.0 m until
3.6 m; in the cheap night tariff (20-6 h) it fills the tank (both pumps below 4.5 m) and holds
it between 5.65 and 5.8 m; duty and assist alternate daily. Each day is simulated from noon
the day before (the zoo's contract), so the level at midnight is only as continuous as the
night's hold makes it: a few cm, more on a day whose evening peak kept the tank low.
The district draws through a metered main: a diurnal demand (morning peak 6-9 h, evening peak
18-21 h, a night minimum of 35-45 % of the mean), the day's mean 110-190 m^3/h by weather and
weekday, with minute-scale noise and a slow wander.

SCADA export every 15 min (a historian with its usual blemishes): tank level (instantaneous
pressure transducer, 1 cm, 0.5 cm noise), pumps running (the interval's mean count, from the
run-hour counters), pump flow (the station's magnetic flow meter: interval mean, 1 m^3/h,
1 % noise), outflow to the district (interval mean, 1 m^3/h, 1 % noise), station power (kW,
interval mean, 0.5 kW). About 2 % of the rows, and on 30 % of the days an outage of 1-4 hours
of the telemetry link, repeat the last good row (the historian holds the last value; a user
sees stale rows, not gaps).

The white box a user writes (:class:`PumpStationWhiteBox`): the tank level (the only state),
``A level' = flow - outflow``; the station's flow ``pumps x q_rated (1 - s (level - 4))``
(the pump curve linearised around a mid level, no interaction between the pumps, no clear
well); the power ``pumps x p0 + c x flow x head`` with a constant efficiency; parameters
10-20 % off.

Faults and why these magnitudes (fixed from the physics before any detection run):

* ``impeller_wear``: each pump's shut-off head ``H0`` down by m (relative) and its efficiency
  down by m. The static margin is about 22 m: 3 % (2.3 m) takes about 5 % of the flow; 8 %
  (6 m) about 15 % and the station runs several hours longer a day: worth a visit.
* ``tank_leak``: an unmetered outflow of m m^3/h from the tank (a leaking floor, a drain valve
  left cracked). The mean demand is about 150 m^3/h: 4 m^3/h is seepage; 15 m^3/h (360 m^3 a
  day) is water lost that an operator must find.
* ``level_drift``: the level transducer (telemetry and controller) drifts by m cm a day from the
  onset. 2 cm/day is ordinary ageing; 8 cm/day (24 cm in three nights) is a failing sensor.
* ``outflow_meter``: the district meter reads low by m (relative). 2 % is within calibration
  tolerance; 8 % is a meter whose revenue and leakage figures are wrong.
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 900.0
SUBSTEPS = 15
H = DT / SUBSTEPS
#: samples of warm-up: the previous day from noon
WARMUP = 12 * 4
LIFT = 48.0


class PumpStationWhiteBox(WhiteBoxModel):
    """Tank level ``level`` (m); outputs the level, the station's flow (m^3/h) and power (kW);
    inputs the pumps running (mean count) and the district's outflow (m^3/h)."""

    states = ("level",)
    outputs = ("level", "flow", "power")
    inputs = ("pumps", "outflow")
    controlled_inputs = ("pumps",)  # the level controller starts and stops them
    default_parameters = {"area": 360.0, "q_rated": 230.0, "slope": 0.07, "p0": 4.0,
                          "lift": 52.0, "efficiency": 0.65}

    def _flow(self, level, pumps):
        p = self.parameters
        return pumps * p["q_rated"] * (1.0 - p["slope"] * (level - 4.0))

    def derivatives(self, x, u):
        p = self.parameters
        level, pumps, outflow = x[..., 0], u[..., 0], u[..., 1]
        return ((self._flow(level, pumps) - outflow) / (3600.0 * p["area"]))[..., None]

    def output(self, x, u):
        p = self.parameters
        level, pumps = x[..., 0], u[..., 0]
        flow = self._flow(level, pumps)
        power = pumps * p["p0"] + 9.81 * (p["lift"] + level) * flow / 3600.0 / p["efficiency"]
        return np.stack([level, flow, power], axis=-1)


def _demand_shape(hour: np.ndarray, night: np.ndarray) -> np.ndarray:
    """The district's diurnal demand relative to the day's mean (B, T)."""
    peaks = (1.6 * np.exp(-((hour - 7.5) / 1.3) ** 2) + 1.2 * np.exp(-((hour - 19.5) / 1.6) ** 2)
             + 0.5 * np.exp(-((hour - 13.0) / 2.5) ** 2))
    shape = night[:, None] + peaks[None, :]
    return shape / shape.mean(axis=1, keepdims=True)


class PumpStation(Family):
    name = "pump_station"
    title = "Water booster station and tank, SCADA export (15 min)"
    description = ("two fixed-speed pumps on a tank, level control with a night tariff, "
                   "diurnal district demand, clear-well level, soft starts; 15-min SCADA rows "
                   "with stale (held) rows and link outages; white box: tank mass balance, "
                   "linearised pump curve, constant efficiency, 10-20 % off")
    spec = "benchmarks.zoo.families.pump_station:PumpStationWhiteBox"
    columns = {"level": "tank_level", "pumps": "pumps_running", "flow": "pump_flow",
               "power": "station_power", "outflow": "district_outflow"}
    sample_interval = DT
    held_out = False  # the reading rules of 2026-11-27 were chosen on it (docs/benchmarks.md)
    channels = ("tank_level", "pumps_running", "pump_flow", "district_outflow", "station_power")
    faults = (
        FaultKind("impeller_wear", "each pump's shut-off head and efficiency down by m "
                  "(relative)", (0.03, 0.08)),
        FaultKind("tank_leak", "an unmetered outflow of m m^3/h from the tank", (4.0, 15.0)),
        FaultKind("level_drift", "the level sensor (telemetry and controller) drifts by m cm "
                  "a day from the onset", (2.0, 8.0)),
        FaultKind("outflow_meter", "the district meter reads low by m (relative)", (0.02, 0.08)),
    )

    def true_parameters(self, rng):
        return {"area": float(rng.uniform(350.0, 450.0)), "h0": spread(rng, 76.0, 0.015),
                "k": spread(rng, 16.0 / 200.0 ** 2, 0.04), "r": spread(rng, 7.0 / 400.0 ** 2, 0.1),
                "eta": spread(rng, 0.76, 0.02), "lift": spread(rng, LIFT, 0.01),
                "demand": float(rng.uniform(130.0, 170.0)), "night": float(rng.uniform(0.35, 0.45))}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        _, ts, hs, steps = self.clock(WARMUP, SUBSTEPS)
        mean = p["demand"] * batch.uniform(0.8, 1.15)
        night = p["night"] * batch.uniform(0.9, 1.1)
        demand = (mean[:, None] * _demand_shape(hs, night)
                  * (1 + smooth_noise(batch, steps, 120.0, 0.08))
                  * (1 + batch.normal((steps,), 0.03)))
        clear_well = 1.0 + 0.6 * np.sin(2 * np.pi * (hs[None, :] - batch.uniform(0.0, 24.0)[:, None])
                                        / 12.0)
        duty_first = (batch.day % 2 == 0)
        wear = batch.active("impeller_wear", t)
        leak = batch.active("tank_leak", t)
        drift = (batch.active("level_drift", t) / 100.0
                 * np.maximum(t - batch.onset[:, None], 0.0) / 86400.0)
        meter = 1.0 - batch.active("outflow_meter", t)

        level = batch.uniform(3.0, 5.0)
        duty, assist = np.zeros(size, dtype=bool), np.zeros(size, dtype=bool)
        ramp = np.zeros((size, 2))
        out = {k: np.zeros((size, total)) for k in ("level", "pumps", "flow", "power", "outflow")}
        for k in range(total):
            h0 = p["h0"] * (1 - wear[:, k])
            eta_scale = 1 - wear[:, k]
            sums = {key: np.zeros(size) for key in ("pumps", "flow", "power", "outflow")}
            for j in range(SUBSTEPS):
                s = k * SUBSTEPS + j
                reading = level + drift[:, k]
                if hs[s] < 6.0 or hs[s] >= 20.0:                # the night tariff: fill and hold
                    duty = np.where(duty, reading < 5.8, reading < 5.65)
                    assist = np.where(assist, reading < 5.3, reading < 4.5)
                else:
                    duty = np.where(duty, reading < 5.4, reading < 2.6)
                    assist = np.where(assist, reading < 3.6, reading < 2.0)
                running = np.stack([duty, assist], axis=1).astype(float)
                running = np.where(duty_first[:, None], running, running[:, ::-1])
                ramp = ramp + (running - ramp) * (1 - np.exp(-H / 60.0))
                count = ramp.sum(axis=1)
                static = p["lift"] + level - clear_well[:, s]
                margin = np.maximum(h0 * np.minimum(count, 1.0) - static, 0.0)
                safe = np.maximum(count, 1e-6)
                flow = np.where(count > 1e-3, np.sqrt(margin / (p["k"] / safe ** 2 + p["r"])), 0.0)
                q = flow / safe
                eta = np.clip(p["eta"] * (1 - 0.8 * ((q - 210.0) / 210.0) ** 2), 0.2, None) * eta_scale
                head = static + p["r"] * flow ** 2
                power = np.where(count > 1e-3, 9.81 * head * flow / 3600.0 / eta / 0.93
                                 + 1.5 * count, 0.0)
                outflow = demand[:, s]
                level = np.clip(level + H * (flow - outflow - leak[:, k]) / (3600.0 * p["area"]),
                                0.2, 6.2)
                sums["pumps"] += count
                sums["flow"] += flow
                sums["power"] += power
                sums["outflow"] += outflow
            out["level"][:, k] = level + drift[:, k]
            for key, value in sums.items():
                out[key][:, k] = value / SUBSTEPS
        day = slice(WARMUP, total)
        rows = {
            "tank_level": quantise(out["level"][:, day] + batch.normal((n,), 0.005), 0.01),
            "pumps_running": quantise(out["pumps"][:, day], 0.01),
            "pump_flow": quantise(out["flow"][:, day] * (1 + batch.normal((n,), 0.01)), 1.0),
            "district_outflow": quantise(out["outflow"][:, day] * meter[:, day]
                                         * (1 + batch.normal((n,), 0.01)), 1.0),
            "station_power": quantise(out["power"][:, day], 0.5)}
        # the historian's stale rows: single ones and a link outage on some days
        stale = batch.uniform(0.0, 1.0, (n,)) < 0.02
        outage = batch.uniform(0.0, 1.0) < 0.3
        first = (batch.uniform(0.0, 20.0) * 4).astype(int)
        length = (batch.uniform(1.0, 4.0) * 4).astype(int)
        index = np.arange(n)[None, :]
        stale |= outage[:, None] & (index >= first[:, None]) & (index < (first + length)[:, None])
        stale[:, 0] = False
        held = np.where(stale, 0, index)
        held = np.maximum.accumulate(held, axis=1)
        return {c: np.take_along_axis(v, held, axis=1) for c, v in rows.items()}


FAMILY = PumpStation()
