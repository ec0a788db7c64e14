"""A diesel generator set giving prime power to a remote mine camp, 24 h a day, logged every 5 s.

True plant: a 400-kW prime (500 kVA) set at 1500 rpm (50 Hz). The speed loop (1-s substeps,
discretised exactly, zero-order hold): the rotor's swing equation ``2H dw/dt = P_m - P_e - D w``
in per unit (``2H`` about 0.56 s: flywheel and alternator rotor, about 9 kg m^2), an isochronous
PI governor on the fuel rack (``Kp`` about 8, ``Ki`` about 10 /s) and the turbocharger's lag
between rack and torque (about 0.8 s): a 30-kW step dips the speed by about 35 rpm and the
governor recovers it in about 3 s; a combustion torque variability of 0.3 % of rated power keeps
the speed wandering by about 1.2 rpm (r.m.s.). Fuel from the torque delivered by a BSFC curve
(``9 + 0.225 P + 5e-5 P^2`` l/h with ``P`` in kW: 56 l/h at half load, 107 l/h at full),
times the day's fuel quality (its heating value, +-1 %) and the fuel's density falling with
its temperature (0.08 %/K). The exhaust (after the turbine) ``T_amb + (160 + 340 L^1.3)`` C
at load fraction ``L``, more on a hot day (0.25 %/K: less air mass) and at altitude (5 %/km),
humidity changing it +-1 % a day; the thermocouple (25-s lag) reads 65 % gas and 35 % the
manifold's metal (4-min lag). The coolant loop: the engine block and coolant (about 900 kJ/K)
take 27 % of the fuel's power; a wax thermostat (82 C opening, fully open at 93 C, 40-s lag)
sends it through a radiator with an engine-driven fan of about 7 kW/K fully open, scaled by
the air's density (ambient temperature and the site's altitude, 200-1800 m) to the power
0.6 and by the core's cleanliness (drifting down 0.1 %/day with dust, +-1 % by the day's wind
and rain); 0.3 kW/K more lost by the block to the enclosure.

The site's load (1-s resolution): the camp's base (about 140 kW by the vehicle, +-8 % by the
day), cooking and showers at the shift changes (5-7 h and 17-21 h), the workshop in the day
shift (by the day's work), air conditioning 4 kW per K of the last half-hour's ambient above
22 C, 30-80 motor starts a day (pumps, compressors, cold-room units: 10-45 kW each for 2-60
min, with a 3-s inrush of the same again), and small loads switching (1 kW, 20-s correlation).
The ambient: the site's climate (22-28 C by the vehicle), +-5 C by the day's weather, a daily
swing of 5-9 K peaking at 15 h, clouds (1 K, 30-min correlation).

Telemetry at 5 s from the set's controller (snapshots): electrical load (kW, 0.1 kW, 0.3 kW
noise), ambient temperature (0.1 C, 0.1 C noise), engine speed (rpm, 1 rpm resolution, 0.3 rpm
noise), fuel rate (the ECU's, l/h, 0.05 l/h, 1 % noise), exhaust temperature (1 C, 1.5 C
noise) and coolant temperature (the ECU's J1939 value: 1 C resolution, 0.2 C noise).

The white box a user writes (:class:`GensetWhiteBox`): speed a first-order return to 1500 rpm
(no load term: the governor is not modelled); fuel a linear Willans line in the measured load
(no curvature, no fuel quality or density); exhaust a first-order lag (90 s) to a linear
function of load and ambient (no altitude, no intake-air effect beyond the 1:1 ambient, no
metal-thermocouple split); coolant one thermal node heated linearly in the load and cooled
by a constant radiator conductance to the ambient: no thermostat (the real coolant is held at
85-93 C whatever the ambient, the white box's rises 1:1 with it), no air density, no dust.
Its parameters are 10-20 % off the fleet's.

Faults and why these magnitudes (fixed from the physics before any detection run):

* ``injector_fouling``: fuel for the same torque up by m (coked or dribbling injectors: worse
  spray, late burning), the exhaust's rise over ambient up by 1.5 m (the late heat leaves with
  the gas). 3 % is a few thousand hours of coking, within what a fuel bill hides; 8 % is a
  dribbling injector, about 4 l/h and 30-40 K of exhaust at the camp's load.
* ``turbo_degradation``: a fouled compressor wheel or turbine nozzle: the exhaust's rise over
  ambient up by m (less air for the same fuel), fuel up by 0.15 m and the turbocharger's lag
  x (1 + 3 m) (deeper speed dips on load steps). 6 % is about 20 K of exhaust at mid load (a
  wheel due for cleaning); 15 % is 45-50 K, an exhaust-high alarm on a hot afternoon.
* ``radiator_fouling``: the radiator's conductance down by m (dust and insects matted in the
  core, beyond the healthy drift). 20 % is a dusty season (the thermostat opens further, 1-2
  K); 45 % is a matted core: 2-5 K more at the camp's load, the thermostat fully open on a
  warm afternoon and the coolant then climbing with the ambient.
* ``governor_hunting``: a worn actuator linkage sticking and slipping: a rack disturbance of m
  of rated power (2-s correlation). Sized by the speed band it makes, computed from the loop
  before any run: 3 % gives about 2.8 rpm r.m.s. (+-0.35 %, out of ISO 8528's G3 steady band
  of +-0.25 %); 8 % gives about 6.7 rpm r.m.s. (+-0.9 %: lights flicker, out of G2's band).

The simulation costs about 4.7 s of CPU per batch of 64 asset-days, 2.6 s for 9 (a 1-s step
loop of a 3-state linear system over the batch, the thermal parts on the 5-s grid).
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 5.0
#: speed-loop substeps per sample (1 s, exact discretisation)
SUBSTEPS = 5
H = DT / SUBSTEPS
#: samples of warm-up: the previous day's last hour
WARMUP = 720
RATED_KW = 400.0
NOMINAL_RPM = 1500.0
#: kW of fuel power per l/h of diesel (0.84 kg/l, 42.8 MJ/kg)
KW_PER_LPH = 0.84 * 42.8e3 / 3600.0


class GensetWhiteBox(WhiteBoxModel):
    """Engine speed (rpm), exhaust and coolant temperatures (C) as states, fuel rate (l/h) as a
    Willans line in the load; inputs electrical load (kW) and ambient temperature (C)."""

    states = ("speed", "exhaust", "coolant")
    outputs = ("speed", "fuel", "exhaust", "coolant")
    inputs = ("load", "ambient")
    default_parameters = {"speed_nominal": 1500.0, "speed_lag": 1.5,
                          "fuel_idle": 7.5, "fuel_per_kw": 0.27,
                          "exhaust_base": 180.0, "exhaust_per_kw": 0.95,
                          "exhaust_per_ambient": 1.0, "exhaust_lag": 90.0,
                          "coolant_capacity": 750.0, "coolant_ua": 3.6,
                          "coolant_heat_idle": 28.0, "coolant_heat_per_kw": 0.75}
    positive = ("speed_nominal", "speed_lag", "fuel_per_kw", "exhaust_per_kw",
                "exhaust_lag", "coolant_capacity", "coolant_ua", "coolant_heat_per_kw")

    def derivatives(self, x, u):
        p = self.parameters
        speed, exhaust, coolant = x[..., 0], x[..., 1], x[..., 2]
        load, ambient = u[..., 0], u[..., 1]
        target = (p["exhaust_per_ambient"] * ambient + p["exhaust_base"]
                  + p["exhaust_per_kw"] * load)
        heat = p["coolant_heat_idle"] + p["coolant_heat_per_kw"] * load     # kW
        return np.stack([(p["speed_nominal"] - speed) / p["speed_lag"],
                         (target - exhaust) / p["exhaust_lag"],
                         (heat - p["coolant_ua"] * (coolant - ambient)) / p["coolant_capacity"]],
                        axis=-1)

    def output(self, x, u):
        p = self.parameters
        fuel = p["fuel_idle"] + p["fuel_per_kw"] * u[..., 0]
        return np.stack([x[..., 0], fuel, x[..., 1], x[..., 2]], axis=-1)


def _speed_loop(p: dict[str, np.ndarray], lag_scale: np.ndarray):
    """Per element the speed loop's exact one-substep transition: state (speed deviation pu,
    governor integral pu, torque delivered pu), inputs (electrical load pu, rack disturbance
    pu). Returns ``A`` (B, 3, 3) and ``B`` (B, 3, 2)."""
    size = len(lag_scale)
    a_out = np.empty((size, 3, 3))
    b_out = np.empty((size, 3, 2))
    for i in range(size):
        two_h, kp, ki = p["two_h"][i], p["kp"][i], p["ki"][i]
        lag = p["turbo_lag"][i] * lag_scale[i]
        m = np.zeros((5, 5))
        m[:3, :3] = [[-1.0 / two_h, 0.0, 1.0 / two_h], [-ki, 0.0, 0.0],
                     [-kp / lag, 1.0 / lag, -1.0 / lag]]
        m[0, 3] = -1.0 / two_h
        m[2, 4] = 1.0 / lag
        e = expm(m * H)
        a_out[i], b_out[i] = e[:3, :3], e[:3, 3:]
    return a_out, b_out


def _load_events(rng: np.random.Generator, steps: int) -> np.ndarray:
    """One day's motor loads (kW per 1-s substep): 30-80 starts, each 10-45 kW for 2-60 min with
    a 3-s inrush of the same again."""
    delta = np.zeros(steps + 1)
    for _ in range(int(rng.integers(30, 81))):
        at = int(rng.integers(0, steps))
        kw = rng.uniform(10.0, 45.0)
        end = min(at + int(rng.uniform(120.0, 3600.0) / H), steps)
        delta[at] += kw
        delta[end] -= kw
        inrush = min(at + int(3.0 / H), steps)
        delta[at] += kw
        delta[inrush] -= kw
    return np.cumsum(delta)[:steps]


class Genset(Family):
    name = "genset"
    title = "Diesel generator set, prime power to a remote camp (5 s)"
    description = ("isochronous PI governor with turbocharger lag, BSFC curve, exhaust with "
                   "thermocouple and manifold lags, thermostat and radiator with air density "
                   "and dust drift, camp load with motor starts; white box: first-order speed, "
                   "Willans fuel, lagged linear exhaust, one coolant node without thermostat, "
                   "10-20 % off")
    spec = "benchmarks.zoo.families.genset:GensetWhiteBox"
    columns = {"speed": "engine_speed", "fuel": "fuel_rate", "exhaust": "exhaust_temp",
               "coolant": "coolant_temp", "load": "load_kw", "ambient": "ambient_temp"}
    sample_interval = DT
    held_out = True
    channels = ("load_kw", "ambient_temp", "engine_speed", "fuel_rate", "exhaust_temp",
                "coolant_temp")
    batch_size = 64
    faults = (
        FaultKind("injector_fouling", "fuel for the same torque up by m, the exhaust's rise "
                  "over ambient by 1.5 m (relative)", (0.03, 0.08)),
        FaultKind("turbo_degradation", "the exhaust's rise over ambient up by m, fuel by "
                  "0.15 m, the turbocharger's lag x (1 + 3 m)", (0.06, 0.15)),
        FaultKind("radiator_fouling", "the radiator's conductance down by m (relative)",
                  (0.20, 0.45)),
        FaultKind("governor_hunting", "a stick-slip rack disturbance of m of rated power "
                  "(2-s correlation)", (0.03, 0.08)),
    )

    def true_parameters(self, rng):
        return {"two_h": spread(rng, 0.56, 0.05), "kp": spread(rng, 8.0, 0.05),
                "ki": spread(rng, 10.0, 0.05), "turbo_lag": spread(rng, 0.8, 0.08),
                "fuel_idle": spread(rng, 9.0, 0.05), "fuel_slope": spread(rng, 0.225, 0.02),
                "exhaust_rise": spread(rng, 340.0, 0.04), "exhaust_idle": spread(rng, 160.0, 0.05),
                "capacity": spread(rng, 900.0, 0.06), "ua_radiator": spread(rng, 7.0, 0.05),
                "thermostat": spread(rng, 82.0, 0.01), "cleanliness": float(rng.uniform(0.88, 1.0)),
                "altitude": float(rng.uniform(0.2, 1.8)), "climate": float(rng.uniform(22.0, 28.0)),
                "base_kw": spread(rng, 140.0, 0.1)}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        _, ts, hs, steps = self.clock(WARMUP, SUBSTEPS)
        # -- weather ----------------------------------------------------------------------------
        mean = p["climate"] + batch.uniform(-5.0, 5.0)
        swing = batch.uniform(5.0, 9.0)
        ambient = (mean[:, None] + 0.5 * swing[:, None] * np.cos(2 * np.pi * (hour - 15.0) / 24.0)
                   + smooth_noise(batch, total, 1800.0 / DT, 1.0))
        # air conditioning follows the last half-hour's ambient
        felt = np.empty_like(ambient)
        felt[:, 0] = ambient[:, 0]
        keep = np.exp(-DT / 1800.0)
        for k in range(1, total):
            felt[:, k] = keep * felt[:, k - 1] + (1 - keep) * ambient[:, k]
        # -- the camp's load (kW) on the 1-s grid -------------------------------------------------
        base = p["base_kw"] * batch.uniform(0.92, 1.08)
        work = batch.uniform(0.5, 1.2)
        occupancy = batch.uniform(0.8, 1.2)
        pattern = (40.0 * np.exp(-((hour - 6.0) / 0.8) ** 2)
                   + 60.0 * np.exp(-((hour - 19.0) / 1.5) ** 2)
                   - 20.0 * np.exp(-((hour - 2.0) / 2.0) ** 2))
        workshop = 35.0 * ((hour >= 7.0) & (hour < 17.0))
        slow = (base[:, None] + pattern[None, :] + work[:, None] * workshop[None, :]
                + occupancy[:, None] * 4.0 * np.maximum(felt - 22.0, 0.0))
        motors = np.stack([_load_events(rng, steps) for rng in batch.rngs])
        load_kw = (np.repeat(slow, SUBSTEPS, axis=1) + motors
                   + smooth_noise(batch, steps, 20.0 / H, 1.0))
        load_kw = np.clip(load_kw, 30.0, 1.1 * RATED_KW)
        combustion = batch.normal((steps,), 0.003)
        stick = smooth_noise(batch, steps, 2.0 / H, 1.0)
        # -- unmeasured day-to-day conditions ----------------------------------------------------
        fuel_quality = 1.0 + 0.01 * batch.normal(())
        humidity = 1.0 + 0.01 * batch.normal(())
        cleanliness = (p["cleanliness"] - 0.001 * batch.day + 0.01 * batch.normal(())
                       )[:, None] * (1.0 + 0.01 * smooth_noise(batch, total, 6 * 3600 / DT))
        # -- faults -----------------------------------------------------------------------------
        injector = batch.active("injector_fouling", t)
        turbo = batch.active("turbo_degradation", t)
        radiator = batch.active("radiator_fouling", t)
        hunting = batch.active("governor_hunting", ts)
        a_ok, b_ok = _speed_loop(p, np.ones(size))
        a_turbo, b_turbo = _speed_loop(p, 1.0 + 3.0 * batch.magnitude
                                       * (batch.fault == "turbo_degradation"))
        turbo_sub = batch.active("turbo_degradation", ts) > 0
        # -- the loop -------------------------------------------------------------------------
        loop = np.zeros((size, 3))
        loop[:, 1] = loop[:, 2] = load_kw[:, 0] / RATED_KW
        density = np.exp(-p["altitude"] / 8.4)
        gas0 = ambient[:, 0] + p["exhaust_idle"] + p["exhaust_rise"] * (load_kw[:, 0] / RATED_KW) ** 1.3
        metal, thermocouple = gas0.copy(), gas0.copy()
        coolant = np.full(size, 87.0)
        opening = np.full(size, 0.5)
        out = {k: np.zeros((size, n)) for k in ("speed", "fuel", "torque", "exhaust", "coolant")}
        k_metal, k_tc, k_wax = (np.exp(-DT / tau) for tau in (240.0, 25.0, 40.0))
        for k in range(total):
            torque_sum = np.zeros(size)
            for j in range(SUBSTEPS):
                s = k * SUBSTEPS + j
                w = np.stack([load_kw[:, s] / RATED_KW + combustion[:, s],
                              hunting[:, s] * stick[:, s]], axis=1)
                a = np.where(turbo_sub[:, s, None, None], a_turbo, a_ok)
                b = np.where(turbo_sub[:, s, None, None], b_turbo, b_ok)
                loop = np.einsum("bij,bj->bi", a, loop) + np.einsum("bij,bj->bi", b, w)
                torque_sum += loop[:, 2]
            torque_kw = np.maximum(loop[:, 2], 0.0) * RATED_KW        # at the sample
            mean_kw = np.maximum(torque_sum / SUBSTEPS, 0.0) * RATED_KW
            amb = ambient[:, k]
            per_kwh = (1.0 / fuel_quality * (1.0 + 0.0008 * (amb - 25.0))
                       * (1.0 + injector[:, k]) * (1.0 + 0.15 * turbo[:, k]))
            fuel = (p["fuel_idle"] + p["fuel_slope"] * torque_kw + 5e-5 * torque_kw ** 2) * per_kwh
            fuel_mean = (p["fuel_idle"] + p["fuel_slope"] * mean_kw + 5e-5 * mean_kw ** 2) * per_kwh
            rise = ((p["exhaust_idle"] + p["exhaust_rise"] * (mean_kw / RATED_KW) ** 1.3)
                    * (1.0 + 0.0025 * (amb - 25.0)) * (1.0 + 0.05 * p["altitude"]) * humidity
                    * (1.0 + 1.5 * injector[:, k]) * (1.0 + turbo[:, k]))
            gas = amb + rise
            metal = k_metal * metal + (1 - k_metal) * gas
            thermocouple = k_tc * thermocouple + (1 - k_tc) * (0.65 * gas + 0.35 * metal)
            heat = 0.27 * KW_PER_LPH * fuel_mean                               # kW
            air = (298.15 / (273.15 + amb) * density) ** 0.6
            ua = p["ua_radiator"] * air * cleanliness[:, k] * (1.0 - radiator[:, k])
            wanted = np.clip((coolant - p["thermostat"]) / 11.0, 0.03, 1.0)
            opening = k_wax * opening + (1 - k_wax) * wanted
            lost = ua * opening * (coolant - amb) + 0.3 * (coolant - amb)
            coolant = coolant + DT * (heat - lost) / p["capacity"]
            if k >= WARMUP:
                i = k - WARMUP
                out["speed"][:, i] = NOMINAL_RPM * (1.0 + loop[:, 0])
                out["fuel"][:, i] = fuel
                out["exhaust"][:, i] = thermocouple
                out["coolant"][:, i] = coolant
        day = slice(WARMUP, total)
        sampled = load_kw[:, WARMUP * SUBSTEPS + SUBSTEPS - 1::SUBSTEPS]     # with the speed's
        return {
            "load_kw": quantise(sampled + batch.normal((n,), 0.3), 0.1),
            "ambient_temp": quantise(ambient[:, day] + batch.normal((n,), 0.1), 0.1),
            "engine_speed": quantise(out["speed"] + batch.normal((n,), 0.3), 1.0),
            "fuel_rate": quantise(out["fuel"] * (1.0 + batch.normal((n,), 0.01)), 0.05),
            "exhaust_temp": quantise(out["exhaust"] + batch.normal((n,), 1.5), 1.0),
            "coolant_temp": quantise(out["coolant"] + batch.normal((n,), 0.2), 1.0)}


FAMILY = Genset()
