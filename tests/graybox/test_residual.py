import numpy as np
import pandas as pd
import pytest
from scipy.linalg import expm

from graybox.models import DriveTrain, LangevinShaft
from graybox.residual import inverse_residual, one_step_residual, residual_frame


def test_one_step_residual_recovers_a_held_force_exactly():
    """Eq. 8 with a force held over each sample: x_k = phi x_{k-1} + (1 - phi)/gamma F_k, so the
    one-step residual of the true model is (1 - phi)/gamma F_k, up to RK4's truncation."""
    gamma, dt, n = 0.06, 10.0, 2000
    rng = np.random.default_rng(0)
    force = rng.normal(0, 0.2, n)
    phi = np.exp(-gamma * dt)
    omega = np.zeros(n)
    for k in range(1, n):
        omega[k] = phi * omega[k - 1] + (1 - phi) / gamma * force[k]
    model = LangevinShaft({"gamma": gamma, "omega_ref": 0.0, "fuel_gain": 0.0})
    residual = one_step_residual(model, omega[:, None], np.ones((n, 1)), dt, substeps=4)
    np.testing.assert_allclose(residual[:, 0], (1 - phi) / gamma * force[1:], atol=1e-4)


def test_one_step_residual_is_multichannel():
    model = DriveTrain()
    A, B, dt, n = model.A, model.B, 5.0, 500
    rng = np.random.default_rng(1)
    forces = rng.normal(0, 0.1, (n, 2))
    u = np.full((n, 1), 2.0)
    step = expm(A * dt)
    gain = np.linalg.solve(A, step - np.eye(2))
    x = np.zeros((n, 2))
    for k in range(1, n):
        x[k] = step @ x[k - 1] + gain @ (B @ u[k] + forces[k])
    residual = one_step_residual(model, x, u, dt, substeps=8)
    np.testing.assert_allclose(residual, forces[1:] @ gain.T, atol=1e-6)


def test_inverse_residual_equals_a_smooth_injected_force():
    """Eq. 13 on Langevin data with the true gamma returns the injected force."""
    from graybox.simulation import simulate_langevin

    gamma, dt, n = 0.05, 1.0, 3000
    t = np.arange(n) * dt

    def force(time):
        return 0.3 * np.sin(2 * np.pi * time / 200) + 0.1 * np.cos(2 * np.pi * time / 57 + 1)

    omega = simulate_langevin(n, dt, gamma, force, omega0=1.0)
    model = LangevinShaft({"gamma": gamma, "omega_ref": 0.0, "fuel_gain": 0.0})
    residual = inverse_residual(model, omega[:, None], np.zeros((n, 1)), dt)[:, 0]
    inner = slice(10, -10)
    error = residual[inner] - force(t)[inner]
    assert np.max(np.abs(error)) < 0.01 * np.max(np.abs(force(t)))


def test_residual_frame_names_channels_after_states_and_drops_first_sample():
    n = 50
    index = pd.date_range("2026-01-01", periods=n, freq="10s", tz="UTC")
    frame = pd.DataFrame({"speed": np.linspace(990, 1010, n), "fuel_rate": np.ones(n)}, index)
    model = LangevinShaft(columns={"omega": "speed"})
    one_step = residual_frame(model, frame)
    assert list(one_step.columns) == ["omega"] and one_step.index.equals(index[1:])
    inverse = residual_frame(model, frame, "inverse")
    assert inverse.index.equals(index)
    with pytest.raises(ValueError, match="residual method"):
        residual_frame(model, frame, "robust")
