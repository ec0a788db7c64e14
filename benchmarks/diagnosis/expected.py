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
    hypothesis measures the one-step innovations' spread ``s``, of which the sensor's noise is
    a share ``c``: ``s^2 = 1 + c ((1 + m)^2 - 1)``. ``c`` depends on the plant's process noise
    and is not known to the product, so the implied magnitude is ``s - 1``, a lower bound of
    ``m`` (equal where the sensor's noise is all of the innovations).
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


def implied_magnitude(fault: str, estimate: float, baseline: float) -> float:
    """The fault's magnitude, in the grid's units, that the expected hypothesis' estimate
    implies (NaN for a fault kind without one).

    >>> implied_magnitude("friction", 40.0, 50.0)
    0.25
    >>> implied_magnitude("bias", 0.48, 0.0)
    0.48
    >>> round(implied_magnitude("noise", 1.13, 1.0), 6)
    0.13
    """
    if fault == "friction":
        return baseline / estimate - 1.0 if estimate > 0 else math.nan
    if fault == "bias":
        return estimate
    if fault == "noise":
        return estimate - 1.0
    return math.nan
