"""The true plants of a fleet, vectorised over vehicles, and their RK4 integration over a
time grid cut into chunks that are integrated side by side.
"""
from __future__ import annotations

import math

import numpy as np

from graybox.exceptions import GrayBoxError
from graybox.models.gas_turbine import GasTurbineShaft
from graybox.rk4 import rk4_step

WARMUP_SECONDS = 1_500.0        # warm-up of each time chunk (25 decay times at gamma = 0.06)
CHUNK_SAMPLES = 512             # integration steps per time chunk (the warm-up is extra)
SPLICE_TOLERANCE = 1e-9         # rad/s, largest accepted mismatch where chunks meet


class Plant:
    """The true plants of a fleet: their white-box model, driven by its own dynamics.

    The vehicles' models are stacked into one (:meth:`WhiteBoxModel.stacked`: parameters as
    arrays over vehicles, last axis), so one call of the model's ``derivatives`` evaluates
    every vehicle. What the model lacks is added here, as the simulator's truth: the random
    moment ``M_r / J`` and the friction fault, an extra damping ``m gamma(omega_eq)`` around
    the moving equilibrium ``omega_eq(mu)`` (``m`` the fault's relative magnitude), so

    ``domega/dt = f(omega, mu) + M_r / J + m gamma(omega_eq) (omega_eq - omega)``.

    Parameters
    ----------
    models : list of GasTurbineShaft
        One per vehicle, all of one class (the friction fault needs its
        ``equilibrium_speed`` and ``damping_rate``).
    """

    def __init__(self, models: list[GasTurbineShaft]):
        self.model = type(models[0]).stacked(models)

    def subset(self, which) -> "Plant":
        """The plants of the vehicles selected by ``which`` (index or mask)."""
        sub = Plant.__new__(Plant)
        sub.model = self.model.subset(which)
        return sub

    def equilibrium(self, fuel):
        return self.model.equilibrium_speed(fuel)

    def forcing(self, fuel, moment, friction, with_friction: bool):
        """The terms the model lacks, which depend on the step's inputs only:
        ``(forcing, damping)`` with the drift's extra part ``forcing - damping * omega``."""
        if not with_friction:
            return moment, 0.0
        omega_eq = self.equilibrium(fuel)
        damping = friction * self.model.damping_rate(omega_eq)
        return moment + damping * omega_eq, damping

    def drift(self, omega, fuel, forcing, damping):
        """``domega/dt`` at ``omega`` for the fuel rate ``fuel``."""
        return (self.model.derivatives(omega[..., None], fuel[..., None])[..., 0]
                + forcing - damping * omega)


def _rk4_step(plant: Plant, omega, fuel0, fuel1, moment, friction, dt, substeps,
                with_friction):
    """Advance ``omega`` over one integration step: RK4, ``substeps`` steps, fuel linear."""
    fractions = np.arange(2 * substeps + 1) / (2 * substeps)
    shape = (-1,) + (1,) * np.ndim(omega)
    fuel = fuel0 + (fuel1 - fuel0) * fractions.reshape(shape)
    forcing, damping = plant.forcing(fuel, moment, friction, with_friction)
    forcing = np.broadcast_to(forcing, fuel.shape)
    damping = np.broadcast_to(damping, fuel.shape)

    def derivative(x, j):
        return plant.drift(x, fuel[j], forcing[j], damping[j])

    h = dt / substeps
    for s in range(substeps):
        omega = rk4_step(derivative, omega, 2 * s, 2 * s + 1, 2 * s + 2, h)
    return omega


def chunk_layout(n: int, dt: float, serial: bool) -> tuple[int, int, int, int]:
    """``(n_chunks, chunk, warmup, steps)``: chunk i integrates intervals ``i*chunk ...``."""
    warmup = int(math.ceil(WARMUP_SECONDS / dt))
    chunk = max(CHUNK_SAMPLES, 2 * warmup)
    if serial or n - 1 <= warmup + chunk:
        return 1, n - 1, 0, n - 1
    return int(math.ceil((n - 1 - warmup) / chunk)), chunk, warmup, warmup + chunk


def integrate(plant: Plant, omega0, fuel, moment, friction, dt, substeps, serial=False):
    """Shaft speed at the integration instants, shape ``(n, n_vehicles)``, and the splice
    mismatch."""
    n, n_vehicles = fuel.shape
    n_chunks, chunk, warmup, steps = chunk_layout(n, dt, serial)
    padded = (n_chunks - 1) * chunk + steps + 1

    def pad(a):
        return np.concatenate([a, np.repeat(a[-1:], padded - n, axis=0)])

    fuel, moment, friction = pad(fuel), pad(moment), pad(friction)
    with_friction = bool(np.any(friction != 0))
    omega = np.empty((padded, n_vehicles))
    omega[0] = omega0
    state = np.empty((n_chunks, n_vehicles))
    state[0] = omega0
    state[1:] = plant.equilibrium(fuel[chunk:(n_chunks - 1) * chunk + 1:chunk])
    last = (n_chunks - 1) * chunk  # offset of the last chunk
    mismatch = np.zeros(n_vehicles)
    for r in range(steps):
        state = _rk4_step(plant, state, fuel[r:r + last + 1:chunk],
                            fuel[r + 1:r + last + 2:chunk], moment[r:r + last + 1:chunk],
                            friction[r:r + last + 1:chunk], dt, substeps, with_friction)
        s = r + 1
        if s < warmup:
            omega[s] = state[0]          # later chunks are still warming up
        elif s < steps or n_chunks == 1:
            omega[s:s + last + 1:chunk] = state
        else:
            # chunk i ends where chunk i+1 took over after its warm-up: they must agree
            taken = omega[chunk + warmup:last + warmup + 1:chunk]
            mismatch = np.max(np.abs(state[:-1] - taken), axis=0, initial=0.0)
            mismatch[~np.isfinite(state[:-1]).all(axis=0)] = np.inf
    return omega[:n], mismatch


def integrate_fleet(plant: Plant, omega0, fuel, moment, friction, dt, substeps):
    """:func:`integrate` every vehicle, serially those whose chunk splices disagree."""
    has_friction = np.any(friction != 0, axis=0)
    groups = [g for g in (~has_friction, has_friction) if g.any()]
    omega = None if len(groups) == 1 else np.empty_like(fuel)
    # vehicles without a friction fault skip its (costly) terms; the terms would add exact
    # zeros, so the grouping does not change any vehicle's numbers
    for group in groups:
        if omega is None:
            sub, args = plant, (omega0, fuel, moment, friction)
        else:
            sub, args = plant.subset(group), (omega0[group], fuel[:, group], moment[:, group],
                                              friction[:, group])
        result, mismatch = integrate(sub, *args, dt, substeps)
        weak = ~(mismatch <= SPLICE_TOLERANCE)
        if weak.any():
            # weakly damped plant: the warm-up did not forget its start; integrate serially
            result[:, weak], _ = integrate(sub.subset(weak), *(a[..., weak] for a in args),
                                            dt, substeps, serial=True)
        if omega is None:
            omega = result
        else:
            omega[:, group] = result
    if not np.isfinite(omega).all():
        raise GrayBoxError("the simulated shaft speed is not finite (unstable plant parameters?)")
    return omega
