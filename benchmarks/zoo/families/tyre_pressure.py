"""A regional distribution truck's tyre-pressure monitoring (TPMS), four monitored tyres,
logged every 60 s by the truck's telematics unit.

The truck: a two-axle rigid (steer axle 6 t +0.1 of the payload, drive axle 4.5 t +0.9 of
it, twin tyres on the drive axle); the monitored tyres are the two steer tyres (``fl``,
``fr``) and the drive axle's two outer tyres (``rl``, ``rr``). It runs every day of the
week from one depot: weekdays 7-11 h of duty starting 4:30-7:30, Saturdays 5-8 h, Sundays a
short 3-5-h run (days count from the first simulated day, a Monday in the zoo's runs); out
of the depot through town, a highway stint, 3-12 deliveries (2-7 on a Sunday) between town
and rural legs, a lunch break, the highway back. The payload (40-100 % of 8 t, 20-60 % on
a Sunday) falls at every delivery. At a delivery the engine is switched off (60 %) or idles
for the tail lift; parked overnight at the depot.

True plant, per tyre, on 30-s substeps. The tyre's gas obeys the ideal gas law at a nearly
constant volume: ``p_abs = n R T_gas / V`` with the volume growing 0.5 % per 100 kPa
(``p_abs (1 + c (p - p_fill)) = m P0 (T_gas + 273.15) / 293.15``, ``m`` the gas left of the
fill, ``P0`` the absolute fill pressure at 20 C: steer 850 kPa, drive 800 kPa gauge, each
tyre +-2 % as filled). The gas sits between the carcass and the rim and takes 0.75 of the
carcass's temperature and 0.25 of the rim's (its own heat capacity, under 1 kJ/K, is
neglected). The carcass (90 kJ/K steer, 85 kJ/K drive, +-5 %) is heated by its rolling loss
``Q = C_rr F_z v (p_nom / p)^0.6`` (``C_rr`` 0.0055 steer, 0.006 drive +-5 %; ``F_z`` the
tyre's share of its axle's load; an under-inflated tyre flexes and heats more) and by the
sun (up to 120 W by the day's cloud), and loses heat to the air by ``(17 + 9.5 v^0.75)`` W/K
(+-8 %; natural convection parked, forced when rolling: about 115 W/K at 80 km/h, a 13-minute
time constant; 30 minutes in town, 90 parked). The rim with its wheel end (40 kJ/K) takes a
fifth of its wheel end's share of the brake heat (in town about 2 stops a km from 1.6 times
the mean speed, on rural legs one stop every 3 km, on the highway occasional slow-downs),
loses ``(8 + 5 v^0.75)`` W/K to the air and exchanges 15 W/K with the carcass at the bead.
The gas leaks by diffusion through the rubber, ``m' = -lambda m (p / p_nom) e^{0.025 (T_gas -
20)}`` with ``lambda`` 1-3 % a month per tyre: a healthy tyre loses about 0.3-0.8 kPa a day,
and the fleet does not top it up within a zoo run (the tyres were filled 0-60 days before
the first day). The atmosphere is 101.3 +-2.5 kPa by the day's weather (the TPMS reports
gauge pressure). The air: a site climate of 0-22 C (per truck), +-5 C by the day, a daily
swing of 4-10 K peaking at 15 h and a 0.8-K wander; the truck's ambient sensor behind the
grille soaks up to 4 K of engine heat when the truck idles or crawls (a 5-minute lag). The
previous evening from 20:00 is simulated parked as a warm-up (the tyres 0-6 K above the air).
Each day is simulated on its own: the gas a tyre lost before the warm-up is its healthy leak
at the nominal rate over the days since its fill, and a fault's loss before the warm-up (a
fault from an earlier day) is its rate at an assumed day (below).

Telemetry at 60 s: the vehicle's speed (the minute's mean, km/h, 0.1), the ambient sensor
(0.5 C, 0.1 C noise), the ignition (1 on, 0 off), and per tyre the TPMS pressure (gauge,
kPa, 1 kPa steps, 0.4 kPa noise) and temperature (1 K steps, 0.3 K noise, each sensor +-1 K
off by its calibration). The sensors keep reporting while the truck is parked, and the
telematics unit logs them with the ignition at 0: the class declares ``running = { ignition
= [0.5, 1.5] }`` (:data:`GRID`), so parked hours are pauses and the idling at a delivery
(ignition on, speed 0) is data.

The white box a user writes (:class:`TyreWhiteBox`): each tyre's gas temperature a
first-order lag (one time constant, 20 minutes, whatever the speed) toward the ambient
sensor's reading plus a heating proportional to the speed (0.26 K per km/h, steer and drive
alike: no load, no brakes, no sun, no rim); each pressure the ideal gas law at a constant
volume from the tyre's specified cold pressure (850 / 800 kPa at 20 C) and 101.3 kPa of
atmosphere; no leak. Against the plant (its steady state at a constant speed): the gas
+24 K on a steer tyre at 80 km/h, a drive tyre +9 K empty to +24 K with 8 t aboard, the
white box +21 K for all; at 20 km/h the plant +13 K steer and +5-13 K drive, the white box
+5 K; the plant's slowest time constant 12-13 minutes at 80 km/h, 16-17 at 50, 27-28 at 20
and 83-87 parked, the white box's 20 throughout.

Faults and why these magnitudes (fixed from the physics before any detection run). Each
faulty truck has its fault on one tyre, drawn per truck. What each does to the plant was
first written from hand calculations and then corrected from simulations of the plant alone
(8 trucks, 3 days each, before any detection run; the magnitudes never changed): the
puncture's loss per day was first written 2.5-3 and 10-12 kPa, the hot leak's a few tenths
of a percent and 1-4 % a day, the drag's gas 3-4 K and 14 K warmer.

* ``slow_puncture``: the tyre's leak rate x m (a nail in the tread, a porous repair). At
  x5 the tyre loses 1.3-3 kPa a day (the tyres' own leak rates differ by three and the
  leak slows in the cold): a nail a fleet engineer wants found at the next depot visit,
  weeks before the TPMS's own low-pressure warning (typically 10-20 % below the setpoint);
  at x20 it loses 7-15 kPa a day, 3-5 % in three days: the warning comes within one to
  three weeks, and a tyre run under-inflated on the highway fails (a blow-out, a burnt-out
  twin).
* ``hot_leak``: a valve stem or bead seat that leaks only when hot (a cracked valve core
  seal, a bead seated over corrosion: the rim's and the valve's expansion and the pressure's
  rise open it once the tyre has warmed up): m % of the tyre's gas an hour per 10 K of gas
  temperature more than 10 K above the air, nothing parked or cool. At 0.3 %/h the tyre
  loses 7-14 kPa (1-1.7 %) a working day: a fault a cold-pressure check in the yard sees
  only as a tyre that needs topping up again and again; at 1 %/h 22-46 kPa (3-5.5 %) a
  day, a tyre at the low-pressure warning within a few days. (Before the warm-up of a later
  day the fault is assumed to have lost m % x 3 h a day.)
* ``pressure_bias``: the tyre's pressure sensor reads m kPa high (ageing, a knock at a tyre
  change). 7 kPa is the sensor's own accuracy band (a sensor off by its tolerance: the
  tyre kept 1 % below its setpoint unseen); 20 kPa hides 2.5 % of under-inflation and
  delays the low-pressure warning by that much.
* ``bearing_drag``: a wheel bearing running rough or a brake shoe not releasing on the
  tyre's wheel end: m N of drag at the tyre's radius, its heat ``m v`` into the rim. 30 N
  (0.7 kW at 80 km/h; the gas 2-2.4 K warmer on average while the truck runs, 3-4 K at
  most, its pressure 5.5-7 kPa higher) is the early sign of a failing bearing an engineer
  wants before the hub overheats; 120 N (2.7 kW at 80 km/h; the gas 8-9.5 K warmer on
  average, 12-13 K at most, 22-29 kPa) is a dragging brake or a bearing about to seize (a
  wheel-end fire risk).
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 60.0
SUBSTEPS = 2
H = DT / SUBSTEPS
#: samples of warm-up: the previous evening from 20:00, parked
WARMUP = 4 * 60
TYRES = ("fl", "fr", "rl", "rr")
#: specified cold pressures (kPa gauge at 20 C): steer, steer, drive, drive
SPEC = np.array([850.0, 850.0, 800.0, 800.0])
ATMOSPHERE = 101.3
KELVIN = 273.15
#: the class's grid: the telematics unit logs the parked truck with the ignition at 0
GRID = {"running": {"ignition": [0.5, 1.5]}}


class TyreWhiteBox(WhiteBoxModel):
    """Each monitored tyre's gas temperature ``temp_*`` (C) as a first-order lag toward the
    ambient temperature plus a heating proportional to the speed, and its pressure
    ``pressure_*`` (kPa gauge) by the ideal gas law at a constant volume from the specified
    cold pressure; inputs the vehicle's speed (km/h) and the ambient temperature (C)."""

    states = tuple(f"temp_{t}" for t in TYRES)
    outputs = tuple(f"pressure_{t}" for t in TYRES) + states
    inputs = ("speed", "ambient_temp")
    default_parameters = {"lag": 1200.0, "heating": 0.26, "cold_steer": 850.0,
                          "cold_drive": 800.0}

    def derivatives(self, x, u):
        p = self.parameters
        # a parameter broadcast over the tyres (an array over the fleet in a stacked model)
        heating, lag = (np.asarray(p[k])[..., None] for k in ("heating", "lag"))
        target = u[..., 1:2] + heating * u[..., 0:1]
        return (target - x) / lag

    def output(self, x, u):
        p = self.parameters
        pressure = [(p["cold_steer" if i < 2 else "cold_drive"] + ATMOSPHERE)
                    * (x[..., i] + KELVIN) / (20.0 + KELVIN) - ATMOSPHERE for i in range(4)]
        return np.concatenate([np.stack(pressure, axis=-1), x], axis=-1)


