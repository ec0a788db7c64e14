import itertools

import numpy as np
import pytest

from graybox.nonlinear_tier import (FitSettings, NonlinearTier, fit_networks, initial_weights,
                                    lagged)

W_TRUE = np.array([1.2, -0.9, 0.8])
w_TRUE = np.array([[1.5, -0.8, 0.3], [-0.6, 1.2, 0.9], [0.4, 0.7, -1.4]])
NOISE = 0.05


def eq25_series(n, seed, w=w_TRUE, W=W_TRUE, noise=NOISE, tau=1):
    """z(t) = tanh(sum_j W_j tanh(sum_k w_jk z(t - k tau))) + noise (Eq. 25)."""
    rng = np.random.default_rng(seed)
    m = w.shape[1]
    z = np.zeros(n)
    z[: m * tau] = rng.normal(0, 0.3, m * tau)
    for t in range(m * tau, n):
        past = z[t - tau * np.arange(1, m + 1)]
        z[t] = np.tanh(np.tanh(w @ past) @ W) + noise * rng.normal()
    return z


def best_match_error(w, W):
    """Largest weight error after the best hidden-unit permutation and sign flips."""
    best = np.inf
    for perm in itertools.permutations(range(len(W))):
        wp, Wp = w[list(perm)], W[list(perm)]
        sign = np.sign(Wp * W_TRUE)
        best = min(best, max(np.abs(wp * sign[:, None] - w_TRUE).max(), np.abs(Wp * sign - W_TRUE).max()))
    return best


def test_network_recovers_a_known_eq25_series_to_the_noise_floor():
    # this series has unit scale, so the initial weights use init_scale=1 (unit pre-activations)
    z = eq25_series(20000, 0)
    X, y = lagged(z, 3, 1)
    fit = fit_networks([(X, y)], 3, settings=FitSettings(max_iter=1000, weight_decay=0.0, init_scale=1.0),
                       random_state=0)[0]
    assert fit.mse == pytest.approx(NOISE ** 2, rel=0.05)
    # weights are identifiable only up to permuting hidden units and flipping their signs
    assert best_match_error(fit.w, fit.W) < 0.35
    # and the fitted function equals the true one on fresh data
    Xt, _ = lagged(eq25_series(3000, 1), 3, 1)
    truth = np.tanh(np.tanh(Xt @ w_TRUE.T) @ W_TRUE)
    fitted = np.tanh(np.tanh(Xt @ fit.w.T) @ fit.W)
    assert np.sqrt(np.mean((truth - fitted) ** 2)) < 0.2 * NOISE


def test_warm_start_from_the_true_weights_stays_there():
    z = eq25_series(20000, 2)
    X, y = lagged(z, 3, 1)
    fit = fit_networks([(X, y)], 3, initial=[(w_TRUE, W_TRUE)],
                       settings=FitSettings(weight_decay=0.0))[0]
    assert np.abs(fit.w - w_TRUE).max() < 0.1 and np.abs(fit.W - W_TRUE).max() < 0.1
    assert fit.mse == pytest.approx(NOISE ** 2, rel=0.05)


def test_delay_tau_is_respected():
    z = eq25_series(8000, 3, tau=2)
    X, y = lagged(z, 3, 2)
    fit = fit_networks([(X, y)], 3, settings=FitSettings(max_iter=600, weight_decay=0.0, init_scale=1.0),
                       random_state=1)[0]
    assert fit.mse == pytest.approx(NOISE ** 2, rel=0.1)


def test_a_batch_gives_each_series_the_weights_it_gets_alone():
    rng = np.random.default_rng(4)
    problems = [lagged(eq25_series(3000 + 500 * i, 10 + i) * (1 + 0.1 * i), 3, 1) for i in range(5)]
    problems.append(lagged(rng.normal(0, 0.25, 4000), 3, 1))
    settings = FitSettings(max_iter=150)
    seeds = [100 + i for i in range(len(problems))]
    batched = fit_networks(problems, 4, settings=settings, random_state=seeds, chunk_size=4)
    for problem, seed, together in zip(problems, seeds, batched):
        alone = fit_networks([problem], 4, settings=settings, random_state=[seed])[0]
        assert together.iterations == alone.iterations
        np.testing.assert_array_equal(together.w, alone.w)      # bit for bit
        np.testing.assert_array_equal(together.W, alone.W)


def test_record_predicts_with_eq25_and_round_trips_arrays():
    w, W = initial_weights(4, 3, seed=0)
    tier = NonlinearTier.from_arrays(w, W, 0.1, None, 5)
    assert (tier.hidden_units, tier.embedding_dim) == (4, 3)
    x = np.random.default_rng(5).normal(size=50)
    X, _ = lagged(x, 3, 2)
    np.testing.assert_allclose(tier.predict(x, tau=2)[0], np.tanh(np.tanh(X @ w.T) @ W))
    w2, W2 = tier.weight_arrays()
    np.testing.assert_array_equal(w2, w)
    np.testing.assert_array_equal(W2, W)


def test_lagged_design_matrix():
    X, y = lagged(np.arange(10.0), 2, 3)
    np.testing.assert_array_equal(X[0], [3, 0])
    np.testing.assert_array_equal(y, np.arange(6.0, 10.0))
    with pytest.raises(ValueError, match="same embedding dimension"):
        fit_networks([lagged(np.ones(20), 2, 1), lagged(np.ones(20), 3, 1)], 2)
