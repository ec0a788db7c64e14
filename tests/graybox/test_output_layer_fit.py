import numpy as np

from graybox.network_settings import FitSettings, initial_weights
from graybox.nonlinear_tier import lagged
from graybox.output_layer_fit import fit_output_layers


def problem(seed, n=3000, dim=3, hidden=8):
    rng = np.random.default_rng(seed)
    x = rng.normal(0, 0.25, n)
    x[1:] += 0.3 * np.tanh(4 * x[:-1])                      # some structure to explain
    X, y = lagged(x, dim, 1)
    w, W = initial_weights(hidden, dim, seed, 4.0)
    return (X, y), np.concatenate([w.ravel(), W])


def torch_lbfgs(problems, starts, hidden, settings):
    """The batched L-BFGS of the full network with the hidden layer frozen: the reference."""
    from graybox.network_training import fit_chunk, single_thread

    with single_thread():
        return fit_chunk(problems, starts, hidden, problems[0][0].shape[1], settings,
                         max(len(y) for _, y in problems), train_input_weights=False)


def loss(fit, X, y, decay):
    return np.mean((y - np.tanh(np.tanh(X @ fit.w.T) @ fit.W)) ** 2) + decay * fit.W @ fit.W


def test_reaches_the_minimum_the_batched_lbfgs_finds():
    settings = FitSettings()
    problems, starts = zip(*[problem(seed) for seed in range(3)])
    ours = fit_output_layers(problems, starts, 8, settings)
    reference = torch_lbfgs(list(problems), list(starts), 8, settings)
    for (X, y), start, a, b in zip(problems, starts, ours, reference):
        np.testing.assert_array_equal(a.w, start[:24].reshape(8, 3))   # hidden layer fixed
        # one minimum: the same weights up to where L-BFGS stops (a relative loss change of
        # 1e-9 leaves flat directions ~1e-4 short), and never a higher loss than it reached
        np.testing.assert_allclose(a.W, b.W, atol=5e-4)
        assert loss(a, X, y, settings.weight_decay) <= loss(b, X, y, settings.weight_decay) + 1e-15
        assert a.iterations < b.iterations


def test_the_gradient_vanishes_at_the_result():
    settings = FitSettings()
    (X, y), start = problem(7)
    fit = fit_output_layers([(X, y)], [start], 8, settings)[0]
    H = np.tanh(X @ fit.w.T)
    p = np.tanh(H @ fit.W)
    gradient = -2 * ((1 - p ** 2)[:, None] * H).T @ (y - p) / len(y) + 2 * settings.weight_decay * fit.W
    assert np.abs(gradient).max() < 1e-8


def test_each_series_alone_or_together():
    settings = FitSettings()
    problems, starts = zip(*[problem(seed, n=500 + 300 * seed) for seed in range(3)])
    together = fit_output_layers(problems, starts, 8, settings)
    for p, s, fit in zip(problems, starts, together):
        alone = fit_output_layers([p], [s], 8, settings)[0]
        np.testing.assert_array_equal(alone.W, fit.W)
        assert alone.mse == fit.mse


def test_the_prediction_kept_is_the_networks_on_each_segment_to_rounding():
    # the noise tier reads the fit's prediction instead of running the network again: the
    # same numbers but for the last rows of a segment, whose output-layer sum BLAS adds in
    # another order (a difference at the sum's rounding, 1e-16)
    from graybox.nonlinear_tier import NonlinearTier

    rng = np.random.default_rng(7)
    segments = [rng.normal(0, 0.25, n) for n in (2000, 3, 517, 1200)]   # one without rows
    dim, tau, hidden = 3, 2, 32
    parts = [lagged(s, dim, tau) for s in segments]
    X, y = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    w, W = initial_weights(hidden, dim, 3, 4.0)
    fit, = fit_output_layers([(X, y)], [np.concatenate([w.ravel(), W])], hidden, FitSettings(),
                             keep_predictions=True)
    tier = NonlinearTier.from_arrays(fit.w, fit.W, fit.mse, None, fit.iterations)
    expected = np.concatenate(tier.predict(segments, tau))
    prediction = fit.prediction
    assert prediction.shape == (len(y),)
    np.testing.assert_allclose(prediction, expected, rtol=0.0, atol=1e-15)
    assert np.mean(prediction == expected) > 0.99
    # unless asked, nothing of the series' length is kept
    assert fit_output_layers([(X, y)], [np.concatenate([w.ravel(), W])], hidden,
                             FitSettings())[0].prediction is None


def test_the_segments_design_is_each_segments_lagged_design_concatenated():
    # the nonlinear tier's design is written in place (lagged_segments): the same arrays as
    # each segment's lagged design of its scaled values, concatenated, to the bit
    from graybox.nonlinear_tier import lagged_segments

    rng = np.random.default_rng(11)
    segments = [rng.normal(0, 3.0, n) for n in (2000, 3, 517, 0, 1200)]   # some without rows
    for dim, tau in ((3, 2), (5, 1), (1, 7)):
        parts = [lagged(s / 0.37, dim, tau) for s in segments]
        X, y = lagged_segments(segments, dim, tau, 0.37)
        np.testing.assert_array_equal(X, np.concatenate([p[0] for p in parts]))
        np.testing.assert_array_equal(y, np.concatenate([p[1] for p in parts]))
        assert X.shape == (len(y), dim) and X.flags.f_contiguous
        w = initial_weights(32, dim, 5, 4.0)[0]                         # the same products
        np.testing.assert_array_equal(X @ w.T, np.concatenate([p[0] for p in parts]) @ w.T)
    X, y = lagged_segments(segments[1:2], 3, 2)                           # no rows at all
    assert X.shape == (0, 3) and y.shape == (0,)


def test_a_new_baselines_output_layer_from_zero_reaches_the_random_starts_minimum_sooner():
    # a new baseline's fixed-feature fits keep the seeded hidden layer and start the output
    # weights at zero (graybox.tiers.nonlinear._output_layer_starts): the same minimum, to the
    # fit's tolerance, in fewer iterations than from the seeded random output weights
    from graybox.settings import GrayBoxSettings
    from graybox.tiers.nonlinear import _output_layer_starts

    settings = GrayBoxSettings()
    hidden, dim = 32, 3
    (w, W0), = _output_layer_starts(hidden, dim, [17], settings)
    np.testing.assert_array_equal(w, initial_weights(hidden, dim, 17,
                                                     settings.network.init_scale)[0])
    assert not W0.any()
    rng = np.random.default_rng(17)
    x = rng.normal(0, 0.25, 20000)
    x[1:] += 0.3 * np.tanh(4 * x[:-1])
    X, y = lagged(x, dim, 1)
    w_random, W_random = initial_weights(hidden, dim, 17, settings.network.init_scale)
    random_start = np.concatenate([w_random.ravel(), W_random])
    fitted_random, = fit_output_layers([(X, y)], [random_start], hidden, settings.network,
                                       keep_predictions=True)
    fitted_zero, = fit_output_layers([(X, y)], [np.concatenate([w.ravel(), W0])], hidden,
                                     settings.network, keep_predictions=True)
    assert fitted_zero.iterations < fitted_random.iterations
    spread = np.sqrt(np.mean(fitted_random.prediction ** 2))
    assert np.sqrt(np.mean((fitted_zero.prediction - fitted_random.prediction) ** 2)) < 1e-4 * spread
