"""An air-to-water heat pump heating a detached house through radiators, logged every 30 s by
its controller, as autumn turns to winter.

True plant (10-s substeps; the controller and the house on the 30-s grid). The outdoor air:
the site's climate (-3 to 3 C) plus 8 K on the first simulated day, falling by 0.4 K a day
(days count from the first simulated day: over a zoo run's 20 days the daily mean falls
8 K, so the scored nights are colder than the baseline's days), +-3 K by the day's weather,
a daily swing of 2-6 K peaking at 14 h and 0.7 K of 1-h wander; the relative humidity
65-98 % by the day, 8 points higher before dawn.

The unit: a fixed-speed compressor. While it heats, its heat to the water is ``Q = Q7 (1 +
0.025 (T_evap - 1))`` (``Q7`` about 9 kW at 7 C outdoor air and a 1-C evaporator) and its
COP ``0.52 T_cond / (T_cond - T_evap)`` (kelvin; ``T_cond`` the condenser water's outlet
+ 3 K; ``T_evap`` the outdoor air less the coil's approach, 6 K at the fan's healthy air
flow, growing with the ice on the coil), so its electrical power ``Q / COP``: about 2 kW and
a COP of 4.4 at 7 C / 35 C, 2.5 at -12 C / 45 C. After a start the heat comes up with a
1-min lag and the power with 20 s. The coil ices while the compressor runs with the coil
below 0 C and the air's dew point (``T_out - 20 (1 - RH)``) above the coil: at a rate of
0.22 h^-1 per kelvin of that difference, times ``exp(0.07 T_out)`` (the air's water
content); a full coil (ice 1) lowers the evaporator by a further 4.8 K and the heat by a
quarter. At a full coil the unit defrosts by reversing its 4-way valve: the fan stops, the
compressor runs at 75 % of its nominal power and takes about 45 % of ``Q7`` from the water
until the ice is gone (4 minutes from a full coil) and one more minute of dripping; then it
heats again (a cold start, the heat's lag from a third). Humid days near 0-5 C defrost
every 40-90 minutes of running; dry or mild days not at all.

The controller: degree-minutes (as Nordic units do): the supply sensor's reading less the
heating curve's setpoint ``22 + s (20 - T_out, 1-h filter) + 2 (21 - T_room)`` (``s``
0.5-0.8, clamped to 25-55 C), integrated per minute; the compressor starts at -60
degree-minutes and stops at 0, with a minimum run of 10 minutes and a minimum off time of
8 (a defrost finishes first); the integral is held during a defrost and clamped to [-600,
100].

The water: a constant-speed circulation pump (0.30 kg/s +- 10 %, always running); the
condenser's outlet (the supply sensor) follows ``return + Q / (c m)`` with a 40-s hold-up;
the radiators and pipes as one mixed node (500-800 kJ/K) emitting ``K (T_w - T_room)^1.3``
(sized to give the design load at 40 C mean water) whose outlet is the return. The house:
one node (time constant 40-70 h) losing ``UA`` (5 kW +- 15 % at -10 C, so 0.16 kW/K) to
the outdoor air, with internal gains (0.3 kW, more in the morning and evening) and sun by
the day's cloud.

Telemetry at 30 s (the controller's snapshots): outdoor temperature (the unit's sensor: 0.1
C, 0.1 C noise), supply and return water temperatures (0.1 C, 0.05 C noise), compressor
electrical power (kW, 0.01, 1 % noise; exactly 0 when it is off), room temperature (the
room unit: 0.1 C, 0.05 C noise) and the defrost flag as the controller logs it (0 or 1).

The white box a user writes (:class:`HeatPumpWhiteBox`): the water as one node (the mean of
supply and return: supply and return are that mean +- half the heat over ``c m``) and the
house as another; the heat from the electrical power by a COP linear in the outdoor
temperature (a datasheet's two points at 35 C water: 3.2 at 0 C, 0.08 a kelvin), a
defrost as a constant heat taken from the water while the flag is set; radiators linear,
no gains, no start-up lag, no ice; parameters 10-20 % off. The compressor power and the
defrost flag are set by the controller (``controlled_inputs``). No grid line: the unit logs
all day, the circulation pump never stops and the house is heated all day; the compressor
off (power exactly 0) is a state of the model (no heat), not a pause, and a model of the
running compressor alone would leave out the off-cycles that say how the house loses heat.

Faults and why these magnitudes (fixed from the physics before any detection run):

* ``refrigerant_undercharge``: the heat down by m and the COP by m/2 (so the power by about
  m/2). 10 % is a slow leak a season old; 25 % a unit that runs 30-40 % longer and can no
  longer hold the house on the coldest nights.
* ``fan_degradation``: the outdoor fan's air flow down by m (a worn bearing, a coil blocked
  by leaves): the coil's approach grows as ``1 / (1 - m)^0.8`` (6 K to 7.6 K at 25 %, 10.4 K
  at 50 %), lowering the evaporator, the heat and the COP and icing the coil faster.
* ``valve_leak``: the 4-way valve leaks hot gas to the suction side: the heat to the water
  down by m at the same power. 5 % is a valve beginning to leak; 15 % a valve a technician
  hears hissing.
* ``supply_sensor_drift``: the supply sensor (telemetry and controller) reads low by m K per
  day from the onset. 0.3 K/day is a sensor ageing in its pocket; 1 K/day a failing one (3 K
  in three nights: the controller heats the water 3 K hotter, the COP falls).
* ``pump_flow_loss``: the circulation pump's flow down by m (a clogging strainer, air in the
  loop, a failing pump). 20 % widens the supply-return difference from about 7 to 9 K; 45 %
  to 13 K, lifting the condenser and lowering the COP.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 30.0
SUBSTEPS = 3
H = DT / SUBSTEPS
#: samples of warm-up: the previous day from 12:00
WARMUP = 12 * 120
#: kJ/(kg K)
CP = 4.19
KELVIN = 273.15
ROOM = 21.0
DESIGN_OUTDOOR = -10.0
#: K a day the daily mean outdoor temperature falls (autumn into winter)
SEASONAL_FALL = 0.4
#: the coil's approach at the healthy fan's air flow (K), its extra at a full coil
APPROACH = 6.0
ICE_APPROACH = 0.8
#: ice growth per hour per kelvin of dew point above the coil; melt time of a full coil (s)
ICING_RATE = 0.22
MELT_SECONDS = 240.0
DRIP_SECONDS = 60.0
MIN_RUN, MIN_OFF = 600.0, 480.0


class HeatPumpWhiteBox(WhiteBoxModel):
    """The heating water's mean temperature and the room temperature (C) as two nodes; the
    supply and return (C) the water's mean +- half the heat over the flow; the heat from the
    compressor's power (kW) by a COP linear in the outdoor temperature (C), less a constant
    heat while the defrost flag is set."""

    states = ("water", "room")
    outputs = ("supply", "return_water", "room")
    inputs = ("power", "outdoor", "defrost")
    # the degree-minute controller starts and stops the compressor on the supply sensor and
    # the unit decides when to defrost
    controlled_inputs = ("power", "defrost")
    default_parameters = {"cop_at_0": 3.2, "cop_slope": 0.08, "flow": 0.33,
                          "c_water": 800.0, "emitter": 0.40, "ua_house": 0.19,
                          "c_house": 2.6e4, "defrost_heat": 3.5}

    def heat(self, u):
        """Heat to the water (kW)."""
        p = self.parameters
        power, outdoor, defrost = u[..., 0], u[..., 1], u[..., 2]
        cop = p["cop_at_0"] + p["cop_slope"] * outdoor
        return cop * power * (1.0 - defrost) - p["defrost_heat"] * defrost

    def derivatives(self, x, u):
        p = self.parameters
        water, room = x[..., 0], x[..., 1]
        emitted = p["emitter"] * (water - room)
        return np.stack([(self.heat(u) - emitted) / p["c_water"],
                         (emitted - p["ua_house"] * (room - u[..., 1])) / p["c_house"]],
                        axis=-1)

    def output(self, x, u):
        half = self.heat(u) / (2.0 * CP * self.parameters["flow"])
        return np.stack([x[..., 0] + half, x[..., 0] - half, x[..., 1]], axis=-1)


class HeatPump(Family):
    name = "heat_pump"
    title = "Air-to-water heat pump cycling and defrosting as winter comes (30 s)"
    description = ("fixed-speed compressor switched by a degree-minute controller (minimum "
                   "run and off times), COP falling with the lift, coil icing with humidity "
                   "and reverse-cycle defrosts, outdoor temperature falling 0.4 K a day; "
                   "white box: two nodes, COP linear in the outdoor temperature, defrost a "
                   "constant heat, 10-20 % off")
    spec = "benchmarks.zoo.families.heat_pump:HeatPumpWhiteBox"
    columns = {"supply": "supply_temp", "return_water": "return_temp", "room": "room_temp",
               "power": "compressor_power", "outdoor": "outdoor_temp", "defrost": "defrost"}
    sample_interval = DT
    held_out = True
    channels = ("outdoor_temp", "supply_temp", "return_temp", "compressor_power", "room_temp",
                "defrost")
    batch_size = 64
    faults = (
        FaultKind("refrigerant_undercharge", "the heat down by m and the COP by m/2 "
                  "(relative)", (0.10, 0.25)),
        FaultKind("fan_degradation", "the outdoor fan's air flow down by m (relative): the "
                  "coil's approach times 1 / (1 - m)^0.8, more icing", (0.25, 0.50)),
        FaultKind("valve_leak", "the 4-way valve leaks: the heat to the water down by m at "
                  "the same power", (0.05, 0.15)),
        FaultKind("supply_sensor_drift", "the supply sensor (telemetry and controller) reads "
                  "low by m K per day from the onset", (0.3, 1.0)),
        FaultKind("pump_flow_loss", "the circulation pump's flow down by m (relative)",
                  (0.20, 0.45)),
    )

    def true_parameters(self, rng):
        return {"q7": spread(rng, 9.0, 0.08), "design_kw": spread(rng, 5.0, 0.15),
                "flow": spread(rng, 0.30, 0.10), "c_water": float(rng.uniform(500.0, 800.0)),
                "house_hours": float(rng.uniform(40.0, 70.0)),
                "slope": float(rng.uniform(0.5, 0.8)), "climate": float(rng.uniform(-3.0, 3.0)),
                "eta": spread(rng, 0.52, 0.04), "condenser_lag": spread(rng, 40.0, 0.1)}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        # -- weather (on the 30-s grid) -----------------------------------------------------
        mean = p["climate"] + 8.0 - SEASONAL_FALL * batch.day + batch.uniform(-3.0, 3.0)
        swing = batch.uniform(2.0, 6.0)
        outdoor = (mean[:, None] + 0.5 * swing[:, None] * np.cos(2 * np.pi * (hour - 14.0) / 24.0)
                   + smooth_noise(batch, total, 3600.0 / DT, 0.7))
        humidity = np.clip(batch.uniform(0.65, 0.98)[:, None]
                           + 0.08 * np.cos(2 * np.pi * (hour - 4.0) / 24.0)[None, :], 0.3, 1.0)
        dew_point = outdoor - 20.0 * (1.0 - humidity)
        outdoor_read = outdoor + batch.normal((total,), 0.1)
        keep = np.exp(-DT / 3600.0)
        filtered, _ = lfilter([1 - keep], [1.0, -keep], outdoor_read, axis=1,
                              zi=keep * outdoor_read[:, :1])
        # -- the house's gains ----------------------------------------------------------------
        occupancy = 0.3 + 0.3 * (np.exp(-((hour - 7.5) / 1.5) ** 2)
                                 + np.exp(-((hour - 19.0) / 2.5) ** 2))
        daylight = np.clip(np.sin(np.pi * (hour - 8.0) / 8.0), 0.0, None) * ((hour > 8) & (hour < 16))
        gains = (batch.uniform(0.8, 1.2)[:, None] * occupancy[None, :]
                 + 1.2 * batch.uniform(0.0, 1.0)[:, None] * daylight[None, :])
        # -- faults --------------------------------------------------------------------------
        undercharge = batch.active("refrigerant_undercharge", t)
        fan = batch.active("fan_degradation", t)
        leak = batch.active("valve_leak", t)
        drift_rate = batch.active("supply_sensor_drift", t)
        drift = drift_rate * np.maximum(t[None, :] - batch.onset[:, None], 0.0) / 86400.0
        flow_loss = batch.active("pump_flow_loss", t)
        # -- sizes -------------------------------------------------------------------------------
        ua_house = p["design_kw"] / (ROOM - DESIGN_OUTDOOR)
        c_house = ua_house * p["house_hours"] * 3600.0
        emitter = p["design_kw"] / (40.0 - ROOM) ** 1.3
        q7, eta = p["q7"], p["eta"]
        nominal_power = q7 / (eta * (38.0 + KELVIN) / 37.0)
        condenser_keep = np.exp(-H / p["condenser_lag"])
        heat_keep, power_keep = np.exp(-H / 60.0), np.exp(-H / 20.0)
        # -- state at the warm-up's start: the house near its balance, the unit off -------------
        room = ROOM + batch.uniform(-0.5, 0.5)
        load = np.maximum(ua_house * (room - outdoor[:, 0]) - gains[:, 0], 0.3)
        water = room + (load / emitter) ** (1 / 1.3)
        supply = water.copy()
        on = np.zeros(size, bool)
        since = np.full(size, 3600.0)            # seconds since the compressor last switched
        degree_minutes = np.zeros(size)
        ice = batch.uniform(0.0, 0.5)
        defrosting = np.zeros(size, bool)
        drip = np.zeros(size)
        ramp_heat, ramp_power = np.zeros(size), np.zeros(size)
        reading = supply.copy()
        #: the supply sensor's noise (the controller reads it too)
        supply_noise = batch.normal((total,), 0.05)
        out = {k: np.zeros((size, n)) for k in ("supply", "return", "power", "room", "defrost")}
        for k in range(total):
            # -- the controller on the 30-s snapshot ------------------------------------------
            setpoint = np.clip(22.0 + p["slope"] * (20.0 - filtered[:, k]) + 2.0 * (ROOM - room),
                               25.0, 55.0)
            degree_minutes = np.where(defrosting, degree_minutes, np.clip(
                degree_minutes + (reading - setpoint) * DT / 60.0, -600.0, 100.0))
            start = ~on & (degree_minutes <= -60.0) & (since >= MIN_OFF)
            stop = on & ~defrosting & (degree_minutes >= 0.0) & (since >= MIN_RUN)
            since = np.where(start | stop, 0.0, since + DT)
            on = (on | start) & ~stop
            begin = on & ~defrosting & (ice >= 1.0)
            defrosting = defrosting | begin
            drip = np.where(begin, DRIP_SECONDS, drip)
            ramp_heat = np.where(start, 0.0, ramp_heat)
            ramp_power = np.where(start, 0.0, ramp_power)
            flow = p["flow"] * (1.0 - flow_loss[:, k])
            logged = defrosting.copy()
            approach = APPROACH / (1.0 - fan[:, k]) ** 0.8
            for _ in range(SUBSTEPS):
                # -- the refrigerant circuit --------------------------------------------------
                evaporator = outdoor[:, k] - approach * (1.0 + ICE_APPROACH * ice)
                condenser = supply + 3.0
                capacity = (q7 * (1.0 + 0.025 * (evaporator - 1.0)) * (1.0 - 0.25 * ice)
                            * (1.0 - undercharge[:, k]))
                cop = (eta * (condenser + KELVIN) / np.maximum(condenser - evaporator, 5.0)
                       * (1.0 - 0.5 * undercharge[:, k]))
                heating = on & ~defrosting
                ramp_heat = np.where(on, 1.0 + (ramp_heat - 1.0) * heat_keep, 0.0)
                ramp_power = np.where(on, 1.0 + (ramp_power - 1.0) * power_keep, 0.0)
                heat = np.where(heating, ramp_heat * capacity * (1.0 - leak[:, k]),
                                np.where(defrosting, -0.45 * q7, 0.0))
                power = np.where(heating, ramp_power * capacity / cop,
                                 np.where(defrosting, 0.75 * nominal_power, 0.0))
                # the coil: ice while heating below 0 C under a dew point above it; melting
                # in a defrost, then dripping
                frost = heating & (evaporator < 0.0)
                ice = ice + frost * ICING_RATE * H / 3600.0 * np.maximum(
                    dew_point[:, k] - evaporator, 0.0) * np.exp(0.07 * outdoor[:, k])
                melting = defrosting & (ice > 0.0)
                ice = np.where(melting, np.maximum(ice - H / MELT_SECONDS, 0.0), ice)
                drip = np.where(defrosting & ~melting, drip - H, drip)
                done = defrosting & (drip <= 0.0)
                defrosting = defrosting & ~done
                logged = logged | defrosting
                ramp_heat = np.where(done, 1.0 / 3.0, ramp_heat)
                # -- the water: the condenser's outlet, the radiators' node ----------------------
                to_supply = water + heat / (CP * flow)
                supply = to_supply + (supply - to_supply) * condenser_keep
                emitted = emitter * np.maximum(water - room, 0.0) ** 1.3
                water = water + H * (CP * flow * (supply - water) - emitted) / p["c_water"]
            # -- the house on the 30-s grid ----------------------------------------------------
            room = room + DT * (emitted + gains[:, k] - ua_house * (room - outdoor[:, k])) / c_house
            reading = supply - drift[:, k] + supply_noise[:, k]
            if k >= WARMUP:
                i = k - WARMUP
                out["supply"][:, i] = reading
                out["return"][:, i] = water
                out["power"][:, i] = power
                out["room"][:, i] = room
                out["defrost"][:, i] = logged
        day = slice(WARMUP, total)
        power = out["power"] * (1.0 + batch.normal((n,), 0.01))
        return {
            "outdoor_temp": quantise(outdoor_read[:, day], 0.1),
            "supply_temp": quantise(out["supply"], 0.1),
            "return_temp": quantise(out["return"] + batch.normal((n,), 0.05), 0.1),
            "compressor_power": quantise(np.where(out["power"] > 0.0, power, 0.0), 0.01),
            "room_temp": quantise(out["room"] + batch.normal((n,), 0.05), 0.1),
            "defrost": out["defrost"]}


FAMILY = HeatPump()
