"""A city delivery van's permanent-magnet DC traction drive at 1 Hz: stop-and-go service by
day, parked at night.

Sign convention: current, voltage and speed are positive driving forward; a negative current
is regenerative braking (the van does not reverse; the armature voltage stays within
0..130 V).

True plant: the armature ``L i' = V - R(T) i - k w`` (``R = 0.05`` ohm at 25 C, copper
``+0.39 %/K``, ``L = 0.3`` mH: ``L/R`` about 6 ms) and the shaft with the van reflected to it
(gear 8, wheel 0.3 m: ``J = J_m + m (r/G)^2``, about 2 kg m^2) ``J w' = k i - T_c - b w -
T_road``, where ``T_road`` is aerodynamic drag (``~ w^2``), rolling resistance and the grade of a
slowly varying road (not measured), and the van's mass changes with the day's payload (not
measured either). The motor's ``k`` is the torque and the back-EMF constant. A speed loop at
20 Hz (a PI on the driver's speed reference giving a current reference within -200..300 A)
feeds a current loop (feed-forward ``k w + R i_ref`` with the nominal constants plus an
integral of the measured current's error) that sets the armature voltage. The electrical part
is integrated exactly over each 50-ms control period (``i`` relaxes toward
``(V - k w) / R`` as ``exp(-h R / L)`` for the held voltage and speed), the shaft with explicit
50-ms steps, the winding temperature once a second:
``C T' = R(T) i^2 + k_fe w^2 - (T - T_amb) / R_th(w)`` with iron losses and a shaft fan whose
cooling grows with speed. The driver's reference: a service of 5:30-7:30 to 18:00-21:30 with a
lunch break, legs of acceleration, cruising at 20-50 km/h, braking, traffic stops and delivery
stops. At a standstill with a zero reference the drive is disabled (no voltage, no current,
the brake holds). The ambient temperature follows the asset's climate (4-26 C), the day's
weather (+-4 C) and a daily cycle. Telemetry at 1 Hz: armature current (0.1 A, 0.5 A
noise), armature voltage (0.05 V, 0.1 V noise), motor speed (an encoder, rad/s), winding
temperature, ambient temperature.

The white box a user writes (:class:`TractionDriveWhiteBox`): the textbook armature ODE
``i' = (V - R i - k w) / L`` (a stiff state, about 8 ms, at 1-s samples), ``J w' = k i - b w -
c w |w| - T_roll tanh(w / 2)`` with a fixed van mass, no grade and no Coulomb friction
(lumped into the rolling term), ``C T' = R i^2 - (T - T_amb) / R_th`` with constant
resistance and cooling; ``k`` within 1 %, the rest 10-20 % off.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 1.0
#: control periods per second (the speed and current loops run at 20 Hz)
SUBSTEPS = 20
WARMUP = 1800
#: wheel radius over gear ratio: metres travelled per radian of the motor
RATIO = 0.3 / 8.0
MOTOR_INERTIA = 0.05
ALPHA = 0.0039
#: speed loop (A per rad/s, A per rad), current loop (V per A s), limits
KP, KI, KIC = 25.0, 15.0, 0.4
I_MIN, I_MAX, V_BUS, INTEGRAL_V = -200.0, 300.0, 130.0, 20.0
#: the controller's nominal motor constants (its feed-forward)
K_NOMINAL, R_NOMINAL = 0.28, 0.05


class TractionDriveWhiteBox(WhiteBoxModel):
    """Armature current ``i`` (A), motor speed ``w`` (rad/s) and winding temperature ``T`` (C),
    all measured; inputs armature voltage ``v`` (V) and ambient temperature (C)."""

    states = ("i", "w", "T")
    inputs = ("v", "ambient")
    controlled_inputs = ("v",)  # the current loop sets the armature voltage
    default_parameters = {"resistance": 0.045, "inductance": 3.5e-4, "k": 0.282, "inertia": 1.7,
                          "viscous": 0.02, "drag": 2.6e-5, "rolling": 6.0,
                          "heat_capacity": 4600.0, "thermal_resistance": 0.09}

    def derivatives(self, x, u):
        p = self.parameters
        i, w, temp = x[..., 0], x[..., 1], x[..., 2]
        v, ambient = u[..., 0], u[..., 1]
        di = (v - p["resistance"] * i - p["k"] * w) / p["inductance"]
        dw = (p["k"] * i - p["viscous"] * w - p["drag"] * w * np.abs(w)
              - p["rolling"] * np.tanh(w / 2.0)) / p["inertia"]
        dT = (p["resistance"] * i ** 2
              - (temp - ambient) / p["thermal_resistance"]) / p["heat_capacity"]
        return np.stack([di, dw, dT], axis=-1)


def _stint(rng: np.random.Generator, seconds: int) -> np.ndarray:
    """A stint of stop-and-go driving (m/s per second): legs of acceleration, cruising with a
    smooth wobble, braking, traffic and delivery stops; from and back to a standstill."""
    legs, speed, length = [], 0.0, 0
    while length < seconds:
        target = rng.uniform(6.0, 13.0)
        rate = rng.uniform(0.8, 1.4) if target > speed else rng.uniform(0.6, 1.0)
        steps = max(int(abs(target - speed) / rate), 1)
        legs.append(np.linspace(speed, target, steps + 1)[1:])
        cruise = int(rng.uniform(15.0, 120.0))
        wobble = lfilter([0.031], [1.0, -1.8, 0.81], rng.normal(0.0, 1.0, cruise))
        legs.append(np.maximum(target + wobble, 0.5))
        speed = float(legs[-1][-1])
        if rng.random() < 0.65:
            braking = rng.uniform(0.7, 1.2)
            legs.append(np.maximum(speed - braking * np.arange(1, int(speed / braking) + 2), 0.0))
            wait = rng.uniform(5.0, 40.0) if rng.random() < 0.7 else rng.uniform(60.0, 400.0)
            legs.append(np.zeros(int(wait)))
            speed = 0.0
        length = sum(len(leg) for leg in legs)
    v = np.concatenate(legs)[:seconds]
    return np.minimum(v, 0.8 * np.arange(seconds - 1, -1, -1))


def _reference(rng: np.random.Generator, total: int) -> np.ndarray:
    """The driver's speed (m/s) over the warm-up and the day (``total + 1`` seconds): the
    morning stint to the lunch break and the afternoon stint to the service's end."""
    hours = 3600.0
    start = rng.uniform(5.5, 7.5) * hours
    lunch = rng.uniform(11.5, 13.0) * hours
    back = lunch + rng.uniform(30, 60) * 60
    end = rng.uniform(18.0, 21.5) * hours
    v = np.zeros(total + 1)
    for begin, finish in ((start, lunch), (back, end)):
        lo, hi = int(WARMUP + begin), int(WARMUP + finish)
        v[lo:hi] = _stint(rng, hi - lo)
    return v


