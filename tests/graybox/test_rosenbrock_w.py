"""Known answers of ``rosenbrock_w`` (:mod:`graybox.integration`): ROS2 with the Jacobian,
the inputs' term and the stage matrix shared by ``JACOBIAN_SUBSTEPS`` sub-steps.

* On a linear model the Jacobian is the same at every sub-step, so it is ROS2 (``rosenbrock``)
  itself: equal to 1e-7 relative (both take the Jacobian by forward differences, at different
  points: 1e-9 relative each).
* It is second order whatever the Jacobian's error over the sub-steps sharing it (a
  W-method): on a nonlinear, non-autonomous pair of equations, doubling the sub-steps divides
  the error by 4 +- 0.3, with the default sharing and with one Jacobian per sample.
* On a stiff linear lag (time constant 1 ms) driven by a ramp, at one sample a second with 2
  sub-steps, the state ends within 1e-3 of its quasi-static value, where RK4 diverges.
* The choice takes the sub-steps ROS2's own estimate takes, given as ``rosenbrock_w`` where
  that method's estimate passes there too, and stays ROS2 where it does not (a stiff lag
  behind ``sin(u)`` with one Jacobian per sample, whose input term the sample's start does
  not represent).
"""
from __future__ import annotations

import numpy as np
import pytest

from graybox import integration as integration_module
from graybox.integration import (ERROR_FRACTION, ERROR_POINTS, JACOBIAN_SUBSTEPS, Integration,
                                 advance, choose_integration, error_estimate)
from graybox.models.base import WhiteBoxModel


def _linear(x, u):
    a = np.array([[-0.5, 0.2, 0.0], [0.1, -3.0, 1.0], [0.0, -40.0, -200.0]])
    return x @ a.T + np.stack([u[..., 0], 0.0 * u[..., 0], 5.0 * u[..., 0]], axis=-1)


def test_on_a_linear_model_it_is_ros2():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(300, 3))
    u0, u1 = rng.normal(size=(300, 1)), rng.normal(size=(300, 1))
    for substeps in (2, 8):
        frozen = advance(_linear, x, u0, u1, 1.0, Integration("rosenbrock_w", substeps))
        ros2 = advance(_linear, x, u0, u1, 1.0, Integration("rosenbrock", substeps))
        np.testing.assert_allclose(frozen, ros2, rtol=1e-7, atol=1e-9)


def _nonlinear(x, u):
    return np.stack([-x[..., 0] ** 2 + np.sin(3.0 * x[..., 1]) + u[..., 0],
                     -0.5 * x[..., 1] * x[..., 0]], axis=-1)


@pytest.mark.parametrize("shared", [JACOBIAN_SUBSTEPS, 1000])
def test_it_is_second_order_with_a_jacobian_shared_by_sub_steps(monkeypatch, shared):
    # shared by 4 sub-steps (the default) and by all of the sample's (1000): a sample of
    # 0.1 s, 8, 16 and 32 sub-steps are in the asymptotic range (3.82 and 3.90 with the
    # default, 3.91 and 3.95 with one per sample)
    monkeypatch.setattr(integration_module, "JACOBIAN_SUBSTEPS", shared)
    x = np.array([[0.8, 0.3], [0.2, 1.1]])
    u0, u1 = np.array([[0.0], [1.0]]), np.array([[2.0], [-1.0]])
    exact = advance(_nonlinear, x, u0, u1, 0.1, Integration("rk4", 64))
    errors = [np.abs(advance(_nonlinear, x, u0, u1, 0.1, Integration("rosenbrock_w", s))
                     - exact).max() for s in (8, 16, 32)]
    assert errors[0] / errors[1] == pytest.approx(4.0, abs=0.3)
    assert errors[1] / errors[2] == pytest.approx(4.0, abs=0.3)


def _stiff(x, u):
    return (u[..., 0:1] - x) / 1e-3


def test_a_stiff_lag_relaxes_to_its_quasi_static_value_within_the_sample():
    x = np.array([[0.0], [5.0]])
    u0, u1 = np.array([[1.0], [2.0]]), np.array([[3.0], [-2.0]])
    end = advance(_stiff, x, u0, u1, 1.0, Integration("rosenbrock_w", 2))
    # quasi-static: x = u - tau u', u' = u1 - u0 per second
    np.testing.assert_allclose(end, u1 - 1e-3 * (u1 - u0), atol=1e-3)
    with np.errstate(all="ignore"):
        assert not np.all(np.abs(advance(_stiff, x, u0, u1, 1.0, Integration("rk4", 2))) < 1e3)


class _Lag(WhiteBoxModel):
    """A stiff measured lag (1 ms) behind a slow input and a slow state it drives."""

    states = ("x", "y")
    inputs = ("u",)
    default_parameters = {"tau": 1e-3}

    def derivatives(self, x, u):
        return np.stack([(u[..., 0] - x[..., 0]) / self.parameters["tau"],
                         0.3 * x[..., 0] - 0.2 * x[..., 1] * np.abs(x[..., 1])], axis=-1)


