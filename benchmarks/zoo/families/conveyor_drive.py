"""An electric conveyor drive at 1 Hz: a motor under a speed loop, a belt load, a winding that
heats.

True plant: the motor's speed ``w`` follows ``J w' = k_t i - T_c sign(w) - b w - r F_belt``,
where the current ``i`` is set by a PI speed controller closed every quarter second (the
electrical dynamics, milliseconds, are not seen at 1 Hz; the drive reports each second's mean
current), the belt force grows with the load on the belt (a belt scale measures it)
and with friction that drifts; the winding temperature follows
``C T' = R(T) i^2 + k_fe w^2 - (T - T_amb) / R_th(w)``, with the copper resistance rising with
temperature, iron losses, and a shaft-mounted fan whose cooling grows with speed. The speed
set point changes a few times a day with production; the belt load follows the material flow.
Telemetry at 1 Hz: speed (an encoder), winding temperature, motor current, belt load, ambient
temperature.

The white box a user writes (:class:`DriveWhiteBox`): ``J w' = k_t i - b w - k_l load`` and
``C T' = R i^2 - (T - T_amb) / R_th``: no Coulomb friction, no iron losses, constant resistance
and cooling, parameters 10-20 % off.
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 1.0
SUBSTEPS = 4
WARMUP = 3 * 3600


class DriveWhiteBox(WhiteBoxModel):
    """Speed ``w`` (rad/s) and winding temperature ``T`` (C); inputs current (A), belt load
    (kN) and ambient temperature (C)."""

    states = ("w", "T")
    inputs = ("current", "load", "ambient")
    controlled_inputs = ("current",)  # the speed loop sets it
    default_parameters = {"inertia": 6.0, "torque_constant": 1.7, "viscous": 0.22,
                          "load_torque": 38.0, "heat_capacity": 5.5e4, "resistance": 0.085,
                          "thermal_resistance": 0.042}

    def derivatives(self, x, u):
        p = self.parameters
        w, temp = x[..., 0], x[..., 1]
        current, load, ambient = u[..., 0], u[..., 1], u[..., 2]
        dw = (p["torque_constant"] * current - p["viscous"] * w - p["load_torque"] * load) / p["inertia"]
        dT = (p["resistance"] * current ** 2
              - (temp - ambient) / p["thermal_resistance"]) / p["heat_capacity"]
        return np.stack([dw, dT], axis=-1)


class ConveyorDrive(Family):
    name = "conveyor_drive"
    title = "Conveyor drive (1 Hz)"
    description = ("speed-controlled motor with Coulomb and drifting belt friction, belt load, "
                   "winding heated by copper and iron losses and cooled by a shaft fan; white "
                   "box: linear friction, constant resistance and cooling, 10-20 % off")
    spec = "benchmarks.zoo.families.conveyor_drive:DriveWhiteBox"
    columns = {"w": "speed", "T": "winding_temp", "current": "motor_current",
               "load": "belt_load", "ambient": "ambient_temp"}
    sample_interval = DT
    held_out = False
    channels = ("speed", "winding_temp", "motor_current", "belt_load", "ambient_temp")
    faults = (
        FaultKind("bearing", "bearing friction up: m N m of Coulomb torque more", (2.0, 5.0)),
        FaultKind("cooling", "fan cooling down by m (relative: a clogged fan cover)", (0.15, 0.35)),
        FaultKind("winding", "winding resistance up by m (relative: a loose connection)",
                  (0.1, 0.25)),
        FaultKind("encoder_noise", "speed encoder noise x (1 + m)", (1.0, 3.0)),
    )

    def true_parameters(self, rng):
        return {"inertia": spread(rng, 5.0, 0.03), "torque_constant": spread(rng, 1.9, 0.02),
                "coulomb": spread(rng, 6.0, 0.1), "viscous": spread(rng, 0.25, 0.05),
                "load_torque": spread(rng, 45.0, 0.03), "heat_capacity": spread(rng, 6.5e4, 0.03),
                "resistance": spread(rng, 0.075, 0.03), "iron": spread(rng, 2.5e-3, 0.05),
                "thermal_resistance": spread(rng, 0.05, 0.03)}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        n, t, hour, total = self.clock(WARMUP)
        setpoints = batch.uniform(90.0, 150.0, (6,))                    # rad/s, per 4-h shift
        reference = setpoints[:, (hour // 4).astype(int)]
        load = np.clip(batch.uniform(0.6, 1.2)[:, None]
                       + 0.25 * smooth_noise(batch, total, 600 / DT), 0.05, None)
        friction = 1 + 0.05 * smooth_noise(batch, total, 4 * 3600 / DT)
        ambient = (batch.uniform(10.0, 30.0)[:, None]
                   + 4 * np.sin(2 * np.pi * (hour - 9) / 24)[None, :])
        coulomb = p["coulomb"][:, None] + batch.active("bearing", t)
        cooling = 1 - batch.active("cooling", t)
        resistance = p["resistance"][:, None] * (1 + batch.active("winding", t))
        w = reference[:, 0].copy()
        temp = ambient[:, 0] + 30.0
        integral = np.full(len(batch), 30.0)
        shocks = batch.normal((total,), 1.0)
        out = {k: np.empty((len(batch), n)) for k in ("w", "T", "i")}
        h = DT / SUBSTEPS
        for k in range(total):
            logged_current = np.zeros(len(batch))
            for _ in range(SUBSTEPS):
                # the drive closes its speed loop every sub-step (a real one runs at a kHz);
                # once per 1-s sample, a loop gain of k_t * 8 / J ~ 3 per second made it chatter
                error = reference[:, k] - w
                integral = np.clip(integral + 2.0 * error * h, -50.0, 200.0)
                current = np.clip(8.0 * error + integral, -20.0, 250.0)
                logged_current += current / SUBSTEPS
                torque = (p["torque_constant"] * current - coulomb[:, k] * np.sign(w)
                          - p["viscous"] * friction[:, k] * w - p["load_torque"] * load[:, k])
                r_hot = resistance[:, k] * (1 + 0.0039 * (temp - 20.0))
                r_th = p["thermal_resistance"] / (cooling[:, k] * (0.4 + 0.6 * w / 150.0))
                heat = r_hot * current ** 2 + p["iron"] * w ** 2 - (temp - ambient[:, k]) / r_th
                w = w + h * torque / p["inertia"]
                temp = temp + h * heat / p["heat_capacity"]
            w = w + 0.05 * shocks[:, k]                               # belt stick-slip
            if k >= WARMUP:
                out["w"][:, k - WARMUP], out["T"][:, k - WARMUP] = w, temp
                out["i"][:, k - WARMUP] = logged_current   # the drive reports the second's mean
        day = slice(WARMUP, total)
        encoder = 0.05 * (1 + batch.active("encoder_noise", t[day]))
        return {"speed": out["w"] + batch.normal((n,), 1.0) * encoder,
                "winding_temp": quantise(out["T"] + batch.normal((n,), 0.05), 0.01),
                "motor_current": quantise(out["i"] + batch.normal((n,), 0.2), 0.01),
                "belt_load": quantise(load[:, day] + batch.normal((n,), 0.01), 0.001),
                "ambient_temp": quantise(ambient[:, day] + batch.normal((n,), 0.1), 0.01)}


FAMILY = ConveyorDrive()
