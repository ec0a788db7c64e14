"""The paper's gas turbine shaft (Eq. 5) and its linearized Langevin form (Eq. 8)."""
from __future__ import annotations

import numpy as np

from graybox.exceptions import ModelSpecError
from graybox.models.base import WhiteBoxModel


class GasTurbineShaft(WhiteBoxModel):
    r"""Shaft speed of a single-shaft gas turbine, Eq. 5 of the paper.

    .. math:: J \dot\omega = M_1(\omega, \mu) - M_2(\omega) - M_r(t)

    with the parametric moments used throughout this project

    .. math::
        M_1(\omega, \mu) = a\,\mu - b\,\omega \qquad\text{(turbine)}

        M_2(\omega) = c\,\omega + d\,\omega^2 \qquad\text{(compressor, bearings)}

    The stability conditions 6a/6b hold for every ``omega >= 0`` when ``b > 0``, ``c > 0``
    and ``d >= 0``: ``dM1/domega = -b < 0`` and ``dM2/domega = c + 2 d omega > 0``; this is
    checked on construction. The random moment ``M_r`` is what the model lacks; it is left in
    the residual.

    States: ``omega`` (rad/s). Inputs: ``fuel_rate`` (``mu``, kg/s).

    The defaults put the equilibrium at ``omega = 1000`` rad/s for ``mu = 1`` kg/s with a
    damping rate ``gamma = 0.06`` 1/s there (see :meth:`damping_rate`).

    Diagnosable (:mod:`graybox.diagnosis`): ``inertia``, ``turbine_gain``,
    ``compressor_linear`` (the linear friction of compressor and bearings) and
    ``compressor_quadratic``; not ``turbine_slope``, which enters the shaft only in the sum
    ``b + c`` with ``compressor_linear`` and so would tie with it.
    """

    states = ("omega",)
    inputs = ("fuel_rate",)
    diagnosable = ("inertia", "turbine_gain", "compressor_linear", "compressor_quadratic")
    default_parameters = {
        "inertia": 50.0,            # J, kg m^2
        "turbine_gain": 2250.0,     # a, N m per kg/s of fuel
        "turbine_slope": 1.0,       # b, N m s
        "compressor_linear": 0.5,   # c, N m s
        "compressor_quadratic": 0.00075,  # d, N m s^2
    }

    def check_parameters(self) -> None:
        p = self.parameters
        if p["inertia"] <= 0:
            raise ModelSpecError(f"{type(self).__name__}: inertia must be > 0")
        if p["turbine_slope"] <= 0 or p["compressor_linear"] <= 0 or p["compressor_quadratic"] < 0:
            raise ModelSpecError(
                f"{type(self).__name__}: stability conditions 6a/6b need turbine_slope > 0, "
                f"compressor_linear > 0 and compressor_quadratic >= 0, got {p}")

    def turbine_moment(self, omega, fuel_rate):
        """``M1(omega, mu) = a mu - b omega``."""
        p = self.parameters
        return p["turbine_gain"] * fuel_rate - p["turbine_slope"] * omega

    def compressor_moment(self, omega):
        """``M2(omega) = c omega + d omega**2``."""
        p = self.parameters
        return p["compressor_linear"] * omega + p["compressor_quadratic"] * omega ** 2

    def derivatives(self, x, u):
        omega, fuel_rate = x[..., 0], u[..., 0]
        net = self.turbine_moment(omega, fuel_rate) - self.compressor_moment(omega)
        return (net / self.parameters["inertia"])[..., None]

    def damping_rate(self, omega):
        r"""``gamma = -(1/J) d(M1 - M2)/domega`` at ``omega`` (Eq. 9, positive when stable).

        The paper prints Eq. 9 as ``(1/J)[dM1/domega - dM2/domega] > 0``, which contradicts
        6b; with Eq. 8 written as ``domega/dt = -gamma omega + Gamma`` the sign is the one here.
        """
        p = self.parameters
        slope = p["turbine_slope"] + p["compressor_linear"] + 2 * p["compressor_quadratic"] * omega
        return slope / p["inertia"]

    def equilibrium_speed(self, fuel_rate):
        """The steady-state ``omega`` for a constant fuel rate (root of ``M1 = M2``).

        Written ``2 a mu / (b + c + sqrt((b + c)^2 + 4 d a mu))``, the root without
        cancellation, which also holds for ``d = 0``.
        """
        p = self.parameters
        drive = p["turbine_gain"] * np.asarray(fuel_rate, dtype=float)
        slope = p["turbine_slope"] + p["compressor_linear"]
        return 2 * drive / (slope + np.sqrt(slope ** 2 + 4 * p["compressor_quadratic"] * drive))


class LangevinShaft(WhiteBoxModel):
    r"""The linearized shaft, Eq. 8: a Langevin equation around an operating point.

    .. math:: \dot\omega = -\gamma\,(\omega - \omega_{ref}) + k\,(\mu - \mu_{ref}) + \Gamma(t)

    With ``omega_ref = 0`` and ``fuel_gain = 0`` this is exactly Eq. 8,
    ``domega/dt = -gamma omega + Gamma``. The defaults linearize :class:`GasTurbineShaft`'s
    defaults at ``mu = 1``: ``gamma = 0.06``, ``k = a / J = 45``.
    """

    states = ("omega",)
    inputs = ("fuel_rate",)
    default_parameters = {
        "gamma": 0.06,        # 1/s
        "omega_ref": 1000.0,  # rad/s
        "fuel_ref": 1.0,      # kg/s
        "fuel_gain": 45.0,    # rad/s^2 per kg/s
    }

    def check_parameters(self) -> None:
        if self.parameters["gamma"] <= 0:
            raise ModelSpecError(f"{type(self).__name__}: gamma must be > 0 (Eq. 9)")

    def derivatives(self, x, u):
        p = self.parameters
        drive = p["fuel_gain"] * (u[..., 0] - p["fuel_ref"])
        return (-p["gamma"] * (x[..., 0] - p["omega_ref"]) + drive)[..., None]