def test_the_choice_takes_ros2s_sub_steps_given_as_rosenbrock_w():
    rng = np.random.default_rng(2)
    u = np.cumsum(rng.normal(0, 0.3, 400))[:, None]
    x = np.column_stack([u[:, 0], np.cumsum(rng.normal(0, 0.1, 400))])
    change = np.sqrt(np.mean(np.diff(x, axis=0) ** 2, axis=0))
    model = _Lag()
    chosen = choose_integration(model, x, u, 1.0, change)
    assert chosen.method == "rosenbrock_w"
    take = np.unique(np.linspace(0, len(x) - 2, min(ERROR_POINTS, len(x) - 1)).round()
                     .astype(int))
    bound = ERROR_FRACTION * change

    def passes(integration):
        return np.all(error_estimate(model.derivatives, x[take], u[take], u[take + 1], 1.0,
                                     integration) <= bound)

    # the first sub-step count at which ROS2's own estimate passes, not fewer
    counts = [s for s in (2, 4, 8, 16, 32) if passes(Integration("rosenbrock", s))]
    assert chosen.substeps == counts[0]
    assert passes(chosen)


class _SteepLag(_Lag):
    """The lag behind ``sin(u)``: its input term changes within a sample, so the term of the
    sample's start is not good enough for ``rosenbrock_w``."""

    def derivatives(self, x, u):
        out = super().derivatives(x, u)
        out[..., 0] = (np.sin(u[..., 0]) - x[..., 0]) / self.parameters["tau"]
        return out


def test_where_the_shared_terms_fail_their_estimate_the_choice_stays_ros2(monkeypatch):
    # one Jacobian for the whole sample: the input term of its start does not hold
    monkeypatch.setattr(integration_module, "JACOBIAN_SUBSTEPS", 1000)
    rng = np.random.default_rng(2)
    u = np.cumsum(rng.normal(0, 0.3, 400))[:, None]
    x = np.column_stack([np.sin(u[:, 0]), np.cumsum(rng.normal(0, 0.1, 400))])
    change = np.sqrt(np.mean(np.diff(x, axis=0) ** 2, axis=0))
    assert choose_integration(_SteepLag(), x, u, 1.0, change).method == "rosenbrock"


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_the_shared_stage_matrix_is_the_inverse_of_the_jacobians_to_the_bit(n):
    # built entry by entry, it is inverse_columns(I - gamma h J) of the forward-difference
    # Jacobian: the same numbers (and from 4 states the very same call)
    from graybox.batched_lu import inverse_columns
    from graybox.integration import _stage_inverse, jacobian

    rng = np.random.default_rng(n)
    coupling = rng.normal(size=(n, n))

    def f(x, u):
        return np.tanh(x @ coupling) * 50.0 - x * u[..., :1] + u[..., 1:] * x ** 2

    x, u = rng.normal(size=(500, n)) * 3.0, rng.uniform(0.5, 2.0, size=(500, 2))
    fx = f(x, u)
    expected = inverse_columns(np.eye(n) - 0.085 * jacobian(f, x, u, fx))
    assert np.array_equal(_stage_inverse(f, x, u, fx, 0.085), expected)


def test_rows_held_column_by_column_give_the_row_major_arithmetic_to_the_bit():
    # ROS2-W holds its rows of states column by column (contiguous per state, for the white
    # box's reads and apply_columns' sums): the same operations element by element as the
    # row-major loop below (the method before that change), and its result row-major again
    from graybox.batched_lu import apply_columns
    from graybox.integration import _GAMMA, _stage_inverse, advance

    def row_major(f, x, u0, u1, dt, substeps):
        h, change = dt / substeps, u1 - u0
        rate, state = change / dt, x
        for step in range(substeps):
            begin = step / substeps
            ua = u0 + change * begin
            ub = u0 + change * (begin + 1.0 / substeps)
            slope = f(state, ua)
            if step % JACOBIAN_SUBSTEPS == 0:
                epsilon = 1e-7 * max(1.0, float(np.max(np.abs(ua), initial=0.0)))
                shift = _GAMMA * h * ((f(state, ua + epsilon * rate) - slope) / epsilon)
                inverse = _stage_inverse(f, state, ua, slope, _GAMMA * h)
            k1 = apply_columns(inverse, slope + shift)
            k2 = apply_columns(inverse, f(state + h * k1, ub) - 2.0 * k1 - shift)
            state = state + 1.5 * h * k1 + 0.5 * h * k2
        return state

    rng = np.random.default_rng(4)
    x, u = rng.normal(size=(2001, 3)) * 2.0, rng.normal(size=(2001, 2))
    for f in (_stiff_three, lambda x, u: np.stack([x[..., 1] - u[..., 0] * x[..., 0],
                                                   np.sin(x[..., 2]) * u[..., 1],
                                                   -30.0 * x[..., 2] + x[..., 0]], axis=-1)):
        for substeps in (1, 4, 16):
            expected = row_major(f, x[:-1], u[:-1], u[1:], 1.0, substeps)
            got = advance(f, x[:-1], u[:-1], u[1:], 1.0, Integration("rosenbrock_w", substeps))
            assert np.array_equal(got, expected) and got.flags.c_contiguous


def _stiff_three(x, u):
    # the traction drive's white box in miniature: a stiff lag, a tanh, a square
    i, w, temp = x[..., 0], x[..., 1], x[..., 2]
    return np.stack([(u[..., 0] - 0.05 * i - 0.28 * w) / 3e-4,
                     (0.28 * i - 0.02 * w - 6.0 * np.tanh(w / 2.0)) / 1.7,
                     (0.05 * i ** 2 - (temp - u[..., 1]) / 0.09) / 4600.0], axis=-1)
