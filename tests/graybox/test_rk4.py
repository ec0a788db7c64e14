import numpy as np
import pytest

from graybox.rk4 import rk4_step


def test_rk4_step_is_the_fourth_order_taylor_step_of_a_linear_equation():
    h = 0.1
    step = rk4_step(lambda x, u: -x + u, 1.0, 0.0, 0.0, 0.0, h)
    assert step == pytest.approx(1 - h + h ** 2 / 2 - h ** 3 / 6 + h ** 4 / 24, rel=1e-15)


def test_rk4_step_integrates_a_quadratic_input_exactly_and_elementwise():
    # dx/dt = t^2 over [0, h] from x = 0, 1: x(h) = x + h^3 / 3 (Simpson's rule is exact)
    h = 0.5
    end = rk4_step(lambda x, t: t ** 2 + 0 * x, np.array([0.0, 1.0]), 0.0, (h / 2), h, h)
    np.testing.assert_allclose(end, [h ** 3 / 3, 1 + h ** 3 / 3], rtol=1e-15)
