"""The hypothesis each fault kind of the gas-turbine grid should produce, and its true size.

Declared in the benchmark, not in the product: the product ranks hypotheses, the benchmark
knows what it injected.

``friction``
    The simulator adds a damping ``m gamma(omega_eq)`` around the moving equilibrium, which
    does not move (:mod:`graybox.simulation.plant`). In the shaft's white box
    ``J omega' = M1 - M2`` the one parameter that scales the damping rate and leaves the
    equilibrium alone is the inertia: ``J / (1 + m)`` has the faulty plant's linearised
    dynamics exactly (the fuel response scales alike). Expected: ``parameter inertia``, the
    implied magnitude ``J_baseline / J_estimate - 1``.
``bias``
    The speed sensor reads ``m`` rad/s high. Expected: ``omega sensor bias``, estimate ``m``.
``noise``
    The speed sensor's noise std times ``1 + m``. Expected: ``omega noise level``; the
    hypothesis measures the k-step errors' spread ``s``, of which the sensor noise is a part:
    ``s^2 = 1 + ((1 + m)^2 - 1) sensor^2 / residual_std^2``, so the implied magnitude is
    ``sqrt(1 + (s^2 - 1) residual_std^2 / sensor^2) - 1`` (the start's sensor noise, decayed
    over the horizon, neglected).
``nonlinear``, ``heavy_tails``
    No single physical hypothesis of the white box: what comes first is reported.
"""
from __future__ import annotations

import math

#: the speed channel's name in the white box (its output)
CHANNEL = "omega"
#: fault kind -> (hypothesis kind, target) expected first
EXPECTED = {"friction": ("parameter", "inertia"), "bias": ("bias", CHANNEL),
            "noise": ("noise", CHANNEL)}


def expected_hypothesis(fault: str) -> tuple[str, str] | None:
    """``(kind, target)`` of the hypothesis a fault kind should rank first, None when none."""
    return EXPECTED.get(fault)


def implied_magnitude(fault: str, estimate: float, baseline: float, *,
                      residual_std: float = math.nan, sensor_noise: float = math.nan) -> float:
    """The fault's magnitude, in the grid's units, that the expected hypothesis' estimate
    implies (NaN for a fault kind without one).

    >>> implied_magnitude("friction", 40.0, 50.0)
    0.25
    >>> implied_magnitude("bias", 0.48, 0.0)
    0.48
    >>> round(implied_magnitude("noise", math.sqrt(1 + 0.21 * 0.09 / 4.0), 1.0,
    ...                         residual_std=2.0, sensor_noise=0.3), 6)
    0.1
    """
    if fault == "friction":
        return baseline / estimate - 1.0 if estimate > 0 else math.nan
    if fault == "bias":
        return estimate
    if fault == "noise":
        inner = 1.0 + (estimate ** 2 - 1.0) * residual_std ** 2 / sensor_noise ** 2
        return math.sqrt(inner) - 1.0 if inner >= 0 else math.nan
    return math.nan
