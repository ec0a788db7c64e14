"""Everything random about one simulated vehicle: fuel rate, random moment, sensor noise,
jitter and drops, each from its own stream of the vehicle's seed.

The moment clock's streams (fuel wander, shocks, hence ``Gamma`` and the flutter) and the
fuel phase do not depend on the sampling interval; the others are drawn per sample.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from graybox.simulation.clock import MOMENT_STEP, SECONDS_PER_DAY, Clock
from graybox.simulation.faults import fault_level
from graybox.simulation.specs import FleetSpec, VehicleSpec

FUEL_MEAN = 1.0                 # mu0, kg/s
LOAD_AMPLITUDE = 0.25           # relative amplitude of the daily load cycle
WANDER_TIME = 7_200.0           # s, time constant of the OU wander of the fuel rate
WANDER_STD = 0.03               # relative std of the OU wander
FUEL_SENSOR_NOISE = 1e-4        # kg/s
MOMENT_POLE_RADIUS = 0.9
MOMENT_POLE_ANGLE = 2 * math.pi / 8

_BURN_IN = 1_000                # AR(2) moment steps discarded so Gamma starts stationary
_N_STREAMS = 8                  # independent random streams per vehicle, in this order:
_PHASE, _WANDER, _SHOCK, _SENSOR, _TAILS, _FUEL, _JITTER, _DROP = range(_N_STREAMS)


def moment_ar_coefficients() -> tuple[float, float]:
    """AR(2) coefficients ``(a1, a2)`` of the random moment: poles ``0.9 exp(+-i pi/4)``."""
    a1 = 2 * MOMENT_POLE_RADIUS * math.cos(MOMENT_POLE_ANGLE)
    a2 = -MOMENT_POLE_RADIUS ** 2
    return a1, a2


def _moment_innovation_scale(moment_std: float) -> float:
    """``sigma_u`` such that the AR(2) with unit-variance innovations has std ``moment_std``."""
    a1, a2 = moment_ar_coefficients()
    variance = (1 - a2) / ((1 + a2) * ((1 - a2) ** 2 - a1 ** 2))
    return moment_std / math.sqrt(variance)


def _hermite3(x: np.ndarray) -> np.ndarray:
    """The probabilists' Hermite polynomial ``He3(x) = x^3 - 3x``."""
    return x * (x * x - 3.0)


@dataclass
class Draws:
    """Everything random about one vehicle, on the grids of its :class:`Clock`."""

    # on the integration grid
    fuel: np.ndarray          # mu at the integration instants
    moment: np.ndarray        # Gamma, held over [t_j, t_j+1)
    friction: np.ndarray      # friction magnitude (of the moment step), held over [t_j, t_j+1)
    # on the moment clock
    moment_steps: np.ndarray  # Gamma_i
    innovation: np.ndarray    # u_i
    shock: np.ndarray         # e_i
    # on the output grid
    sensor: np.ndarray        # shaft-speed sensor noise (noise and heavy-tail faults included)
    bias: np.ndarray          # shaft-speed bias (rad/s)
    fuel_sensor: np.ndarray   # fuel-rate sensor noise
    jitter: np.ndarray        # timestamp offsets (s)
    keep: np.ndarray          # samples not dropped


def _fuel_rate(rngs, clock: Clock) -> np.ndarray:
    """``mu`` at the integration instants: the daily cycle, plus the wander drawn at the
    moment-step instants and linear between them."""
    phase = rngs[_PHASE].uniform(0.0, 2 * math.pi)
    rho = math.exp(-MOMENT_STEP / WANDER_TIME)
    # one knot past the last moment step, for instants inside that step; the normals are
    # drawn in sequence, so the other knots do not depend on it
    xi = rngs[_WANDER].standard_normal(clock.n_moment + 2)
    from scipy.signal import lfilter   # with scipy.stats 0.5 s: not at every command's start
    knots = lfilter([WANDER_STD * math.sqrt(1 - rho ** 2)], [1.0, -rho], xi[1:],
                    zi=[rho * WANDER_STD * xi[0]])[0]  # starts in the stationary law
    if clock.per_step == 1:
        wander = knots[:clock.n_int]
    else:
        step, within = np.divmod(np.arange(clock.n_int), clock.per_step)
        wander = knots[step] + (knots[step + 1] - knots[step]) * (within / clock.per_step)
    t = np.arange(clock.n_int) * clock.h
    return FUEL_MEAN * (1 + LOAD_AMPLITUDE * np.sin(2 * math.pi * t / SECONDS_PER_DAY + phase)
                        + wander)