class TractionDrive(Family):
    name = "traction_drive"
    title = "PM DC traction drive (1 Hz)"
    description = ("delivery van's PM DC motor under a 20-Hz speed and current loop in "
                   "stop-and-go service: 6-ms armature, hot copper resistance, Coulomb friction, "
                   "road load with unmeasured grade and payload, fan-cooled winding; white box: "
                   "textbook armature ODE (stiff at 1 Hz), no grade, constant resistance and "
                   "cooling, 10-20 % off")
    spec = "benchmarks.zoo.families.traction_drive:TractionDriveWhiteBox"
    columns = {"i": "armature_current", "w": "speed", "T": "winding_temp",
               "v": "armature_voltage", "ambient": "ambient_temp"}
    sample_interval = DT
    held_out = True
    channels = ("armature_current", "armature_voltage", "speed", "winding_temp", "ambient_temp")
    faults = (
        FaultKind("bearing", "bearing friction up: m N m of Coulomb torque more", (1.0, 3.0)),
        FaultKind("connection", "armature circuit resistance up by m (relative to the "
                  "winding's 0.05 ohm: a corroded connection, heating outside the winding)",
                  (0.1, 0.3)),
        FaultKind("demagnetisation", "motor constant k (torque and back-EMF) down by m "
                  "(relative)", (0.01, 0.03)),
        FaultKind("current_gain", "current sensor reads x (1 + m) (telemetry and the "
                  "current loop)", (0.03, 0.08)),
        FaultKind("cooling_loss", "the winding's cooling (still air and fan) down by m "
                  "(relative: a blocked duct, a broken fan blade)", (0.3, 0.6)),
        FaultKind("encoder_noise", "the speed telemetry's noise up by m rad/s rms (a worn code "
                  "wheel, a loose connector; the loop's own speed estimate filters it)",
                  (0.05, 0.2)),
    )

    def true_parameters(self, rng):
        return {"resistance": spread(rng, 0.05, 0.03), "inductance": spread(rng, 3.0e-4, 0.05),
                "k": spread(rng, 0.28, 0.005), "coulomb": spread(rng, 1.5, 0.1),
                "viscous": spread(rng, 0.008, 0.1), "iron": spread(rng, 1.0e-3, 0.1),
                "heat_capacity": spread(rng, 4000.0, 0.05),
                "thermal_resistance": spread(rng, 0.12, 0.05), "fan": spread(rng, 1.0, 0.1),
                "mass": spread(rng, 1200.0, 0.03), "drag_area": spread(rng, 0.7, 0.05),
                "rolling": spread(rng, 0.012, 0.08), "climate": float(rng.uniform(4.0, 26.0))}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        reference = np.stack([_reference(rng, total) for rng in batch.rngs]) / RATIO
        parked = (reference[:, :-1] == 0) & (reference[:, 1:] == 0)
        everyone_parked = parked.all(axis=0)
        ambient = ((p["climate"] + batch.uniform(-4.0, 4.0))[:, None]      # the day's weather
                   + batch.uniform(3.0, 6.0)[:, None] * np.sin(2 * np.pi * (hour - 9) / 24)[None, :]
                   + smooth_noise(batch, total, 1800 / DT, 0.3))
        grade = smooth_noise(batch, total, 90 / DT, 0.02)
        mass = p["mass"] + batch.uniform(0.0, 300.0)               # the day's payload
        inv_inertia = 1.0 / (MOTOR_INERTIA + mass * RATIO ** 2)
        aero = 0.5 * 1.2 * p["drag_area"] * RATIO ** 3
        rolling = mass * 9.81 * p["rolling"] * RATIO
        slope = mass * 9.81 * RATIO
        onset = batch.onset
        bearing = (batch.fault == "bearing") * batch.magnitude
        connection = (batch.fault == "connection") * batch.magnitude * 0.05
        demag = (batch.fault == "demagnetisation") * batch.magnitude
        gain_fault = (batch.fault == "current_gain") * batch.magnitude
        i, w, volts = np.zeros(size), np.zeros(size), np.zeros(size)
        integral_s, integral_c = np.zeros(size), np.zeros(size)
        temp = ambient[:, 0] + batch.uniform(0.0, 2.0)
        h = DT / SUBSTEPS
        out = {k: np.empty((size, n)) for k in ("i", "v", "w", "T")}
        for k in range(total):
            if k >= WARMUP:
                j = k - WARMUP
                out["i"][:, j], out["v"][:, j], out["w"][:, j], out["T"][:, j] = i, volts, w, temp
            on = t[k] >= onset
            r_winding = p["resistance"] * (1.0 + ALPHA * (temp - 25.0))
            if everyone_parked[k] and (w < 0.5).all():
                # the drive disabled everywhere: what the control periods below give exactly
                i, w, volts = np.zeros(size), np.zeros(size), np.zeros(size)
                integral_s, integral_c = np.zeros(size), np.zeros(size)
                squared = np.zeros(size)
            else:
                r_circuit = r_winding + connection * on
                decay = np.exp(-h * r_circuit / p["inductance"])
                # i relaxes toward (V - k w) / R: i' = a (V - k w) + decay i
                relax = (1.0 - decay) / r_circuit
                k_motor = p["k"] * (1.0 - demag * on)
                k_accel = (h * inv_inertia) * k_motor
                load = (h * inv_inertia) * (p["coulomb"] + bearing * on + rolling
                                            + slope * grade[:, k])
                viscous, drag = (h * inv_inertia) * p["viscous"], (h * inv_inertia) * aero
                gain = 1.0 + gain_fault * on
                target = reference[:, k].copy()
                step = (reference[:, k + 1] - reference[:, k]) / SUBSTEPS
                moving = ~parked[:, k]                          # the reference is not zero
                squared = np.zeros(size)
                for _ in range(SUBSTEPS):
                    error = target - w
                    integral_s += (KI * h) * error
                    np.maximum(integral_s, I_MIN, out=integral_s)
                    np.minimum(integral_s, I_MAX, out=integral_s)
                    wanted = KP * error
                    wanted += integral_s
                    np.maximum(wanted, I_MIN, out=wanted)
                    np.minimum(wanted, I_MAX, out=wanted)
                    integral_c += (KIC * h) * (wanted - gain * i)
                    np.maximum(integral_c, -INTEGRAL_V, out=integral_c)
                    np.minimum(integral_c, INTEGRAL_V, out=integral_c)
                    volts = K_NOMINAL * w
                    volts += R_NOMINAL * wanted
                    volts += integral_c
                    np.maximum(volts, 0.0, out=volts)
                    np.minimum(volts, V_BUS, out=volts)
                    run = ((w >= 0.5) | moving).astype(float)     # the drive enabled
                    volts *= run
                    integral_s *= run
                    integral_c *= run
                    i = (volts - k_motor * w) * relax + decay * i
                    i *= run
                    w += k_accel * i - load - (viscous + drag * w) * w
                    np.maximum(w, 0.0, out=w)
                    w *= run
                    squared += i * i
                    target += step
                squared /= SUBSTEPS
            cooling = ((1.0 + p["fan"] * w / 300.0) / p["thermal_resistance"]
                       * (1.0 - batch.active("cooling_loss", t[k])))
            heat = r_winding * squared + p["iron"] * w ** 2 - cooling * (temp - ambient[:, k])
            temp = temp + DT * heat / p["heat_capacity"]
        day = slice(WARMUP, total)
        gain = 1.0 + batch.active("current_gain", t[day])
        return {"armature_current": quantise(out["i"] * gain + batch.normal((n,), 0.5), 0.1),
                "armature_voltage": quantise(out["v"] + batch.normal((n,), 0.1), 0.05),
                "speed": quantise(out["w"] + batch.normal((n,), 0.02)
                                  + batch.normal((n,), batch.active("encoder_noise", t[day])), 0.01),
                "winding_temp": quantise(out["T"] + batch.normal((n,), 0.05), 0.01),
                "ambient_temp": quantise(ambient[:, day] + batch.normal((n,), 0.1), 0.01)}


FAMILY = TractionDrive()
