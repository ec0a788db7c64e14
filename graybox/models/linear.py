"""Linear state-space models ``dx/dt = A x + B u``."""
from __future__ import annotations

import numpy as np

from graybox.exceptions import ModelSpecError
from graybox.models.base import WhiteBoxModel


def linear_parameters(states, inputs, A, B) -> dict[str, float]:
    """Name the entries of ``A`` and ``B`` as model parameters.

    ``A[i][j]`` becomes ``"A_<state i>_<state j>"`` and ``B[i][k]`` becomes
    ``"B_<state i>_<input k>"``, so a configuration can override single entries.
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float).reshape(len(states), len(inputs))
    if A.shape != (len(states), len(states)):
        raise ModelSpecError(f"A must be {len(states)}x{len(states)}, got {A.shape}")
    names = {f"A_{si}_{sj}": A[i, j] for i, si in enumerate(states) for j, sj in enumerate(states)}
    names.update({f"B_{si}_{uk}": B[i, k] for i, si in enumerate(states) for k, uk in enumerate(inputs)})
    return {key: float(value) for key, value in names.items()}


class LinearStateSpace(WhiteBoxModel, abstract=True):
    """Base of linear models ``dx/dt = A x + B u``.

    A subclass declares ``states`` and ``inputs`` and sets ``default_parameters`` with
    :func:`linear_parameters`; every matrix entry is then a named parameter. The entries
    are signed coefficients (a coupling may change sign): none is ``positive``.
    """

    positive = ()

    def __init_subclass__(cls, abstract: bool = False, **kwargs):
        super().__init_subclass__(abstract=abstract, **kwargs)
        if not abstract:
            expected = set(linear_parameters(cls.states, cls.inputs,
                                             np.zeros((len(cls.states),) * 2),
                                             np.zeros((len(cls.states), len(cls.inputs)))))
            if set(cls.default_parameters) != expected:
                raise ModelSpecError(
                    f"{cls.__qualname__}: default_parameters must be exactly the A_/B_ entries "
                    f"{sorted(expected)}; build them with linear_parameters()")

    @property
    def A(self) -> np.ndarray:
        """The state matrix, shape (n_states, n_states)."""
        p = self.parameters
        return np.array([[p[f"A_{si}_{sj}"] for sj in self.states] for si in self.states])

    @property
    def B(self) -> np.ndarray:
        """The input matrix, shape (n_states, n_inputs)."""
        p = self.parameters
        return np.array([[p[f"B_{si}_{uk}"] for uk in self.inputs] for si in self.states]
                        ).reshape(len(self.states), len(self.inputs))

    def check_parameters(self) -> None:
        eigenvalues = np.linalg.eigvals(self.A)
        if np.any(eigenvalues.real >= 0):
            raise ModelSpecError(
                f"{type(self).__name__}: A must be stable (eigenvalues with negative real part), "
                f"got {np.round(eigenvalues, 6).tolist()}")

    def derivatives(self, x, u):
        return x @ self.A.T + u @ self.B.T


class DriveTrain(LinearStateSpace):
    """Two inertias coupled by a flexible shaft, linearized: a two-channel example model.

    States: ``omega_turbine`` and ``omega_load`` (rad/s). Input: ``torque`` (N m).
    """

    states = ("omega_turbine", "omega_load")
    inputs = ("torque",)
    default_parameters = linear_parameters(
        states, inputs,
        A=[[-0.08, 0.05],
           [0.04, -0.10]],
        B=[[0.02],
           [0.0]],
    )


class PumpLoop(LinearStateSpace):
    """A pump in a cooling loop under pressure control, linearized: a four-state,
    two-input example model.

    States: ``speed`` (pump speed, rad/s), ``flow`` (m3/h), ``pdisch`` (discharge pressure,
    bar) and ``temperature`` (coolant temperature, degC). Inputs: ``pdisch_setpoint`` (the
    discharge-pressure setpoint, bar, which the controller raises the speed towards: it
    holds for minutes at a time) and ``inlet_temperature`` (degC). The speed loop settles
    in about 5 s, flow and pressure in 2-3 s, the temperature in about a minute.
    """

    states = ("speed", "flow", "pdisch", "temperature")
    inputs = ("pdisch_setpoint", "inlet_temperature")
    default_parameters = linear_parameters(
        states, inputs,
        A=[[-0.2, 0.0, -0.3, 0.0],
           [0.5, -0.5, 0.0, 0.0],
           [0.4, -0.3, -0.5, 0.0],
           [0.0, 0.01, 0.0, -0.02]],
        B=[[0.3, 0.0],
           [0.0, 0.0],
           [0.0, 0.0],
           [0.0, 0.02]],
    )