def _moment(rngs, vehicle: VehicleSpec, clock: Clock):
    """``(Gamma_i, u_i, e_i)`` over the moment steps."""
    days = np.arange(clock.n_moment) * MOMENT_STEP / SECONDS_PER_DAY
    shock = rngs[_SHOCK].standard_normal(clock.n_moment + _BURN_IN)
    kappa = np.concatenate([np.zeros(_BURN_IN), fault_level(vehicle.faults, "nonlinear", days)])
    innovation = shock.copy()
    flutter = np.flatnonzero(kappa[1:]) + 1
    innovation[flutter] += kappa[flutter] * _hermite3(shock[flutter - 1])
    a1, a2 = moment_ar_coefficients()
    from scipy.signal import lfilter   # with scipy.stats 0.5 s: not at every command's start
    moment = lfilter([_moment_innovation_scale(vehicle.moment_std)], [1.0, -a1, -a2], innovation)
    return moment[_BURN_IN:], innovation[_BURN_IN:], shock[_BURN_IN:]


def draw(vehicle: VehicleSpec, spec: FleetSpec) -> Draws:
    """Every random input of ``vehicle`` in the fleet ``spec``, faults applied."""
    clock = Clock.of(spec)
    n, dt = clock.n, clock.dt
    seeds = np.random.SeedSequence(vehicle.seed).spawn(_N_STREAMS)
    rngs = [np.random.default_rng(s) for s in seeds]
    days = np.arange(n) * dt / SECONDS_PER_DAY
    faults = vehicle.faults

    fuel = _fuel_rate(rngs, clock)
    moment_steps, innovation, shock = _moment(rngs, vehicle, clock)
    # held over the moment steps like Gamma, so that a ramp is the same plant at every rate
    friction_steps = fault_level(faults, "friction",
                                  np.arange(clock.n_moment) * MOMENT_STEP / SECONDS_PER_DAY)
    moment, friction = (np.repeat(x, clock.per_step)[:clock.n_int]
                        for x in (moment_steps, friction_steps))

    z = rngs[_SENSOR].standard_normal(n)
    tails = fault_level(faults, "heavy_tails", days)
    heavy = tails > 0
    if heavy.any():
        # Student-t as z / sqrt(V / df), rescaled by sqrt((df - 2) / df) to unit variance
        df = np.maximum(2.1, 2.0 + 4.0 / tails[heavy])
        z[heavy] *= np.sqrt((df - 2.0) / rngs[_TAILS].chisquare(df))
    sensor = vehicle.sensor_noise * (1.0 + fault_level(faults, "noise", days)) * z

    fuel_sensor = FUEL_SENSOR_NOISE * rngs[_FUEL].standard_normal(n)
    jitter = np.zeros(n)
    if spec.jitter > 0:
        limit = 0.4 * dt
        jitter = np.clip(rngs[_JITTER].normal(0.0, spec.jitter, n), -limit, limit)
        # the measured span stays inside [start, end of the last sample]
        jitter[0], jitter[-1] = max(jitter[0], 0.0), min(jitter[-1], 0.0)
    keep = np.ones(n, dtype=bool)
    if spec.drop_fraction > 0:
        dropped = rngs[_DROP].random(n) < spec.drop_fraction
        dropped[0] = dropped[-1] = False
        for k in np.flatnonzero(dropped[2:]) + 2:
            if dropped[k - 1] and dropped[k - 2]:
                dropped[k] = False
        keep = ~dropped
    return Draws(fuel=fuel, moment=moment, friction=friction, moment_steps=moment_steps,
                  innovation=innovation, shock=shock, sensor=sensor,
                  bias=fault_level(faults, "bias", days), fuel_sensor=fuel_sensor,
                  jitter=jitter, keep=keep)
