"""White boxes of the extended contract used by the tests: a hidden state with a table in the
output map and direct feed-through, a stiff armature, and a model with a wrong sign."""
from __future__ import annotations

import numpy as np

from graybox.models.base import WhiteBoxModel
from graybox.models.table import Table

#: a convex open-circuit-voltage-like curve over the hidden charge
CURVE = Table((0.0, 0.25, 0.5, 0.75, 1.0), (3.0, 3.45, 3.7, 3.9, 4.2))


class HiddenCharge(WhiteBoxModel):
    """A measured temperature ``temp`` and a hidden charge ``q`` (integrating the current with
    a slow leak); the measured voltage is ``curve(q) - r * current`` (a table, and
    feed-through)."""

    states = ("q", "temp")
    outputs = ("voltage", "temp")
    inputs = ("current",)
    default_parameters = {"capacity": 3600.0, "leak": 1e-4, "r": 0.05, "heating": 0.002,
                          "cooling": 0.01, "curve": CURVE}
    initial_state = {"q": 0.5}

    def derivatives(self, x, u):
        p = self.parameters
        q, temp, current = x[..., 0], x[..., 1], u[..., 0]
        dq = -current / p["capacity"] - p["leak"] * (q - 0.5)
        dtemp = p["heating"] * current ** 2 - p["cooling"] * temp
        return np.stack([dq, dtemp], axis=-1)

    def output(self, x, u):
        p = self.parameters
        return np.stack([p["curve"](x[..., 0]) - p["r"] * u[..., 0], x[..., 1]], axis=-1)


class Armature(WhiteBoxModel):
    """A permanent-magnet DC motor: armature current ``i`` (L/R = 6 ms, the stiff state) and
    speed ``w`` under a voltage ``v``, without load."""

    states = ("i", "w")
    inputs = ("v",)
    default_parameters = {"resistance": 0.05, "inductance": 3e-4, "k": 0.5, "inertia": 2.0,
                          "friction": 0.4}

    def derivatives(self, x, u):
        p = self.parameters
        i, w, v = x[..., 0], x[..., 1], u[..., 0]
        di = (v - p["resistance"] * i - p["k"] * w) / p["inductance"]
        dw = (p["k"] * i - p["friction"] * w) / p["inertia"]
        return np.stack([di, dw], axis=-1)

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """``A`` and ``B`` of the (linear) model."""
        p = self.parameters
        a = np.array([[-p["resistance"] / p["inductance"], -p["k"] / p["inductance"]],
                      [p["k"] / p["inertia"], -p["friction"] / p["inertia"]]])
        return a, np.array([[1.0 / p["inductance"]], [0.0]])


class WrongSign(WhiteBoxModel):
    """A first-order lag toward its input written with the wrong sign: ``x' = (u + x) / tau``
    (it should read ``(u - x) / tau``), with a 50-ms time constant."""

    states = ("x",)
    inputs = ("u",)
    default_parameters = {"tau": 0.05}

    def derivatives(self, x, u):
        return (u + x) / self.parameters["tau"]
