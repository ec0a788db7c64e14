"""An office building's air-handling unit (variable air volume, economizer, chilled-water
cooling, hot-water preheat), logged every 60 s by the building management system.

True plant (15-s substeps). The unit runs on the building's schedule: weekdays from 5:30-6:30
(the room's own start, +-10 minutes by the day) to 18:30-19:30, Saturdays 7-13 h, never on
Sundays (days count from a Monday). Off, the fan stops, the valves close and the outdoor
damper shuts; the BMS keeps logging (fan speed 0, airflow and power reading 0), so the class
declares ``running = { fan_speed = [15, 100] }`` (:data:`GRID`): the nights and Sundays are
pauses, not data.

The air path: outdoor and return air meet in the mixing box (the outdoor damper's installed
characteristic is concave, ``x = leak + (1 - leak) p / (p + a (1 - p))`` with ``a`` 0.4-0.6
and a 2-4 % leak of the shut damper; the mixed-air sensor stratifies, reading ``s (T_out -
T_ret) x (1 - x)`` off with ``s`` +-0.4 per unit), then the preheat coil (hot water, 60 kW +-
10 % at full open, a 90-s lag), the chilled-water coil and the draw-through fan, whose shaft
power heats the air; the supply sensor (a 20-s lag) sits after the fan. The cooling coil is
an effectiveness-NTU counter-flow exchanger (``UA`` about 11 kW/K at design flows, the air
side's film coefficient going as flow^0.6, the water's as flow^0.8), the water flow from an
equal-percentage valve (rangeability 50) of authority 0.4-0.6, the chilled water supplied at
7 C +0.5/-1 K by the day with a 0.3-K wander, and the latent load taken from the water's
capacity: only ``SHR`` (0.7-0.95 by the day's humidity) of it cools the air sensibly. The
coil's metal and water lag its outlet by 60-120 s.

The fan: a curve ``dp = a N^2 - b Q^2`` (N the impeller's speed, fraction of full), the filter
(about 100 Pa at the design flow, clean) and the coils and casing (about 150 Pa) before the
duct, whose VAV boxes open as the zones' sensible load asks for air: ``Q_d = L / (1.207
(T_zone - T_sp))`` (30 % of design at least), the boxes moving with a 5-minute lag and
the duct's static pressure ``p = a N^2 / (1 + (b + r) K^2)`` with ``K = Q / sqrt(p)`` their
aggregate conductance. The design airflow is 6 m^3/s +-15 %, the fan sized so the design
flow needs about 92 % speed. Shaft power ``Q (p + r Q^2) / 0.65``, divided by the belt's and
the drive's efficiencies (0.95, 0.92) and a 2 % turbulence flicker.

The controls (as a BMS programs them: separate PI loops with clamped integrals): the fan's
speed on the duct static pressure (200-350 Pa per building; the drive ramps 1 %/s), the
supply-air setpoint reset on the outdoor temperature (13 C above 20 C, 16 C below 10 C), the
chilled-water valve on the supply sensor at the setpoint, the preheat valve at the setpoint -
2 K, and the economizer on the mixed-air sensor at the setpoint - 1 K (the fan's heat),
locked out above 18-21 C (the building's dry-bulb high limit) or when the outdoor air is
warmer than the return: then the damper holds the ventilation minimum (20-30 %), as it does
whenever the loop asks for less. The damper actuator strokes in 90 s.

The zones: their sensible load is the occupancy's gains (40 kW +-20 % at full occupancy,
ramping in 7-9 h and out 16-19 h), the envelope (2 kW/K +-20 % times outdoor - 22.5 C) and the
sun (0-20 kW by the day's cloud, peaking at 14 h); the zones' temperature (the return air,
plus 0.3-0.8 K of plenum lights) is held near 22.5 C while the unit runs (a 1-h settle after
the start, warmer when the unit cannot deliver the air asked for) and floats toward the
outdoor temperature + 5 K at night (30-h time constant). The weather: the site's spring
climate (6-16 C), +-5 C by the day, a daily swing of 6-12 K peaking at 15 h, 0.7 K of 2-h
wander.

Telemetry at 60 s (the BMS's trend log: instantaneous values): outdoor, return, mixed and
supply air temperatures (0.1 C; noise 0.1, 0.05, 0.1, 0.05 C), the outdoor damper, preheat
valve and chilled-water valve commands (%, 1), the fan's speed (the drive's output, %, 1),
the supply airflow (the airflow station's, m^3/s, 0.01, 4 % noise), the duct static pressure
(Pa, 1, 4 Pa noise) and the fan's electrical power (the drive's, kW, 0.1).

The white box a user writes (:class:`AirHandlerWhiteBox`): the mixed air as the damper's
command share of outdoor air (a linear damper, no leak, no stratification); the supply air as
a first-order lag to the mixed air, plus the preheat coil's capacity times its valve, minus
the cooling coil's ``UA`` times its valve times the coil's entering air above a fixed
chilled-water temperature (at most the air's own capacity), plus a constant fan heat; the
airflow and the fan's power from the speed by the fan laws (``Q ~ N``, ``P ~ N^3``: a fixed
system curve, which a VAV duct held at a static pressure is not). The static pressure is not
modelled. Parameters 10-20 % off.

Faults and why these magnitudes (fixed from the physics before any detection run):

* ``coil_fouling``: the cooling coil's ``UA`` down by m (dirt on the fins, scale in the
  tubes). 15 % is a coil due for its yearly cleaning: the valve opens a few % more for the
  same supply air (1-2 points on a mild day); 40 % is a matted coil: the valve runs wide open
  on a warm afternoon and the supply air drifts above its setpoint (1.8-2.6 K on the warmest
  tenth of the running hours of units whose afternoons reach 24 C; nothing on a cool day, when
  the economizer does the cooling).
* ``valve_leak``: the chilled-water valve passes m of its full flow when shut (a worn seat, a
  stem that does not reach its seat). 3 % cools the air by about 0.5 K while the economizer
  holds the mixed air (a mild day); 10 % by 1.5-2 K: the preheat valve opens against it
  (simultaneous heating and cooling). (Simulated on a mild day, seed 11: the supply 0.4 /
  0.9 K colder over the running hours, the preheat valve 7 % open on average at 10 %.)
* ``supply_sensor_bias``: the supply-air sensor (logged and controlling) reads m K high. 1 K
  is a sensor out of its tolerance (the loop delivers 1 K colder air than logged: more chilled
  water, cold zones); 3 K is a sensor touching the coil's frame or in a hot spot behind the
  fan: 3 K colder supply air, every zone's reheat working.
* ``belt_slip``: the fan's impeller turns m (relative) slower than its motor (a slack, glazed
  belt); the loop raises the speed to hold the duct's pressure, the slip's power heats the
  belt. 5 % is a belt due for tensioning (3-4 points more speed); 15 % is a belt squealing at
  start and the fan out of headroom at the design flow (11-12 points more speed, at its 100 %
  limit on a warm afternoon on 4 of 10 units simulated, the static pressure sagging; 4-18 %
  more power).
* ``filter_clogging``: the filter's pressure drop at the design flow up by m Pa (clean 100
  Pa). 60 Pa is a filter half-way to its change; 170 Pa one at its final pressure drop and
  past it. (First written as 2-3 / 6-10 points more speed and 10 % / 30 % more power; the
  plant alone, before any detection run, gives about 1 point and 5 % at 60 Pa, 1-5 points and
  5-28 % at 170 Pa: the added drop goes as the flow squared, so a unit at half its design
  flow feels a quarter of it.)
* ``damper_linkage``: the outdoor damper's blades lag its actuator by m % of stroke (a
  slipped linkage on the jackshaft: the blades at ``command - m``). 10 % takes the ventilation
  minimum of 25 % to 15 % (the economizer loop hides it while it modulates); 35 % shuts the
  outdoor air at the minimum (no ventilation: a CO2 complaint) and caps free cooling at 65 %.
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 60.0
SUBSTEPS = 4
H = DT / SUBSTEPS
#: samples of warm-up: the previous evening from 21:00 (the unit off)
WARMUP = 3 * 60
#: kJ/(m^3 K) of air at about 15 C
RHO_CP = 1.207
ZONE = 22.5
#: the class's grid: the BMS logs the stopped unit; its rows are pauses
GRID = {"running": {"fan_speed": [15.0, 100.0]}}


class AirHandlerWhiteBox(WhiteBoxModel):
    """Supply air temperature (C) as a first-order lag to the mixed air plus preheat minus
    cooling plus fan heat; mixed air (C) from the damper's command, airflow (m^3/s) and fan
    power (kW) by the fan laws; inputs outdoor and return air (C), the damper, preheat valve,
    chilled-water valve and fan speed commands (%)."""

    states = ("supply_temp",)
    outputs = ("mixed_temp", "supply_temp", "airflow", "fan_power")
    inputs = ("outdoor_temp", "return_temp", "damper", "preheat_valve", "cooling_valve",
              "fan_speed")
    # the BMS's loops set them from the plant's own temperatures and pressure
    controlled_inputs = ("damper", "preheat_valve", "cooling_valve", "fan_speed")
    default_parameters = {"design_airflow": 7.0, "fan_power_full": 7.5, "ua_coil": 9.5,
                          "chilled_water": 7.0, "preheat_capacity": 50.0, "fan_heat": 0.5,
                          "lag": 120.0}

    def _mixed(self, u):
        share = np.clip(u[..., 2], 0.0, 100.0) / 100.0
        return share * u[..., 0] + (1.0 - share) * u[..., 1]

    def _airflow(self, u):
        return self.parameters["design_airflow"] * np.clip(u[..., 5], 0.0, 100.0) / 100.0

    def derivatives(self, x, u):
        p = self.parameters
        capacity = RHO_CP * np.maximum(self._airflow(u), 0.1 * p["design_airflow"])  # kW/K
        entering = self._mixed(u) + p["preheat_capacity"] * u[..., 3] / 100.0 / capacity
        cooling = np.minimum(p["ua_coil"] * np.clip(u[..., 4], 0.0, 100.0) / 100.0,
                             capacity) * np.maximum(entering - p["chilled_water"], 0.0)
        target = entering - cooling / capacity + p["fan_heat"]
        return ((target - x[..., 0]) / p["lag"])[..., None]

    def output(self, x, u):
        p = self.parameters
        speed = np.clip(u[..., 5], 0.0, 100.0) / 100.0
        return np.stack([self._mixed(u), x[..., 0], self._airflow(u),
                         p["fan_power_full"] * speed ** 3], axis=-1)


def _schedule(batch: DayBatch, start: np.ndarray, stop: np.ndarray, hour: np.ndarray,
              t: np.ndarray) -> np.ndarray:
    """Whether the unit runs at each time (B, len(t)): today's hours, yesterday's for the
    warm-up (whose times are negative)."""
    weekday = batch.day % 7
    out = np.zeros((len(batch), len(t)), dtype=bool)
    for offset, times in ((0, t >= 0), (-1, t < 0)):
        day = (weekday + offset) % 7
        begin = np.where(day == 5, 7.0, start)
        end = np.where(day == 5, 13.0, stop)
        runs = (day != 6)[:, None] & (hour[None, :] >= begin[:, None]) & (
            hour[None, :] < end[:, None])
        out |= runs & times[None, :]
    return out


class AirHandler(Family):
    name = "air_handler"
    title = "Office air-handling unit, VAV with economizer (60 s)"
    description = ("mixing box with a concave damper and stratified mixed-air sensor, preheat, "
                   "effectiveness-NTU chilled-water coil with an equal-percentage valve and "
                   "latent load, fan curve against a VAV duct held at static pressure, four PI "
                   "loops, office schedule with nights and Sundays off; white box: linear "
                   "mixing, a lagged coil linear in its valve, fan laws, 10-20 % off")
    spec = "benchmarks.zoo.families.air_handler:AirHandlerWhiteBox"
    columns = {"outdoor_temp": "outdoor_temp", "return_temp": "return_temp",
               "mixed_temp": "mixed_temp", "supply_temp": "supply_temp",
               "damper": "outdoor_damper", "preheat_valve": "preheat_valve",
               "cooling_valve": "cooling_valve", "fan_speed": "fan_speed",
               "airflow": "supply_airflow", "fan_power": "fan_power"}
    sample_interval = DT
    grid = GRID
    held_out = True
    channels = ("outdoor_temp", "return_temp", "mixed_temp", "supply_temp", "outdoor_damper",
                "preheat_valve", "cooling_valve", "fan_speed", "supply_airflow",
                "static_pressure", "fan_power")
    faults = (
        FaultKind("coil_fouling", "the cooling coil's UA down by m (relative)", (0.15, 0.40)),
        FaultKind("valve_leak", "the shut chilled-water valve passes m of its full flow",
                  (0.03, 0.10)),
        FaultKind("supply_sensor_bias", "the supply-air sensor (logged and controlling) reads "
                  "m K high", (1.0, 3.0)),
        FaultKind("belt_slip", "the fan's impeller turns m (relative) slower than its motor",
                  (0.05, 0.15)),
        FaultKind("filter_clogging", "the filter's pressure drop at the design flow up by m Pa",
                  (60.0, 170.0)),
        FaultKind("damper_linkage", "the outdoor damper's blades at its command - m % of "
                  "stroke", (10.0, 35.0)),
    )

    def true_parameters(self, rng):
        return {"design_flow": spread(rng, 6.0, 0.15), "ua_scale": spread(rng, 1.0, 0.06),
                "authority": float(rng.uniform(0.4, 0.6)),
                "preheat_kw": spread(rng, 60.0, 0.1),
                "damper_shape": float(rng.uniform(0.4, 0.6)),
                "damper_leak": float(rng.uniform(0.02, 0.04)),
                "stratification": float(rng.uniform(-0.4, 0.4)),
                "minimum_air": float(rng.uniform(20.0, 30.0)),
                "static_setpoint": float(rng.uniform(200.0, 350.0)),
                "high_limit": float(rng.uniform(18.0, 21.0)),
                "coil_lag": float(rng.uniform(60.0, 120.0)),
                "gains_kw": spread(rng, 40.0, 0.2), "envelope": spread(rng, 2.0, 0.2),
                "plenum": float(rng.uniform(0.3, 0.8)),
                "start": float(rng.uniform(5.5, 6.5)), "stop": float(rng.uniform(18.5, 19.5)),
                "climate": float(rng.uniform(6.0, 16.0))}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        # -- the weather, the chilled water, the day's humidity -------------------------------
        weather = p["climate"] + batch.uniform(-5.0, 5.0)
        swing = batch.uniform(6.0, 12.0)
        outdoor = (weather[:, None] + 0.5 * swing[:, None] * np.cos(2 * np.pi * (hour - 15.0) / 24.0)
                   + smooth_noise(batch, total, 7200.0 / DT, 0.7))
        chilled = (7.0 + batch.uniform(-1.0, 0.5))[:, None] + smooth_noise(batch, total, 30.0, 0.3)
        shr = batch.uniform(0.7, 0.95)
        # -- the schedule and the zones' load -------------------------------------------------
        jitter = batch.uniform(-1.0 / 6, 1.0 / 6)
        running = _schedule(batch, p["start"] + jitter, p["stop"] + jitter, hour, t)
        occupancy = (np.clip((hour - 7.0) / 2.0, 0.0, 1.0) * np.clip((19.0 - hour) / 3.0, 0.0, 1.0))
        occupancy = occupancy[None, :] * np.where(batch.day % 7 == 5, 0.3, 1.0)[:, None]
        sun = batch.uniform(0.0, 20.0)
        solar = np.clip(np.cos(np.pi * (hour - 14.0) / 12.0), 0.0, None) ** 2
        load = (p["gains_kw"][:, None] * occupancy + p["envelope"][:, None] * (outdoor - ZONE)
                + sun[:, None] * solar[None, :])                              # kW
        reset = 13.0 + 3.0 * np.clip((20.0 - outdoor) / 10.0, 0.0, 1.0)
        zone_wander = smooth_noise(batch, total, 3600.0 / DT, 0.2)
        # -- faults ---------------------------------------------------------------------------
        fouling = batch.active("coil_fouling", t)
        leak = batch.active("valve_leak", t)
        bias = batch.active("supply_sensor_bias", t)
        slip = batch.active("belt_slip", t)
        clogging = batch.active("filter_clogging", t)
        linkage = batch.active("damper_linkage", t)
        flicker = batch.normal((total,), 0.02)
        pressure_noise = batch.normal((total * SUBSTEPS,), 4.0)
        # -- sizes: the fan and the duct (Pa, m^3/s), the coil (kW/K) ---------------------------
        design = p["design_flow"]
        r_filter = 100.0 / design ** 2
        r_coil = 150.0 / design ** 2
        # at the design flow and the static setpoint the impeller turns at 92 %
        fan_a = (p["static_setpoint"] + 250.0 + 300.0) / 0.92 ** 2
        fan_b = 300.0 / design ** 2
        c_air_design = RHO_CP * design
        c_water_design = 130.0 / 6.0 * design / 6.0
        ua_design = 11.2 * p["ua_scale"] * design / 6.0
        # -- state at 21:00 the evening before: the unit off ---------------------------------
        zone = ZONE + batch.uniform(-2.0, 0.0)
        speed = np.zeros(size)                   # the drive's output (motor), fraction
        speed_integral = np.full(size, 0.6)
        damper_command = np.zeros(size)
        damper = np.zeros(size)                  # the actuator's position, %
        econ_integral = np.zeros(size)
        cool_integral, heat_integral = np.zeros(size), np.zeros(size)
        cool_command, heat_command = np.zeros(size), np.zeros(size)
        boxes = 0.3 * design / np.sqrt(p["static_setpoint"])
        plant_room = outdoor[:, 0] + 5.0
        mixed = plant_room.copy()
        preheated = plant_room.copy()
        coil_out = plant_room.copy()
        supply = plant_room.copy()
        sensed_supply = plant_room.copy()
        sensed_mixed = plant_room.copy()
        static = np.zeros(size)
        flow = np.zeros(size)
        power = np.zeros(size)
        out = {k: np.zeros((size, n)) for k in ("mixed", "supply", "damper", "preheat", "cooling",
                                                 "speed", "flow", "static", "power", "zone")}
        keep_coil = np.exp(-H / p["coil_lag"])
        keep_preheat = np.exp(-H / 90.0)
        keep_sensor = np.exp(-H / 20.0)
        keep_mixed_sensor = np.exp(-H / 30.0)
        keep_boxes = np.exp(-H / 300.0)
        for k in range(total):
            on = running[:, k]
            amb = outdoor[:, k]
            setpoint = reset[:, k]
            # the zones: held while the unit runs (a 1-h settle), floating while it is off
            asked = np.clip(load[:, k] / (RHO_CP * np.maximum(ZONE - setpoint, 3.0)),
                            0.3 * design, 1.2 * design)
            short = np.maximum(load[:, k] - RHO_CP * flow * np.maximum(zone - supply, 0.0), 0.0)
            zone_target = np.where(on, ZONE + zone_wander[:, k] + short / (3.0 * p["envelope"]),
                                   amb + 5.0)
            zone = zone_target + (zone - zone_target) * np.exp(
                -DT / np.where(on, 3600.0, 30 * 3600.0))
            ret = zone + p["plenum"] * on
            economize = on & (amb < p["high_limit"]) & (amb < ret)
            for j in range(SUBSTEPS):
                s = k * SUBSTEPS + j
                # the VAV boxes open to the air the zones ask for (at the setpoint's pressure)
                wanted = np.where(on, asked / np.sqrt(p["static_setpoint"]), 0.0)
                boxes = wanted + (boxes - wanted) * keep_boxes
                resistance = fan_b + r_filter + r_coil + clogging[:, k] / design ** 2
                impeller = speed * (1.0 - slip[:, k])
                static = fan_a * impeller ** 2 / (1.0 + resistance * boxes ** 2)
                flow = boxes * np.sqrt(static)
                # the static-pressure loop and the drive's ramp (1 %/s)
                error = (p["static_setpoint"] - static - pressure_noise[:, s]) / 1000.0
                speed_integral = np.where(on, speed_integral + 0.5 * error * H / 20.0, 0.6)
                command = np.clip(0.5 * error + speed_integral, 0.2, 1.0)
                speed_integral -= np.where(on, 0.5 * error + speed_integral - command, 0.0)
                target = np.where(on, command, 0.0)
                speed = speed + np.clip(target - speed, -0.01 * H, 0.01 * H)
                # the mixing box (the blades behind a slipped linkage)
                blades = np.clip(damper - linkage[:, k], 0.0, 100.0) / 100.0
                share = p["damper_leak"] + (1.0 - p["damper_leak"]) * blades / (
                    blades + p["damper_shape"] * (1.0 - blades) + 1e-9)
                mixed = np.where(flow > 0.05, share * amb + (1.0 - share) * ret,
                                 mixed + (plant_room - mixed) * 0.01)
                c_air = RHO_CP * np.maximum(flow, 0.05)
                # preheat (its capacity limited by what it can heat the air to)
                heat = np.minimum(p["preheat_kw"] * heat_command / 100.0, c_air * (45.0 - mixed))
                preheated = mixed + heat / c_air + (preheated - mixed - heat / c_air) * keep_preheat
                # the chilled-water coil: valve, effectiveness-NTU, latent share, lag
                opening = cool_command / 100.0
                phi = 50.0 ** (opening - 1.0) * np.minimum(opening / 0.02, 1.0)
                water = 1.0 / np.sqrt((1.0 - p["authority"]) + p["authority"] / np.maximum(
                    phi, 1e-6) ** 2)
                water = np.minimum(water + leak[:, k] * (1.0 - water), 1.0) * (flow > 0.05)
                c_water = shr * c_water_design * np.maximum(water, 1e-4)
                ua = ua_design * (1.0 - fouling[:, k]) / (
                    0.5 * (design / np.maximum(flow, 0.05)) ** 0.6
                    + 0.5 * (1.0 / np.maximum(water, 1e-4)) ** 0.8)
                c_min, c_max = np.minimum(c_air, c_water), np.maximum(c_air, c_water)
                ratio = np.minimum(c_min / c_max, 0.999)
                decay = np.exp(-ua / c_min * (1.0 - ratio))
                q_cool = ((1.0 - decay) / (1.0 - ratio * decay) * c_min
                          * np.maximum(preheated - chilled[:, k], 0.0))
                steady = preheated - q_cool / c_air
                coil_out = steady + (coil_out - steady) * keep_coil
                # the fan: shaft power through the belt and the drive; its heat into the air
                shaft = flow * (static + (r_filter + r_coil + clogging[:, k] / design ** 2)
                                * flow ** 2) / 0.65 / 1000.0                        # kW
                power = shaft / (1.0 - slip[:, k]) / 0.95 / 0.92
                supply = np.where(flow > 0.05, coil_out + shaft / c_air,
                                  supply + (plant_room - supply) * 0.01)
                sensed_supply = supply + (sensed_supply - supply) * keep_sensor
                reading = sensed_supply + bias[:, k]
                sensed_mixed = (mixed + p["stratification"] * (amb - ret) * share * (1 - share)
                                + (sensed_mixed - mixed - p["stratification"] * (amb - ret)
                                   * share * (1 - share)) * keep_mixed_sensor)
                # the loops: cooling at the setpoint, preheat 2 K below, economizer on the
                # mixed air 1 K below; each a PI with its integral clamped at 0-100 %
                cool_error = reading - setpoint
                cool_integral = np.where(on, cool_integral + 4.0 * cool_error * H / 240.0, 0.0)
                raw = 4.0 * cool_error + cool_integral
                cool_command = np.where(on, np.clip(raw, 0.0, 100.0), 0.0)
                cool_integral -= raw - np.where(on, cool_command, raw)
                heat_error = setpoint - 2.0 - reading
                heat_integral = np.where(on, heat_integral + 5.0 * heat_error * H / 300.0, 0.0)
                raw = 5.0 * heat_error + heat_integral
                heat_command = np.where(on, np.clip(raw, 0.0, 100.0), 0.0)
                heat_integral -= raw - np.where(on, heat_command, raw)
                econ_error = sensed_mixed - (setpoint - 1.0)
                econ_integral = np.where(economize,
                                         econ_integral + 2.0 * econ_error * H / 180.0, 0.0)
                raw = p["minimum_air"] + 2.0 * econ_error + econ_integral
                wanted_damper = np.clip(raw, p["minimum_air"], 100.0)
                econ_integral -= np.where(economize, raw - wanted_damper, 0.0)
                damper_command = np.where(economize, wanted_damper,
                                          np.where(on, p["minimum_air"], 0.0))
                damper = damper + np.clip(damper_command - damper, -100.0 / 90.0 * H,
                                          100.0 / 90.0 * H)
            plant_room = plant_room + (amb + 5.0 - plant_room) * (1 - np.exp(-DT / 7200.0))
            if k >= WARMUP:
                i = k - WARMUP
                out["mixed"][:, i] = sensed_mixed
                out["supply"][:, i] = reading
                out["damper"][:, i] = damper_command
                out["preheat"][:, i] = heat_command
                out["cooling"][:, i] = cool_command
                out["speed"][:, i] = speed
                out["flow"][:, i] = flow
                out["static"][:, i] = static
                out["power"][:, i] = power * (1.0 + flicker[:, k])
                out["zone"][:, i] = zone + p["plenum"] * on
        day = slice(WARMUP, total)
        moving = out["flow"] > 0.05
        return {
            "outdoor_temp": quantise(outdoor[:, day] + batch.normal((n,), 0.1), 0.1),
            "return_temp": quantise(out["zone"] + batch.normal((n,), 0.05), 0.1),
            "mixed_temp": quantise(out["mixed"] + batch.normal((n,), 0.1), 0.1),
            "supply_temp": quantise(out["supply"] + batch.normal((n,), 0.05), 0.1),
            "outdoor_damper": quantise(out["damper"], 1.0),
            "preheat_valve": quantise(out["preheat"], 1.0),
            "cooling_valve": quantise(out["cooling"], 1.0),
            "fan_speed": quantise(100.0 * out["speed"], 1.0),
            "supply_airflow": quantise(out["flow"] * (1.0 + batch.normal((n,), 0.04)) * moving,
                                       0.01),
            "static_pressure": quantise((out["static"] + batch.normal((n,), 4.0)) * moving, 1.0),
            "fan_power": quantise(np.maximum(out["power"], 0.0) * moving, 0.1)}


FAMILY = AirHandler()