def _duty(rng: np.random.Generator, total: int, warmup: int, weekday: int):
    """One truck-day on the telemetry's grid: speed (km/h, the minute's mean), ignition,
    the vehicle's brake power (kW) and its payload (kg)."""
    speed = np.zeros(total)
    ignition = np.zeros(total, dtype=bool)
    brake = np.zeros(total)
    payload = np.zeros(total)
    if weekday == 6:
        start, hours, drops, load = rng.uniform(7.0, 10.0), rng.uniform(3.0, 5.0), \
            int(rng.integers(2, 8)), rng.uniform(0.2, 0.6)
    elif weekday == 5:
        start, hours, drops, load = rng.uniform(5.0, 8.0), rng.uniform(5.0, 8.0), \
            int(rng.integers(3, 10)), rng.uniform(0.4, 1.0)
    else:
        start, hours, drops, load = rng.uniform(4.5, 7.5), rng.uniform(7.0, 11.0), \
            int(rng.integers(3, 13)), rng.uniform(0.4, 1.0)
    kg = 8000.0 * load
    t = warmup + int(start * 60)
    end = min(t + int(hours * 60), warmup + 23 * 60)
    lunch = t + int(hours * 60 * rng.uniform(0.4, 0.6))

    def drive(kind: str, minutes: int) -> None:
        nonlocal t
        stop = min(t + minutes, total)
        if stop <= t:
            return
        count = stop - t
        if kind == "highway":
            v = rng.uniform(76.0, 88.0) + np.cumsum(rng.normal(0.0, 1.0, count)) * 0.5
            v = np.clip(v, 60.0, 90.0)
            slow = rng.random(count) < 0.04
            v = np.where(slow, rng.uniform(30.0, 60.0, count), v)
            per_km = np.where(slow, 1.0, 0.02)
            peak = v
        elif kind == "rural":
            v = np.clip(rng.uniform(50.0, 70.0) + rng.normal(0.0, 6.0, count), 20.0, 80.0)
            per_km, peak = 1.0 / 3.0, v
        else:
            v = np.clip(rng.uniform(15.0, 30.0) + rng.normal(0.0, 9.0, count), 2.0, 50.0)
            per_km, peak = 2.0, np.minimum(1.6 * v, 55.0)
        mass = 7500.0 + 3000.0 + kg                       # the truck, its body, the payload
        stops_per_s = v / 3600.0 * per_km
        speed[t:stop] = v
        brake[t:stop] = mass * (peak / 3.6) ** 2 / 2.0 * stops_per_s / 1000.0
        ignition[t:stop] = True
        payload[t:stop] = kg
        t = stop

    def halt(minutes: int, engine: bool) -> None:
        nonlocal t
        stop = min(t + minutes, total)
        ignition[t:stop] = engine
        payload[t:stop] = kg
        t = stop

    halt(int(rng.uniform(3, 10)), True)                   # the morning checks, engine on
    drive("urban", int(rng.uniform(10, 20)))
    drive("highway", int(rng.uniform(30, 90)))
    lunched = False
    for _ in range(drops):
        if t >= end - 90:
            break
        drive("urban" if rng.random() < 0.6 else "rural", int(rng.uniform(8, 40)))
        halt(int(rng.uniform(10, 40)), engine=rng.random() < 0.4)
        kg = max(kg - 8000.0 * load / drops * rng.uniform(0.5, 1.5), 0.0)
        if not lunched and t >= lunch:
            halt(int(rng.uniform(30, 45)), engine=False)
            lunched = True
    drive("highway", int(rng.uniform(30, 90)))
    drive("urban", int(rng.uniform(10, 20)))
    halt(int(rng.uniform(2, 6)), True)
    payload[t:] = kg
    return speed, ignition, brake, payload


