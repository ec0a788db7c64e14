import numpy as np
from scipy.integrate import solve_ivp

from graybox.embedding import (choose_delay, choose_dimension, delay_vectors,
                               false_nearest_fraction, mutual_information)


def henon(n=4000):
    x, y = np.zeros(n + 100), np.zeros(n + 100)
    x[0] = 0.1
    for i in range(n + 99):
        x[i + 1] = 1 - 1.4 * x[i] ** 2 + y[i]
        y[i + 1] = 0.3 * x[i]
    return x[100:]


def lorenz(dt=0.02, n=8000):
    def field(_, v):
        return [10 * (v[1] - v[0]), v[0] * (28 - v[2]) - v[1], v[0] * v[1] - 8 / 3 * v[2]]
    t = np.arange(n + 1000) * dt
    return solve_ivp(field, (0, t[-1]), [1, 1, 1], t_eval=t, rtol=1e-9, atol=1e-9).y[0][1000:]


def test_henon_map_needs_two_dimensions_at_delay_one():
    x = henon()
    assert choose_delay(x) == 1
    assert false_nearest_fraction(x, 1, 1) > 0.5
    assert false_nearest_fraction(x, 2, 1) < 0.05
    assert choose_dimension(x, 1) == 2


def test_lorenz_delay_and_dimension():
    x = lorenz()
    tau = choose_delay(x)
    assert 6 <= tau <= 11          # first minimum of mutual information near 0.16 time units
    assert choose_dimension(x, tau) == 3


def test_white_noise_gets_delay_one_and_a_bounded_dimension():
    x = np.random.default_rng(0).normal(size=5000)
    assert choose_delay(x) == 1
    assert 1 <= choose_dimension(x, 1, max_dim=6) <= 6


def test_mutual_information_and_delay_vectors():
    rng = np.random.default_rng(1)
    x = rng.normal(size=20000)
    assert mutual_information(x, 1) < 0.03
    y = np.repeat(rng.normal(size=10000), 2)        # y(t) = y(t+1) half of the time
    assert mutual_information(y, 1) > 0.5
    vectors = delay_vectors(np.arange(10.0), 3, 2)
    np.testing.assert_array_equal(vectors[0], [4, 2, 0])
    assert vectors.shape == (6, 3)
