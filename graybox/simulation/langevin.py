"""The Langevin equation (Eq. 8) integrated with a given force."""
from __future__ import annotations

from typing import Callable

import numpy as np

from graybox.rk4 import rk4_step
from graybox.simulation.checks import finite, integer


def simulate_langevin(n: int, dt: float, gamma: float, force: np.ndarray | Callable | None,
                      omega0: float = 0.0, substeps: int = 20, seed=None) -> np.ndarray:
    """Integrate Eq. 8, ``domega/dt = -gamma omega + Gamma(t)``, with a given force.

    Classical RK4 with ``substeps`` steps per sample. Because the equation is linear, one RK4
    step is an affine map ``omega -> R omega + c_j``; it is applied as that recurrence, which is
    the same RK4 without a Python loop.

    Parameters
    ----------
    n : int
        Number of grid samples (>= 1); the grid is ``t_k = k dt``.
    dt : float
        Sample interval.
    gamma : float
        Damping rate.
    force : ndarray of shape (n,), callable or None
        ``Gamma`` at the grid instants (interpolated linearly between them), or a callable of
        an ndarray of times returning ``Gamma`` there (a scalar is broadcast), or ``None`` for a
        standard Gaussian force at the grid instants drawn from ``seed``.
    omega0 : float, default 0.0
        ``omega(0)``.
    substeps : int, default 20
    seed : int, Generator or None
        Only used when ``force`` is None.

    Returns
    -------
    ndarray of shape (n,)
        ``omega`` at the grid instants.
    """
    n = integer(n, "n", 1)
    substeps = integer(substeps, "substeps", 1)
    dt, gamma = finite(dt, "dt"), finite(gamma, "gamma")
    times = np.arange(2 * substeps * (n - 1) + 1) * (dt / (2 * substeps))
    if force is None:
        force = np.random.default_rng(seed).standard_normal(n)
    if callable(force):
        values = np.broadcast_to(np.asarray(force(times), dtype=float), times.shape)
    else:
        force = np.asarray(force, dtype=float)
        if force.shape != (n,):
            raise ValueError(f"force must have shape ({n},), got {force.shape}")
        values = np.interp(times, np.arange(n) * dt, force)
    h = dt / substeps

    def derivative(omega, force):
        return -gamma * omega + force

    def step(omega, fa, fm, fb):
        return rk4_step(derivative, omega, fa, fm, fb, h)

    amplification = step(1.0, 0.0, 0.0, 0.0)
    offsets = step(0.0, values[0:-1:2], values[1::2], values[2::2])
    from scipy.signal import lfilter   # with scipy.stats 0.5 s: not at every command's start
    fine = lfilter([1.0], [1.0, -amplification], offsets, zi=[amplification * omega0])[0]
    return np.concatenate([[float(omega0)], fine[substeps - 1::substeps]])
