"""A delivery truck's engine coolant loop, logged every 10 s.

True plant (simulated with 1-s substeps, every node relaxing exactly toward its neighbours'
weighted mean over a substep): the engine's metal (``C_m`` about 140 kJ/K) takes the heat the
combustion rejects (``Q``: about 0.6 of the engine's mechanical power plus idle heat) and gives
it to the jacket coolant through a film whose conductance grows with the flow (``UA_mc
(m / m_nom)^0.8``, about 4 kW/K), and a little to the air under the hood (more while driving).
A mechanical pump's flow ``m`` follows the engine speed with a pump curve (``k rpm (1 - 0.12
(rpm / 2000)^2)``), a bit less through the radiator's path than the bypass; a few grams a second
of thermosiphon with the engine off. A wax thermostat at the engine outlet (wax lag 25 s,
opening from 80-84 C to full 10 K higher, with backlash and a 1 % leak) splits the flow between
the bypass and the radiator: a hose node, then three coolant nodes along the core in cross flow
with the air (each node's heat ``C_air (1 - exp(-UA / C_air)) (T - T_air)``, air-side ``UA ~
u^0.65``), then the return hose mixes with the bypass at the pump. The air through the core
adds ram air (0.22 of the vehicle's speed plus an unmeasured head wind) and an electric fan
(6.5 m/s at full duty, 3-s spin-up) as pressures add (``u = sqrt(u_ram^2 + u_fan^2)``), plus
natural draught; the air entering is preheated by the A/C condenser on warm days (4 kW) and by
hot-air recirculation at low speed. On cold days the cab heater takes coolant heat. The fan
duty comes from the ECU: a PI loop on the measured engine-outlet temperature to 94 C (off below
20 % duty and with the engine off).

Operation: a regional delivery truck, 12-18 t by the day's payload, a shift starting 5-8 h and
ending 16-21 h, engine-off delivery stops and lunch break, urban legs (stop-and-go at 35-50
km/h, idling at lights) and highway legs (80-90 km/h) in a mix that differs by day, an
unmeasured road grade; the engine power from the road load, the engine speed from a gear
pattern. Climate per truck (2-28 C), weather per day, a daily cycle. The 1-s profile is
simulated; the logger samples engine speed, vehicle speed and fan duty every 10 s and averages
the ECU's heat estimate (from the fuel rate: 4 % per-truck calibration error, 3 % slow error,
1 % noise) over the interval. Telemetry: engine-outlet and radiator-outlet coolant temperature
(0.1 C, 0.15-0.2 C noise), heat load (kW), engine speed (rpm), fan duty (1/250), vehicle speed
(m/s), ambient temperature.

The white box a user writes (:class:`CoolantLoopWhiteBox`): three nodes (metal, hidden; engine
coolant; a single lumped radiator whose outlet is its state), flow proportional to engine
speed, a static smooth thermostat curve 1 K off, constant metal-coolant conductance, air-side
conductance linear in vehicle speed and fan duty, a constant loss of the block to ambient; no
hoses, no A/C or recirculation preheat, no cab heater, no wind; 10-20 % off.

Faults and why these magnitudes (fixed from the physics before any detection run):

* ``radiator_fouling``: air-side conductance down by m and air flow by m/2 (insects, dust, bent
  fins). 15 % is a season's dirt nobody notices; 40 % is a core an engineer calls clogged: the
  thermostat runs wide open and the fan runs on every hot climb.
* ``pump_wear``: coolant flow down by m at every speed (impeller erosion, a slipping belt).
  15 % is mild wear; 35 % is a pump due for replacement (the engine's outlet-to-inlet rise
  grows by half).
* ``coolant_sensor_bias``: the engine-outlet sensor (telemetry and the fan loop) reads m K high.
  1 K is within a sensor's tolerance; 3 K is clearly a faulty sensor or connector.
* ``radiator_sensor_noise``: the radiator-outlet sensor's noise x (1 + m): doubled (a worn
  connector) and five-fold (a chafed lead picking up interference).
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 10.0
#: substeps of 1 s (the drive cycle's own resolution)
SUBSTEPS = 10
#: samples of warm-up: the previous evening, from 19:00
WARMUP = 5 * 360
CP = 3500.0            # J/(kg K), 50 % glycol
CP_AIR, RHO_AIR = 1006.0, 1.2
CORE_AREA = 0.40       # m^2
FAN_SET, FAN_KP, FAN_KI = 93.0, 0.15, 0.004


class CoolantLoopWhiteBox(WhiteBoxModel):
    """Engine metal ``metal`` (hidden), engine-outlet coolant ``coolant`` and radiator-outlet
    ``radiator`` temperatures (C); inputs heat load (kW), engine speed (rpm), fan duty (0-1),
    vehicle speed (m/s) and ambient temperature (C)."""

    states = ("metal", "coolant", "radiator")
    outputs = ("coolant", "radiator")
    inputs = ("heat", "rpm", "fan", "speed", "ambient")
    controlled_inputs = ("fan",)  # the ECU's fan loop sets it from the coolant temperature
    initial_state = {"metal": 80.0}
    default_parameters = {"c_metal": 1.2e5, "c_coolant": 4.0e4, "c_radiator": 5.0e4,
                          "ua_metal": 3500.0, "flow_per_rpm": 1.3e-3, "cp": 3600.0,
                          "thermostat_mid": 88.0, "thermostat_width": 4.0,
                          "ua_still": 250.0, "ua_per_speed": 100.0, "ua_fan": 2600.0,
                          "ua_block": 60.0}

    def derivatives(self, x, u):
        p = self.parameters
        metal, coolant, radiator = x[..., 0], x[..., 1], x[..., 2]
        heat, rpm, fan, speed, ambient = (u[..., i] for i in range(5))
        opening = 0.5 * (1.0 + np.tanh((coolant - p["thermostat_mid"]) / p["thermostat_width"]))
        through = p["cp"] * p["flow_per_rpm"] * rpm * opening          # W/K via the radiator
        film = p["ua_metal"] * (metal - coolant)
        air = p["ua_still"] + p["ua_per_speed"] * speed + p["ua_fan"] * fan
        d_metal = (1000.0 * heat - film - p["ua_block"] * (metal - ambient)) / p["c_metal"]
        d_coolant = (film + through * (radiator - coolant)) / p["c_coolant"]
        d_radiator = (through * (coolant - radiator) - air * (radiator - ambient)) / p["c_radiator"]
        return np.stack([d_metal, d_coolant, d_radiator], axis=-1)


def _profile(rng: np.random.Generator, seconds: int, warmup_s: int):
    """One truck-day's 1-s profile over the warm-up and the day: vehicle speed (m/s), engine
    on (bool) and the true road grade is drawn by the caller. The warm-up is the previous
    evening's last hours of the shift."""
    v = np.zeros(seconds)
    on = np.zeros(seconds, dtype=bool)
    highway = rng.uniform(0.15, 0.75)               # the day's share of highway legs

    def stint(begin: int, end: int):
        t = begin
        while t < end:
            if rng.random() < highway:               # a highway leg
                target = rng.uniform(21.0, 25.0)
                cruise = int(rng.uniform(300, 2400))
            else:                                    # an urban block
                target = rng.uniform(9.0, 14.0)
                cruise = int(rng.uniform(10, 90))
            up = max(int(target / rng.uniform(0.4, 0.8)), 1)
            down = max(int(target / rng.uniform(0.6, 1.2)), 1)
            if end - t < up + down + 10:
                break                                # too short for a leg: the shift ends
            cruise = max(min(cruise, end - t - up - down), 0)   # back to a stop by the end
            wobble = np.cumsum(rng.normal(0.0, 0.05, cruise))
            if cruise:
                wobble -= np.linspace(0.0, wobble[-1], cruise)
            leg = np.concatenate([np.linspace(0.0, target, up + 1)[1:],
                                  np.clip(target + wobble, 0.5, None),
                                  np.linspace(target, 0.0, down + 1)[1:]])
            idle = int(rng.uniform(5, 60) if rng.random() < 0.8 else rng.uniform(60, 240))
            leg = np.concatenate([leg, np.zeros(idle)])
            stop = min(end, t + len(leg))
            v[t:stop] = leg[:stop - t]
            on[t:stop] = True
            t = stop
            if rng.random() < 0.04:                  # a delivery: engine off 10-40 min
                t += int(rng.uniform(600, 2400))

    h = 3600
    # the previous evening: driving until 19:30-21:00 (warm-up starts at 19:00 the day before)
    stint(0, int(rng.uniform(0.5, 2.0) * h))
    start = warmup_s + int(rng.uniform(5.0, 8.0) * h)
    lunch = warmup_s + int(rng.uniform(11.5, 13.0) * h)
    back = lunch + int(rng.uniform(0.5, 1.0) * h)
    end = warmup_s + int(rng.uniform(16.0, 21.0) * h)
    stint(start, lunch)
    stint(back, end)
    return v, on


