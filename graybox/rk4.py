"""One classical Runge-Kutta (RK4) step, shared by the residual and the simulators."""
from __future__ import annotations

from typing import Any, Callable


def rk4_step(f: Callable[[Any, Any], Any], x, u0, um, u1, h: float):
    """Advance ``dx/dt = f(x, u)`` by one classical RK4 step of length ``h``.

    Parameters
    ----------
    f : callable
        ``f(x, u)``, the derivative of the state ``x`` under the input ``u``; it must work
        elementwise on whatever ``x`` is (a float, or an array of states).
    x : float or ndarray
        The state at the start of the step.
    u0, um, u1 : object
        The input at the start, the midpoint and the end of the step, passed to ``f`` as they
        are (values, or anything ``f`` knows how to read, such as an index into precomputed
        coefficients).
    h : float
        The step length.

    Returns
    -------
    float or ndarray
        The state at the end of the step,
        ``x + h/6 (k1 + 2 k2 + 2 k3 + k4)`` with ``k1 = f(x, u0)``,
        ``k2 = f(x + h/2 k1, um)``, ``k3 = f(x + h/2 k2, um)`` and ``k4 = f(x + h k3, u1)``.

    Notes
    -----
    The arithmetic is written out in one fixed order (``x + 0.5 * h * k``, then
    ``x + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)``, summed left to right): the one-step
    residual, the Langevin simulator and the fleet simulator all used this order before they
    shared it, so their outputs did not change by a bit.
    """
    half = 0.5 * h
    k1 = f(x, u0)
    k2 = f(x + half * k1, um)
    k3 = f(x + half * k2, um)
    k4 = f(x + h * k3, u1)
    return x + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)

