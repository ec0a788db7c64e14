"""The step of a quantized reading (graybox/resolution.py)."""
import numpy as np
import pytest

from graybox.resolution import reading_resolution


def test_a_reading_logged_to_a_hundredth_has_that_step():
    rng = np.random.default_rng(0)
    temperature = np.round(40.0 + np.cumsum(rng.normal(0, 0.004, 5000)), 2)
    assert reading_resolution(temperature) == pytest.approx(0.01)
    # a pump's power to 0.5 kW, jumping many steps at a time, still has its step
    power = 0.5 * np.round(2 * (50.0 + 8.0 * np.sin(np.arange(500) / 20.0)))
    assert reading_resolution(power) == pytest.approx(0.5)


def test_a_few_interpolated_samples_leave_the_step_and_many_remove_it():
    rng = np.random.default_rng(1)
    level = np.round(2.0 + np.cumsum(rng.normal(0, 0.02, 2000)), 2)
    filled = level.copy()
    filled[100:110] = np.linspace(level[99], level[110], 12)[1:-1]   # a gap of 10 filled
    assert reading_resolution(filled) == pytest.approx(0.01)
    filled[::20] += 0.003                                             # 5 % off the grid
    assert reading_resolution(filled) == 0.0


def test_a_sensor_logged_in_full_and_a_constant_have_no_step():
    rng = np.random.default_rng(2)
    assert reading_resolution(rng.normal(0, 1, 1000)) == 0.0
    assert reading_resolution(np.full(50, 3.2)) == 0.0
    assert reading_resolution(np.array([1.0, np.nan, 1.5, 2.0])) == pytest.approx(0.5)


def test_a_reading_whose_changes_are_below_its_significant_digits_has_no_step(recwarn):
    # a pressure of 100 kPa logged in full in MPa-scale steps: its changes are below the ten
    # significant digits its values are compared at, and round to 0 (not a step, no warning)
    rng = np.random.default_rng(3)
    pressure = 1e5 + np.cumsum(rng.normal(0, 1e-7, 1000))
    assert reading_resolution(pressure) == 0.0
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]