class TyrePressure(Family):
    name = "tyre_pressure"
    title = "Distribution truck's tyre pressures, TPMS (60 s)"
    description = ("four monitored tyres of a two-axle truck on daily delivery runs: gas at "
                   "a nearly constant volume between a carcass heated by its rolling loss "
                   "(load, speed, inflation) and a rim heated by the brakes, diffusion leak, "
                   "payload falling at deliveries, weather and sun, parked hours as pauses; "
                   "white box: one lag per tyre toward ambient + k x speed, the gas law from "
                   "the specified cold pressure, no load, no leak, 10-20 % off")
    spec = "benchmarks.zoo.families.tyre_pressure:TyreWhiteBox"
    columns = {name: name for name in TyreWhiteBox.outputs + TyreWhiteBox.inputs}
    sample_interval = DT
    grid = GRID
    held_out = True
    channels = (("speed", "ambient_temp", "ignition") + tuple(f"pressure_{t}" for t in TYRES)
                + tuple(f"temp_{t}" for t in TYRES))
    faults = (
        FaultKind("slow_puncture", "one tyre's leak rate x m", (5.0, 20.0)),
        FaultKind("hot_leak", "one tyre loses m % of its gas an hour per 10 K of gas "
                  "temperature more than 10 K above the air (a valve or bead seal that leaks "
                  "when hot)",
                  (0.3, 1.0)),
        FaultKind("pressure_bias", "one tyre's pressure sensor reads m kPa high", (7.0, 20.0)),
        FaultKind("bearing_drag", "m N of drag at one tyre's wheel end, its heat into the rim",
                  (30.0, 120.0)),
    )

    def true_parameters(self, rng):
        out = {}
        for i, tyre in enumerate(TYRES):
            out[f"fill_{tyre}"] = spread(rng, SPEC[i], 0.02)
            out[f"leak_{tyre}"] = float(rng.uniform(0.01, 0.03)) / 30.0     # per day
            out[f"crr_{tyre}"] = spread(rng, 0.0055 if i < 2 else 0.006, 0.05)
            out[f"c_carcass_{tyre}"] = spread(rng, 9.0e4 if i < 2 else 8.5e4, 0.05)
            out[f"convection_{tyre}"] = spread(rng, 1.0, 0.08)
            out[f"sensor_{tyre}"] = float(rng.uniform(-1.0, 1.0))
        out["age"] = float(rng.uniform(0.0, 60.0))               # days since the fill
        out["climate"] = float(rng.uniform(0.0, 22.0))
        out["fault_tyre"] = float(rng.integers(0, len(TYRES)))
        return out

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        per_tyre = lambda key: np.stack([p[f"{key}_{tyre}"] for tyre in TYRES], axis=1)
        events = [_duty(rng, total, WARMUP, int(day % 7)) for rng, day in
                  zip(batch.rngs, batch.day)]
        speed, ignition, brake, payload = (np.stack([e[i] for e in events]) for i in range(4))
        # -- weather, the atmosphere, the sun ------------------------------------------------
        weather = p["climate"] + batch.uniform(-5.0, 5.0)
        swing = batch.uniform(4.0, 10.0)
        air = (weather[:, None] + 0.5 * swing[:, None] * np.cos(2 * np.pi * (hour - 15.0) / 24.0)
               + smooth_noise(batch, total, 120.0, 0.8))
        atmosphere = (ATMOSPHERE + batch.uniform(-2.5, 2.5))[:, None] + smooth_noise(
            batch, total, 240.0, 0.3)
        sun = batch.uniform(0.0, 120.0)[:, None] * np.clip(
            np.cos(np.pi * (hour - 13.0) / 12.0), 0.0, None)[None, :] ** 2
        # -- the truck's loads per tyre (N) --------------------------------------------------
        steer = (6000.0 + 0.1 * payload) / 2.0 * 9.81
        drive = (4500.0 + 0.9 * payload) / 4.0 * 9.81
        # -- faults ----------------------------------------------------------------------------
        which = np.arange(len(TYRES))[None, :] == p["fault_tyre"][:, None]      # (B, 4)
        puncture = batch.active("slow_puncture", t)
        hot = batch.active("hot_leak", t)
        bias = batch.active("pressure_bias", t)
        drag = batch.active("bearing_drag", t)
        # -- the state at 20:00 the evening before: parked -----------------------------------
        fill = per_tyre("fill")
        leak = per_tyre("leak")
        crr = per_tyre("crr")
        c_carcass = per_tyre("c_carcass")
        convection = per_tyre("convection")
        before = p["age"] + batch.day + t[0] / 86400.0                    # days since the fill
        gas = np.exp(-leak * before[:, None])
        # a fault from an earlier day: its loss before the warm-up at an assumed day's rate
        earlier = np.minimum(np.maximum(t[0] - batch.onset, 0.0) / 86400.0, 1e4)  # days
        multiple = np.where(batch.fault == "slow_puncture", batch.magnitude, 1.0)
        hot_hours = 3.0
        hot_rate = np.where(batch.fault == "hot_leak", batch.magnitude, 0.0) / 100.0
        gas *= np.where(which, np.exp(-(multiple - 1.0)[:, None] * leak * earlier[:, None]
                                      - (hot_rate * hot_hours * earlier)[:, None]), 1.0)
        warm = batch.uniform(0.0, 6.0)[:, None] * batch.uniform(0.8, 1.2, (len(TYRES),))
        carcass = air[:, :1] + warm
        rim = carcass.copy()
        soak = np.zeros(size)
        out = {k: np.zeros((size, n, len(TYRES))) for k in ("pressure", "temp")}
        sensed_air = np.zeros((size, n))
        absolute = (fill + ATMOSPHERE)
        for k in range(total):
            v = speed[:, k] / 3.6                                          # m/s
            moving = v[:, None] ** 0.75
            ambient = air[:, k:k + 1]
            loads = np.stack([steer[:, k], steer[:, k], drive[:, k], drive[:, k]], axis=1)
            shares = np.array([0.45, 0.45, 0.55, 0.55]) / 2.0 * 0.2
            braking = 1000.0 * brake[:, k:k + 1] * shares[None, :]
            extra = which * (drag[:, k] * v)[:, None]                     # W into the rim
            mult = np.where(which & (puncture[:, k] > 0)[:, None], puncture[:, k:k + 1], 1.0)
            hot_now = which * hot[:, k:k + 1] / 100.0 / 3600.0
            warmed = ambient + 10.0                          # where the hot leak starts
            h_carcass = (17.0 + 9.5 * moving) * convection
            h_rim = 8.0 + 5.0 * moving
            for _ in range(SUBSTEPS):
                temp = 0.75 * carcass + 0.25 * rim
                stretch = gas * absolute * (temp + KELVIN) / (20.0 + KELVIN)
                pressure = stretch / (1.0 + 5e-5 * (stretch - ATMOSPHERE - fill)) \
                    - atmosphere[:, k:k + 1]
                q_roll = crr * loads * v[:, None] * (SPEC / np.maximum(pressure, 100.0)) ** 0.6
                bead = 15.0 * (carcass - rim)
                d_carcass = (q_roll + sun[:, k:k + 1] - h_carcass * (carcass - ambient)
                             - bead) / c_carcass
                d_rim = (braking + extra - h_rim * (rim - ambient) + bead) / 4.0e4
                d_gas = -gas * (leak / 86400.0 * mult * pressure / SPEC
                                * np.exp(0.025 * (temp - 20.0))
                                + hot_now * np.maximum(temp - warmed, 0.0) / 10.0)
                carcass = carcass + H * d_carcass
                rim = rim + H * d_rim
                gas = gas + H * d_gas
            # the ambient sensor soaks up engine heat idling or crawling
            idling = ignition[:, k] & (speed[:, k] < 15.0)
            soak += (4.0 * idling - soak) * (1.0 - np.exp(-DT / 300.0))
            if k >= WARMUP:
                i = k - WARMUP
                out["pressure"][:, i] = pressure + which * bias[:, k:k + 1]
                out["temp"][:, i] = temp
                sensed_air[:, i] = ambient[:, 0] + soak
        day = slice(WARMUP, total)
        pressures = quantise(out["pressure"] + batch.normal((n, len(TYRES)), 0.4), 1.0)
        temps = quantise(out["temp"] + per_tyre("sensor")[:, None, :]
                         + batch.normal((n, len(TYRES)), 0.3), 1.0)
        running = speed[:, day] > 0
        telemetry = {
            "speed": quantise(np.maximum(speed[:, day] + batch.normal((n,), 0.2) * running,
                                         0.0) * running, 0.1),
            "ambient_temp": quantise(sensed_air + batch.normal((n,), 0.1), 0.5),
            "ignition": ignition[:, day].astype(float)}
        for i, tyre in enumerate(TYRES):
            telemetry[f"pressure_{tyre}"] = pressures[:, :, i]
            telemetry[f"temp_{tyre}"] = temps[:, :, i]
        return telemetry


FAMILY = TyrePressure()
