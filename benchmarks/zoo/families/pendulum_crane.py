"""A crane's swinging load at 1 Hz: a nonlinear pendulum driven by the trolley.

True plant: a load on a rope of length ``L`` (about 20 m: period about 9 s) hangs from a trolley
whose acceleration ``a`` is measured::

    L theta'' + c theta' + c2 L theta'|theta'| + g sin(theta) = -a cos(theta) + d

with light viscous damping ``c``, quadratic air drag ``c2`` and wind ``d``. The trolley moves
loads during working hours (trapezoidal moves of random length and speed, an operator's
anti-sway habit of waiting a random while between moves; the number of moves differs by day)
and stands still at night, when only the wind swings the load. Swings reach tenths of a
radian, where ``sin`` and ``cos`` are far from linear. Telemetry at 1 Hz: rope angle and angular
rate (an inertial sensor on the hook block) and the trolley's acceleration.

The white box a user writes (:class:`CraneWhiteBox`): the small-angle pendulum
``L theta'' + c theta' + g theta = -a`` with the damping 10-20 % off and the rope length a
nominal one; ``sin``, ``cos`` and the air drag are left out, so the residual holds an odd
function of the swing that the network tier must describe.
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import DayBatch, Family, FaultKind, smooth_noise, spread
from graybox.models.base import WhiteBoxModel

DT = 1.0
SUBSTEPS = 8
WARMUP = 900
G = 9.81


class CraneWhiteBox(WhiteBoxModel):
    """Rope angle ``theta`` (rad) and rate ``omega`` (rad/s); input trolley acceleration ``a``
    (m/s^2). Small-angle pendulum."""

    states = ("theta", "omega")
    inputs = ("a",)
    default_parameters = {"length": 19.0, "damping": 0.06}

    def derivatives(self, x, u):
        p = self.parameters
        theta, omega = x[..., 0], x[..., 1]
        return np.stack([omega, -(G * theta + u[..., 0]) / p["length"] - p["damping"] * omega],
                        axis=-1)


class PendulumCrane(Family):
    name = "pendulum_crane"
    title = "Crane load swing (1 Hz, nonlinear)"
    description = ("pendulum with large swings, quadratic air drag and wind, driven by the "
                   "trolley's moves on working hours; white box: small-angle linear pendulum, "
                   "damping 10-20 % off")
    spec = "benchmarks.zoo.families.pendulum_crane:CraneWhiteBox"
    columns = {"theta": "rope_angle", "omega": "rope_rate", "a": "trolley_accel"}
    sample_interval = DT
    held_out = True
    channels = ("rope_angle", "rope_rate", "trolley_accel")
    faults = (
        FaultKind("damping", "viscous damping up by m (relative: a sheave bearing rubbing)",
                  (0.5, 1.5)),
        FaultKind("rope", "rope longer by m (relative: a slipping drum brake)", (0.03, 0.08)),
        FaultKind("angle_bias", "angle sensor reads m rad high", (0.01, 0.03)),
        FaultKind("rate_noise", "rate sensor noise x (1 + m)", (0.5, 2.0)),
    )

    def true_parameters(self, rng):
        return {"length": spread(rng, 21.0, 0.03), "damping": spread(rng, 0.05, 0.05),
                "drag": spread(rng, 0.08, 0.1), "wind": spread(rng, 0.02, 0.1)}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        n, t, hour, total = self.clock(WARMUP)
        accel = np.zeros((len(batch), total))
        for i, rng in enumerate(batch.rngs):
            k = int(rng.uniform(5, 90))                   # seconds until the first move
            while k < total:
                h = (t[k] / 3600.0) % 24.0
                if 6.0 <= h < 20.0:
                    ramp, cruise = int(rng.uniform(3, 8)), int(rng.uniform(5, 40))
                    level = rng.uniform(0.2, 0.6) * rng.choice([-1.0, 1.0])
                    accel[i, k:k + ramp] = level
                    accel[i, k + ramp + cruise:k + 2 * ramp + cruise] = -level
                    k += 2 * ramp + cruise + int(rng.exponential(rng.uniform(40, 150)))
                else:
                    k += 600
        wind = p["wind"][:, None] * smooth_noise(batch, total * SUBSTEPS, 5.0 * SUBSTEPS)
        length = p["length"][:, None] * (1 + batch.active("rope", t))
        damping = p["damping"][:, None] * (1 + batch.active("damping", t))
        theta = np.zeros(len(batch))
        omega = np.zeros(len(batch))
        h = DT / SUBSTEPS
        angles, rates = np.empty((len(batch), n)), np.empty((len(batch), n))
        for k in range(total):
            for s in range(SUBSTEPS):
                alpha = (-(G * np.sin(theta) + accel[:, k] * np.cos(theta)) / length[:, k]
                         - damping[:, k] * omega - p["drag"] * omega * np.abs(omega)
                         + wind[:, k * SUBSTEPS + s])
                omega = omega + h * alpha                            # semi-implicit Euler
                theta = theta + h * omega
            if k >= WARMUP:
                angles[:, k - WARMUP], rates[:, k - WARMUP] = theta, omega
        day = slice(WARMUP, total)
        bias = batch.active("angle_bias", t[day])
        rate_noise = 0.001 * (1 + batch.active("rate_noise", t[day]))
        return {"rope_angle": angles + bias + batch.normal((n,), 0.001),
                "rope_rate": rates + batch.normal((n,), 1.0) * rate_noise,
                "trolley_accel": accel[:, day] + batch.normal((n,), 0.005)}


FAMILY = PendulumCrane()
