"""A district-heating substation (indirect connection) heating a block of flats, logged every
15 s by its controller.

True plant (5-s substeps; the building on the 15-s grid): the network's hot water enters at
the heat meter, whose supply sensor reads it, and reaches the plate exchanger through a
service pipe of 40-80 l (about 60 l): a plug-flow buffer whose outlet is the water that entered a pipe's volume of flow
earlier, so its transport delay is ``V / q``: about 45 s at the design flow, 2-3 minutes at a
third of it, and it loses heat to the ground (8 C) by ``exp(-delay / 8 h)``. The network's
supply temperature follows the utility's curve on the day's weather (75-100 C, lower far out
on the network), raised 3 K for the morning peak, with a slow wander (2 K, 3-h correlation)
and the quick swings of mixing upstream (0.7 K, 4-min correlation). The primary flow is set
by an equal-percentage control valve (rangeability 50, ``kvs`` about 1.7 times the design
flow) in series with the rest of the circuit (exchanger, pipes, meter: ``kr`` 2.5 times the
design flow), ``q = sqrt(dp) / sqrt(1 / kv^2 + 1 / kr^2)``, under the network's differential
pressure at the site (0.5-1.3 bar, +-10 % by the day, 4 % quick wander). The valve's motor
strokes in about 90 s; its stem follows the motor past a 0.2-% dead band (healthy packing).
The counter-flow exchanger (``UA`` about design / 11 K at design flows, each side's film
coefficient going as its flow^0.8) by its effectiveness-NTU relation, each side's outlet
lagged by its own hold-up (20 kg and 30 kg of water and plate, so 15-60 s). A PI controller
(``Kp`` about 3 %/K, ``Ti`` about 120 s, clamped integral) holds the secondary supply,
read by a sensor in a pocket (15-s lag), at the heating curve's setpoint ``22 + s (20 -
T_out, 2-h filter) + shift`` (``s`` 1.0-1.4; 35-75 C), set back 5-10 K at night (from 21-23
h to 4:30-6 h, 1.5 h later at weekends: days count from a Monday).

The secondary circuit: a constant-speed circulation pump (about design / (4.19 x 15 K)
kg/s) whose flow the thermostatic radiator valves throttle (45 % + 55 % of their opening, a
2-K proportional band around 21 C). The supply riser (0.4-0.8 m^3: 3-8 minutes) is a
plug-flow buffer to the radiators (one mixed node of water and steel, 45 kJ/K per kW of
design, emitting ``K (T_rad - T_room)^1.3``), the return riser another back to the exchanger.
The building: one air-and-structure node (time constant 30-60 h) losing ``design / 32 K``
per K to the outdoor air, with internal gains (occupancy: mornings and evenings) and solar
gains by the day's cloud. The outdoor air: the site's winter climate (-5 to 5 C), +-6 C by
the day's weather, a daily swing of 1.5-5 K peaking at 14 h, 0.8 K of 1-h wander. The
design load is 220 kW +- 15 % (at -12 C).

Telemetry at 15 s (the controller's snapshots): outdoor temperature (0.1 C, 0.1 C noise),
primary supply and return temperatures (the heat meter's matched pair: 0.01 C, 0.03 C noise),
primary flow (the meter's, m^3/h, 0.01, 0.5 % noise), the valve command (%, 0.1), the
secondary supply temperature (the controller's sensor: 0.1 C, 0.05 C noise) and the secondary
return temperature (0.1 C, 0.05 C noise).

The white box a user writes (:class:`SubstationWhiteBox`): the primary flow from the valve
command by an equal-percentage curve (rangeability 30, a full-open flow from the datasheet's
``kvs`` at an assumed 0.8 bar: no authority, no site pressure); the exchanger as two mixed
nodes (the primary and secondary outlets) exchanging ``UA`` times the difference of their
sides' arithmetic mean temperatures, a constant ``UA`` and the pump's design flow; the
primary supply as read at the meter (no pipe: the transport delay left out), the secondary
return as read. Parameters 10-20 % off.

Faults and why these magnitudes (fixed from the physics before any detection run):

* ``exchanger_fouling``: ``UA`` down by m (scale, sludge). 15 % is a season's scale on hard
  water, about 0.5 K more on the primary return at mid load; 40 % is an exchanger due for
  cleaning, 2-3.5 K more on the return (the utility's return-temperature penalty) and 6-9 %
  more primary flow for the same heat.
* ``valve_stiction``: the stem's dead band widened by m % of stroke (a packing that grips),
  the stem jumping half of it when it breaks free. 1 % makes a slow small limit cycle; 4 % a
  hunting loop (the stem jumping about 2 % at a time, the primary flow by about 0.2 m^3/h,
  the secondary supply by 0.5-1 K, minutes apart).
* ``pump_wear``: the circulation pump's flow down by m (a worn impeller, a clogging
  strainer). 10 % is a degraded pump the radiators still hide; 25 % a pump whose building
  return comes back about 2 K colder with 10-15 % less heat delivered: the rooms cool and
  the top floors complain on a cold day.
* ``supply_sensor_bias``: the heat meter's supply sensor reads m K low (a sensor pulled part
  out of its pocket, a dry pocket); not used by the controller. 1 K is a 2-3 % error on the
  billed energy (the primary's 35-45 K difference); 3 K is 7-9 %: a billing dispute.
* ``sensor_noise``: the secondary supply sensor's noise (telemetry and controller) up by m K
  r.m.s. (a corroded connector, a cable next to the pump's drive). 0.25 K is five times the
  healthy noise; 1 K makes the valve chatter.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 15.0
SUBSTEPS = 3
H = DT / SUBSTEPS
#: samples of warm-up: the previous evening from 21:00
WARMUP = 3 * 240
#: kJ/(kg K), kg/m^3 (water at 60-80 C)
CP = 4.19
RHO = 975.0
#: kW/K of flow per m^3/h
KW_PER_M3H = RHO * CP / 3600.0
DESIGN_OUTDOOR = -12.0
ROOM = 21.0
GROUND = 8.0


class SubstationWhiteBox(WhiteBoxModel):
    """Primary return and secondary supply temperatures (C) as two mixed nodes of a plate
    exchanger; the primary flow (m^3/h) from the valve command (%) by an equal-percentage
    curve; inputs the valve command, the primary supply and the secondary return (C)."""

    states = ("primary_return", "secondary_supply")
    outputs = ("primary_flow", "primary_return", "secondary_supply")
    inputs = ("valve", "primary_supply", "secondary_return")
    controlled_inputs = ("valve",)  # the PI loop sets it from the secondary supply
    default_parameters = {"flow_full_open": 6.0, "rangeability": 30.0, "ua": 17.0,
                          "c_primary": 100.0, "c_secondary": 105.0, "secondary_flow": 12.0}

    def primary_flow(self, valve):
        p = self.parameters
        return p["flow_full_open"] * p["rangeability"] ** (np.clip(valve, 0.0, 100.0) / 100.0 - 1.0)

    def derivatives(self, x, u):
        p = self.parameters
        primary_return, secondary_supply = x[..., 0], x[..., 1]
        valve, primary_supply, secondary_return = u[..., 0], u[..., 1], u[..., 2]
        primary = KW_PER_M3H * self.primary_flow(valve)             # kW/K
        secondary = KW_PER_M3H * p["secondary_flow"]
        heat = p["ua"] * ((primary_supply + primary_return) / 2
                          - (secondary_supply + secondary_return) / 2)
        return np.stack([(primary * (primary_supply - primary_return) - heat) / p["c_primary"],
                         (secondary * (secondary_return - secondary_supply) + heat)
                         / p["c_secondary"]], axis=-1)

    def output(self, x, u):
        return np.stack([self.primary_flow(u[..., 0]), x[..., 0], x[..., 1]], axis=-1)


class PlugFlow:
    """Pipes of the batch as plug-flow buffers: what enters leaves after the pipe's volume of
    flow has followed it (a transport delay of ``volume / flow``, whatever the flow does)."""

    def __init__(self, volume: np.ndarray, steps: int, filled_with: np.ndarray):
        size = len(volume)
        self.volume = volume
        #: cumulative volume entered at the end of each step, and the temperature that entered
        #: (flat, row by row: the step loop indexes them by ``row offset + step``)
        self.entered = np.zeros(size * (steps + 1))
        self.temperature = np.zeros(size * (steps + 1))
        self.first = np.arange(size) * (steps + 1)
        self.entered[self.first] = volume          # the water filling the pipe at the start
        self.temperature[self.first] = filled_with
        self.total = volume.copy()
        self.newest = self.first.copy()
        self.at = self.first.copy()

    def step(self, flow_volume: np.ndarray, inlet: np.ndarray) -> np.ndarray:
        """Let ``flow_volume`` (B,) in at ``inlet`` (B,); the temperature leaving (B,)."""
        self.newest += 1
        self.total = self.total + flow_volume
        self.entered[self.newest] = self.total
        self.temperature[self.newest] = inlet
        leaving = self.total - self.volume
        at = self.at
        while True:
            move = self.entered[at + 1] < leaving
            if not move.any():
                break
            at = at + move
        self.at = at
        low, high = self.entered[at], self.entered[at + 1]
        share = np.minimum(np.maximum((leaving - low) / np.maximum(high - low, 1e-12), 0.0), 1.0)
        before = self.temperature[at]
        return before + share * (self.temperature[at + 1] - before)


class HeatSubstation(Family):
    name = "heat_substation"
    title = "District-heating substation with a transport delay (15 s)"
    description = ("service pipe as a plug-flow delay (45 s-3 min), equal-percentage valve "
                   "with authority under PI control on a heating curve with night setback, "
                   "NTU exchanger with flow-dependent UA and hold-ups, circulation pump with "
                   "TRVs, riser delays, radiators and building; white box: two mixed nodes, "
                   "no delay, constant UA and secondary flow, 10-20 % off")
    spec = "benchmarks.zoo.families.heat_substation:SubstationWhiteBox"
    columns = {"valve": "valve_command", "primary_flow": "primary_flow",
               "primary_supply": "primary_supply_temp", "primary_return": "primary_return_temp",
               "secondary_supply": "secondary_supply_temp",
               "secondary_return": "secondary_return_temp"}
    sample_interval = DT
    held_out = True
    channels = ("outdoor_temp", "primary_supply_temp", "primary_return_temp", "primary_flow",
                "valve_command", "secondary_supply_temp", "secondary_return_temp")
    batch_size = 64
    faults = (
        FaultKind("exchanger_fouling", "the exchanger's UA down by m (relative)", (0.15, 0.40)),
        FaultKind("valve_stiction", "the valve stem's dead band widened by m % of stroke, "
                  "half of it jumped on breaking free", (1.0, 4.0)),
        FaultKind("pump_wear", "the circulation pump's flow down by m (relative)",
                  (0.10, 0.25)),
        FaultKind("supply_sensor_bias", "the heat meter's primary supply sensor reads m K low",
                  (1.0, 3.0)),
        FaultKind("sensor_noise", "the secondary supply sensor's noise (telemetry and "
                  "controller) up by m K r.m.s.", (0.25, 1.0)),
    )

    def true_parameters(self, rng):
        return {"design_kw": spread(rng, 220.0, 0.15), "ua_scale": spread(rng, 1.0, 0.06),
                "pipe_volume": float(rng.uniform(0.04, 0.08)),
                "riser_volume": float(rng.uniform(0.4, 0.8)),
                "kvs_scale": spread(rng, 1.7, 0.05), "dp": float(rng.uniform(0.5, 1.3)),
                "hold_primary": spread(rng, 20.0, 0.1), "hold_secondary": spread(rng, 30.0, 0.1),
                "kp": spread(rng, 3.0, 0.1), "ti": spread(rng, 120.0, 0.1),
                "stroke": spread(rng, 90.0, 0.1), "sensor_lag": spread(rng, 15.0, 0.1),
                "slope": float(rng.uniform(1.0, 1.4)), "shift": float(rng.uniform(-3.0, 3.0)),
                "setback": float(rng.uniform(5.0, 10.0)),
                "setback_from": float(rng.uniform(21.0, 23.0)),
                "setback_to": float(rng.uniform(4.5, 6.0)),
                "building_hours": float(rng.uniform(30.0, 60.0)),
                "climate": float(rng.uniform(-5.0, 5.0)),
                "network": float(rng.uniform(-6.0, 0.0))}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        _, ts, hs, steps = self.clock(WARMUP, SUBSTEPS)
        design = p["design_kw"]
        # -- weather and the controller's heating curve (on the 15-s grid) ---------------------
        weather = p["climate"] + batch.uniform(-6.0, 6.0)
        swing = batch.uniform(1.5, 5.0)
        outdoor = (weather[:, None] + 0.5 * swing[:, None] * np.cos(2 * np.pi * (hour - 14.0) / 24.0)
                   + smooth_noise(batch, total, 3600.0 / DT, 0.8))
        outdoor_read = outdoor + batch.normal((total,), 0.1)
        keep = np.exp(-DT / 7200.0)
        filtered, _ = lfilter([1 - keep], [1.0, -keep], outdoor_read, axis=1,
                              zi=keep * outdoor_read[:, :1])
        weekend = (batch.day % 7) >= 5
        wake = p["setback_to"] + 1.5 * weekend
        night = (hour[None, :] >= p["setback_from"][:, None]) | (hour[None, :] < wake[:, None])
        setpoint = np.clip(22.0 + p["slope"][:, None] * (20.0 - filtered) + p["shift"][:, None],
                           35.0, 75.0) - p["setback"][:, None] * night
        # -- the network: supply temperature at the meter, differential pressure -------------
        network = (np.clip(75.0 + 1.0 * (5.0 - weather), 75.0, 100.0) + p["network"])[:, None]
        supply = (network + 3.0 * ((hour >= 5.0) & (hour < 9.0))[None, :]
                  + smooth_noise(batch, total, 3 * 3600.0 / DT, 2.0))
        supply = np.repeat(supply, SUBSTEPS, axis=1) + smooth_noise(batch, steps, 240.0 / H, 0.7)
        dp = (p["dp"] * batch.uniform(0.9, 1.1))[:, None] * (
            1.0 + smooth_noise(batch, total, 600.0 / DT, 0.04))
        # -- the building's gains ---------------------------------------------------------------
        occupancy = (0.5 + np.exp(-((hour - 7.5) / 1.5) ** 2) + np.exp(-((hour - 19.0) / 2.5) ** 2))
        sun = batch.uniform(0.1, 1.0)
        daylight = np.clip(np.sin(np.pi * (hour - 8.0) / 8.0), 0.0, None) * ((hour > 8) & (hour < 16))
        gains = design[:, None] * (0.04 * batch.uniform(0.8, 1.2)[:, None] * occupancy[None, :]
                                   + 0.12 * sun[:, None] * daylight[None, :])
        # -- faults ---------------------------------------------------------------------------
        fouling = batch.active("exchanger_fouling", t)
        stiction = batch.active("valve_stiction", t)
        wear = batch.active("pump_wear", t)
        bias = batch.active("supply_sensor_bias", t)
        noisy = batch.active("sensor_noise", t)
        fault_noise = batch.normal((steps,))
        # -- sizes ------------------------------------------------------------------------------
        load_per_k = design / (20.0 - DESIGN_OUTDOOR)                    # kW/K of the building
        radiator = design / (45.0 - 20.0) ** 1.3
        c_radiator = 45.0 * design                                       # kJ/K
        c_building = load_per_k * p["building_hours"] * 3600.0
        secondary_nominal = design / (CP * 15.0) * 3600.0 / RHO          # m^3/h
        primary_design = design / (CP * 42.0) * 3600.0 / RHO
        kvs, kr = p["kvs_scale"] * primary_design, 2.5 * primary_design
        ua_design = p["ua_scale"] * design / 11.0
        # -- state at the warm-up's start: near its quasi-steady state ----------------------------
        room = ROOM + batch.uniform(-0.5, 0.5)
        demand = np.maximum(load_per_k * (room - outdoor[:, 0]) - gains[:, 0], 0.1 * design)
        rad = room + (demand / radiator) ** (1 / 1.3)
        secondary_supply = setpoint[:, 0].copy()
        secondary_return = rad.copy()
        primary_return = secondary_return + 3.0
        sensed = secondary_supply.copy()
        integral = np.full(size, 40.0)
        motor, stem = integral.copy(), integral.copy()
        service = PlugFlow(p["pipe_volume"], steps, supply[:, 0])
        riser_up = PlugFlow(p["riser_volume"], total, secondary_supply)
        riser_down = PlugFlow(p["riser_volume"], total, secondary_return)
        trv = np.clip((ROOM + 1.0 - room) / 2.0, 0.0, 1.0)
        rate = 100.0 / p["stroke"] * H
        sensor_keep = np.exp(-H / p["sensor_lag"])
        kp, ki = p["kp"], p["kp"] * H / p["ti"]
        pipe_volume, hold_p, hold_s = p["pipe_volume"], CP * p["hold_primary"], CP * p["hold_secondary"]
        out = {k: np.zeros((size, n)) for k in ("primary_return", "flow", "valve",
                                                 "secondary_supply", "secondary_return")}
        for k in range(total):
            band = 0.2 + stiction[:, k]
            ua_clean = ua_design * (1.0 - fouling[:, k])
            pump = secondary_nominal * (1.0 - wear[:, k])
            circulation = pump * (0.45 + 0.55 * trv)
            c_secondary = KW_PER_M3H * circulation
            for j in range(SUBSTEPS):
                s = k * SUBSTEPS + j
                # the controller: PI on its sensor, the integral clamped at the valve's limits
                reading = sensed + noisy[:, k] * fault_noise[:, s]
                error = setpoint[:, k] - reading
                integral = integral + ki * error
                command = kp * error + integral
                clipped = np.minimum(np.maximum(command, 0.0), 100.0)
                integral = integral - (command - clipped)
                motor = motor + np.minimum(np.maximum(clipped - motor, -rate), rate)
                slip = np.abs(motor - stem) > band
                stem = np.where(slip, motor - np.sign(motor - stem) * 0.5 * band, stem)
                # the valve in series with the circuit, under the site's pressure
                opening = np.minimum(np.maximum(stem, 0.0), 100.0) / 100.0
                kv = kvs * 50.0 ** (opening - 1.0) * np.minimum(opening / 0.02, 1.0) + 1e-3
                flow = np.sqrt(dp[:, k] / (1.0 / kv ** 2 + 1.0 / kr ** 2))        # m^3/h
                delay = pipe_volume / np.maximum(flow, 1e-3) * 3600.0
                inlet = GROUND + (service.step(flow * H / 3600.0, supply[:, s]) - GROUND) * np.exp(
                    -delay / 28800.0)
                # the exchanger: effectiveness-NTU, each outlet lagged by its hold-up
                c_primary = KW_PER_M3H * flow
                ua = ua_clean / (0.5 * (primary_design / np.maximum(flow, 1e-3)) ** 0.8
                                 + 0.5 * (secondary_nominal / circulation) ** 0.8)
                c_min, c_max = np.minimum(c_primary, c_secondary), np.maximum(c_primary, c_secondary)
                ratio = np.minimum(c_min / c_max, 0.999)
                decay = np.exp(-ua / c_min * (1.0 - ratio))
                heat = (1.0 - decay) / (1.0 - ratio * decay) * c_min * (inlet - secondary_return)
                steady_primary = inlet - heat / c_primary
                steady_secondary = secondary_return + heat / c_secondary
                keep_p = np.exp(-H * c_primary / hold_p)
                keep_s = np.exp(-H * c_secondary / hold_s)
                primary_return = steady_primary + (primary_return - steady_primary) * keep_p
                secondary_supply = steady_secondary + (secondary_supply - steady_secondary) * keep_s
                sensed = secondary_supply + (sensed - secondary_supply) * sensor_keep
            # the building on the 15-s grid (minutes of delay and hours of inertia): riser
            # up, radiators, room, riser down; the radiator valves throttle the pump's flow
            volume = circulation * DT / 3600.0
            to_radiators = riser_up.step(volume, secondary_supply)
            emitted = radiator * np.maximum(rad - room, 0.0) ** 1.3
            rad = rad + DT * (c_secondary * (to_radiators - rad) - emitted) / c_radiator
            room = room + DT * (emitted + gains[:, k] - load_per_k * (room - outdoor[:, k])
                                ) / c_building
            secondary_return = riser_down.step(volume, rad)
            trv = np.clip((ROOM + 1.0 - room) / 2.0, 0.0, 1.0)
            if k >= WARMUP:
                i = k - WARMUP
                out["primary_return"][:, i] = primary_return
                out["flow"][:, i] = flow
                out["valve"][:, i] = clipped
                out["secondary_supply"][:, i] = reading
                out["secondary_return"][:, i] = secondary_return
        day = slice(WARMUP, total)
        metered = supply[:, WARMUP * SUBSTEPS + SUBSTEPS - 1::SUBSTEPS]
        return {
            "outdoor_temp": quantise(outdoor_read[:, day], 0.1),
            "primary_supply_temp": quantise(metered - bias[:, day] + batch.normal((n,), 0.03),
                                            0.01),
            "primary_return_temp": quantise(out["primary_return"] + batch.normal((n,), 0.03), 0.01),
            "primary_flow": quantise(out["flow"] * (1.0 + batch.normal((n,), 0.005)), 0.01),
            "valve_command": quantise(out["valve"], 0.1),
            "secondary_supply_temp": quantise(out["secondary_supply"] + batch.normal((n,), 0.05),
                                              0.1),
            "secondary_return_temp": quantise(out["secondary_return"] + batch.normal((n,), 0.05),
                                              0.1)}


FAMILY = HeatSubstation()
