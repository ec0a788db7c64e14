"""A lightly damped mechanical oscillator at 1 Hz: a tall mast swaying under measured wind load.

True plant: the mast's first bending mode, ``m x'' + c x' + k x + k3 x^3 + c2 x'|x'| = F + d``,
natural period about 20 s, damping ratio about 3 %, a hardening cubic stiffness ``k3`` and
aerodynamic quadratic damping ``c2``. ``F`` is the wind load from an anemometer-based load
estimate (measured, gusts with a correlation time of seconds, a mean and gustiness that change
from day to day and over the day); ``d`` the part of the turbulence the estimate misses.
Telemetry at 1 Hz: tip displacement (mm resolution) and velocity (a geophone), wind load.

The white box a user writes (:class:`MastWhiteBox`): the linear mode ``m x'' + c x' + k x = F``
with stiffness and damping 10-20 % off; the cubic stiffness and the aerodynamic damping are
left out.
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 1.0
SUBSTEPS = 8
WARMUP = 600


class MastWhiteBox(WhiteBoxModel):
    """Tip displacement ``x`` (m) and velocity ``v`` (m/s) of a linear mode under load ``F``
    (kN)."""

    states = ("x", "v")
    inputs = ("force",)
    default_parameters = {"mass": 1000.0, "stiffness": 115.0, "damping": 22.0}

    def derivatives(self, x, u):
        p = self.parameters
        position, velocity = x[..., 0], x[..., 1]
        acceleration = (1000.0 * u[..., 0] - p["stiffness"] * position
                        - p["damping"] * velocity) / p["mass"]
        return np.stack([velocity, acceleration], axis=-1)


class Oscillator(Family):
    name = "oscillator"
    title = "Lightly damped mast (1 Hz)"
    description = ("first bending mode (period ~20 s, damping ~3 %) with hardening stiffness and "
                   "aerodynamic damping, measured gusty wind load plus unmeasured turbulence; "
                   "white box: linear mode, 10-20 % off")
    spec = "benchmarks.zoo.families.oscillator:MastWhiteBox"
    columns = {"x": "tip_displacement", "v": "tip_velocity", "force": "wind_load"}
    sample_interval = DT
    held_out = True
    channels = ("tip_displacement", "tip_velocity", "wind_load")
    faults = (
        FaultKind("damping", "structural damping up by m (relative: a loose joint rubbing)",
                  (0.5, 1.5)),
        FaultKind("crack", "stiffness down by m (relative)", (0.03, 0.08)),
        FaultKind("gauge_gain", "displacement sensor reads m high (relative)", (0.03, 0.08)),
        FaultKind("geophone_noise", "velocity sensor noise x (1 + m)", (0.5, 2.0)),
    )

    def true_parameters(self, rng):
        return {"mass": spread(rng, 1000.0, 0.02), "stiffness": spread(rng, 100.0, 0.03),
                "k3": spread(rng, 80.0, 0.1), "damping": spread(rng, 19.0, 0.05),
                "c2": spread(rng, 30.0, 0.1)}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        n, t, hour, total = self.clock(WARMUP)
        mean = batch.uniform(0.0, 0.05)[:, None] * (1 + 0.5 * np.sin(2 * np.pi * (hour - 9) / 24))[None, :]
        gust = batch.uniform(0.02, 0.05)[:, None] * (0.6 + 0.4 * np.sin(2 * np.pi * (hour - 10) / 24))[None, :]
        force = mean + gust * smooth_noise(batch, total, 4.0)          # kN, 1-s samples
        missed = 0.006 * smooth_noise(batch, total * SUBSTEPS, 2.0 * SUBSTEPS)
        stiffness = p["stiffness"][:, None] * (1 - batch.active("crack", t))
        damping = p["damping"][:, None] * (1 + batch.active("damping", t))
        x = np.zeros(len(batch))
        v = np.zeros(len(batch))
        h = DT / SUBSTEPS
        xs, vs = np.empty((len(batch), n)), np.empty((len(batch), n))
        for k in range(total):
            for s in range(SUBSTEPS):
                load = 1000.0 * (force[:, k] + missed[:, k * SUBSTEPS + s])
                a = (load - stiffness[:, k] * x - p["k3"] * x ** 3 - damping[:, k] * v
                     - p["c2"] * v * np.abs(v)) / p["mass"]
                v = v + h * a                                        # semi-implicit Euler:
                x = x + h * v                                        # keeps the light damping
            if k >= WARMUP:
                xs[:, k - WARMUP], vs[:, k - WARMUP] = x, v
        day = slice(WARMUP, total)
        gain = 1 + batch.active("gauge_gain", t[day])
        velocity_noise = 0.002 * (1 + batch.active("geophone_noise", t[day]))
        return {"tip_displacement": quantise(xs * gain + batch.normal((n,), 0.002), 0.001),
                "tip_velocity": vs + batch.normal((n,), 1.0) * velocity_noise,
                "wind_load": quantise(force[:, day] + batch.normal((n,), 0.005), 0.001)}


FAMILY = Oscillator()