class CoolingLoop(Family):
    name = "cooling_loop"
    title = "Truck engine coolant loop (10 s)"
    description = ("engine metal, jacket, hoses, wax thermostat with lag and backlash, 3-node "
                   "cross-flow radiator with ram air and PI fan loop, A/C preheat, cab heater, "
                   "delivery-truck duty; white box: 3 lumped nodes (metal hidden), static "
                   "thermostat, linear air side, 10-20 % off")
    spec = "benchmarks.zoo.families.cooling_loop:CoolantLoopWhiteBox"
    columns = {"coolant": "coolant_out_temp", "radiator": "radiator_out_temp",
               "heat": "heat_load", "rpm": "engine_speed", "fan": "fan_duty",
               "speed": "vehicle_speed", "ambient": "ambient_temp"}
    sample_interval = DT
    held_out = True
    channels = ("coolant_out_temp", "radiator_out_temp", "heat_load", "engine_speed",
                "fan_duty", "vehicle_speed", "ambient_temp")
    faults = (
        FaultKind("radiator_fouling", "radiator air-side conductance down by m and its air "
                  "flow by m/2 (relative)", (0.15, 0.4)),
        FaultKind("pump_wear", "coolant pump flow down by m (relative)", (0.15, 0.35)),
        FaultKind("coolant_sensor_bias", "engine-outlet temperature sensor reads m K high "
                  "(telemetry and the fan loop)", (1.0, 3.0)),
        FaultKind("radiator_sensor_noise", "radiator-outlet temperature noise x (1 + m)",
                  (1.0, 4.0)),
    )

    def true_parameters(self, rng):
        return {"c_metal": spread(rng, 1.4e5, 0.05), "c_jacket": spread(rng, 4.5e4, 0.05),
                "c_hose": spread(rng, 7.5e3, 0.05), "c_core": spread(rng, 1.45e4, 0.05),
                "ua_metal": spread(rng, 4000.0, 0.05), "pump": spread(rng, 1.6e-3, 0.04),
                "ua_core": spread(rng, 4000.0, 0.05), "ram": spread(rng, 0.22, 0.05),
                "fan_air": spread(rng, 6.5, 0.04), "t_open": spread(rng, 82.0, 0.012),
                "block_loss": spread(rng, 40.0, 0.1), "cab_heater": spread(rng, 80.0, 0.1),
                "mass": spread(rng, 11500.0, 0.03), "cda": spread(rng, 5.5, 0.05),
                "q_scale": spread(rng, 1.0, 0.04), "climate": float(rng.uniform(2.0, 28.0))}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        _, ts, hs, seconds = self.clock(WARMUP, SUBSTEPS)             # day-seconds, 1 s
        profiles = [_profile(rng, seconds, WARMUP * SUBSTEPS) for rng in batch.rngs]
        v = np.stack([a for a, _ in profiles])
        on = np.stack([b for _, b in profiles])
        # road load -> engine power -> heat; gears -> engine speed
        grade = smooth_noise(batch, seconds, 120.0, 0.02)
        mass = (p["mass"] + batch.uniform(500.0, 6500.0))[:, None]       # the day's payload
        accel = np.gradient(v, axis=1)
        wheel = (mass * (accel + 9.81 * (0.007 + grade)) * (v > 0.1)
                 + 0.5 * RHO_AIR * p["cda"][:, None] * v ** 2) * v
        mech = np.where(on, np.clip(wheel / 0.9, 0.0, 2.2e5) + 5000.0, 0.0)
        gear_rpm = np.where(v < 18.0, 1100.0 + 600.0 * ((v / 2.6) % 1.0), 62.0 * v)
        rpm = np.where(on, np.where(v > 0.5, gear_rpm, 650.0), 0.0)
        rpm = np.where(on, rpm * (1 + 0.01 * smooth_noise(batch, seconds, 5.0)), 0.0)
        heat = np.where(on, 0.6 * mech + 4000.0 * rpm / 650.0, 0.0)
        # weather
        weather = (p["climate"] + batch.uniform(-5.0, 5.0))[:, None]
        ambient = (weather + batch.uniform(2.0, 6.0)[:, None]
                   * np.sin(2 * np.pi * (hour - 9.0) / 24.0)[None, :]
                   + smooth_noise(batch, total, 3600 / DT, 0.5))
        wind = smooth_noise(batch, total, 300 / DT, 2.0)
        # faults, per sample
        fouling = batch.active("radiator_fouling", t)
        wear = batch.active("pump_wear", t)
        bias = batch.active("coolant_sensor_bias", t)

        metal = ambient[:, 0] + 10.0
        jacket, hose, ret = metal.copy(), metal.copy(), metal.copy()
        core = np.stack([metal] * 3)
        wax, opening, spin, integral = metal.copy(), np.zeros(size), np.zeros(size), np.zeros(size)
        out = {k: np.empty((size, n)) for k in ("jacket", "radiator", "fan", "heat")}
        h = 1.0
        for k in range(total):
            amb = ambient[:, k]
            ua_core = p["ua_core"] * (1 - fouling[:, k]) / 3.0
            air_block = 1 - 0.5 * fouling[:, k]
            cab = np.where(amb < 12.0, p["cab_heater"], 0.0)
            ac = np.where(amb > 22.0, 4000.0, 0.0)
            heat_sum = np.zeros(size)
            duty = np.zeros(size)
            for j in range(SUBSTEPS):
                s = k * SUBSTEPS + j
                running = on[:, s]
                # the ECU's fan loop on the measured outlet temperature (1 s)
                error = jacket + bias[:, k] - FAN_SET
                integral = np.where(running, np.clip(integral + FAN_KI * error * h, -0.3, 1.0), 0.0)
                command = np.clip(FAN_KP * error + integral, 0.0, 1.0)
                duty = np.where(running & (command >= 0.2), command, 0.0)
                spin = spin + (duty - spin) * (1 - np.exp(-h / 3.0))
                # pump and thermostat
                r = rpm[:, s]
                flow = p["pump"] * r * (1 - 0.12 * (r / 2000.0) ** 2) * (1 - 0.08 * opening)
                flow = np.maximum(flow * (1 - wear[:, k]), 0.0) + 0.01
                wax = wax + (jacket - wax) * (1 - np.exp(-h / 25.0))
                target = np.clip((wax - p["t_open"]) / 10.0, 0.0, 1.0)
                opening = np.clip(opening, target - 0.03, target + 0.03)
                share = 0.01 + 0.99 * opening
                g_rad = CP * flow * share                  # W/K of advection through the core
                g_all = CP * flow
                # air through the core
                ram = p["ram"] * np.maximum(v[:, s] + wind[:, k] * (v[:, s] > 1.0), 0.0)
                u_air = (np.sqrt(ram ** 2 + (p["fan_air"] * spin) ** 2) + 0.3) * air_block
                c_air = RHO_AIR * CORE_AREA / 3.0 * u_air * CP_AIR
                g_air = c_air * (1 - np.exp(-ua_core * (u_air / 5.0) ** 0.65 / c_air))
                t_air = amb + np.minimum(ac * running / (3 * c_air) + 2.5 * np.exp(-v[:, s] / 4.0)
                                         * running, 15.0)
                # metal: heat in, film to the jacket, loss to the air under the hood
                film = p["ua_metal"] * (flow / 2.1) ** 0.8 + 30.0
                loss = p["block_loss"] * (1 + 0.1 * v[:, s])
                q = heat[:, s]
                metal = _relax(metal, p["c_metal"], h, (film, jacket), (loss, amb), q)
                # jacket: film from the metal, return flow in, cab heater out
                jacket = _relax(jacket, p["c_jacket"], h, (film, metal), (g_all, ret),
                                (cab * running, amb))
                # hose to the core, the core's three nodes, the return hose (mixing with bypass)
                hose = _relax(hose, p["c_hose"], h, (g_rad, jacket), (8.0, amb))
                upstream = hose
                for i in range(3):
                    core[i] = _relax(core[i], p["c_core"], h, (g_rad, upstream), (g_air, t_air))
                    upstream = core[i]
                mixed = (g_rad * core[2] + (g_all - g_rad) * jacket) / g_all
                ret = _relax(ret, p["c_hose"], h, (g_all, mixed), (8.0, amb))
                heat_sum += q
            if k >= WARMUP:
                i = k - WARMUP
                out["jacket"][:, i], out["radiator"][:, i] = jacket, core[2]
                out["fan"][:, i], out["heat"][:, i] = duty, heat_sum / SUBSTEPS
        day = slice(WARMUP, total)
        sampled = slice(WARMUP * SUBSTEPS + SUBSTEPS - 1, seconds, SUBSTEPS)  # at sample time
        estimate = (out["heat"] / p["q_scale"][:, None]
                    * (1 + 0.03 * smooth_noise(batch, n, 600 / DT))
                    * (1 + batch.normal((n,), 0.01)))
        noise_r = 0.2 * (1 + batch.active("radiator_sensor_noise", t[day]))
        return {
            "coolant_out_temp": quantise(out["jacket"] + bias[:, day] + batch.normal((n,), 0.15), 0.1),
            "radiator_out_temp": quantise(out["radiator"] + batch.normal((n,), 1.0) * noise_r, 0.1),
            "heat_load": quantise(estimate / 1000.0, 0.1),
            "engine_speed": quantise(rpm[:, sampled], 1.0),
            "fan_duty": quantise(out["fan"], 1 / 250),
            "vehicle_speed": quantise(v[:, sampled] + batch.normal((n,), 0.03)
                                      * (v[:, sampled] > 0.5), 0.01),
            "ambient_temp": quantise(ambient[:, day] + batch.normal((n,), 0.2), 0.1)}


def _relax(temp, capacity, h, *links):
    """One node over ``h`` seconds with its neighbours held: it relaxes exactly toward their
    conductance-weighted mean (plus a heat source ``q`` given as a bare array)."""
    conductance, weighted, source = 0.0, 0.0, 0.0
    for link in links:
        if isinstance(link, tuple):
            g, other = link
            conductance = conductance + g
            weighted = weighted + g * other
        else:
            source = source + link
    conductance = np.maximum(conductance, 1e-9)
    equilibrium = (weighted + source) / conductance
    return equilibrium + (temp - equilibrium) * np.exp(-h * conductance / capacity)


FAMILY = CoolingLoop()
