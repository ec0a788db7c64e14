import dataclasses
import warnings

import numpy as np
import pytest
from scipy import stats
from scipy.signal import lfilter

from graybox.exceptions import InsufficientDataError
from graybox.noise_tier import MOMENT_WEIGHTS, NoiseTier, describe_noise


def test_moments_match_scipy():
    x = np.random.default_rng(0).standard_t(6, size=5000) * 2 + 1
    noise = describe_noise(x)
    assert noise.mean == pytest.approx(x.mean())
    assert noise.variance == pytest.approx(x.var())
    assert noise.skewness == pytest.approx(stats.skew(x))
    assert noise.excess_kurtosis == pytest.approx(stats.kurtosis(x))
    assert noise.excess_kurtosis > 1  # heavy tails


def test_ljung_box_matches_statsmodels_and_flags_colour():
    from statsmodels.stats.diagnostic import acorr_ljungbox   # the test extra: must be there
    rng = np.random.default_rng(1)
    white = rng.normal(size=4000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reference = acorr_ljungbox(white, lags=[20])
    noise = describe_noise(white, lags=20)
    assert noise.ljung_box_statistic == pytest.approx(float(reference["lb_stat"].iloc[0]))
    assert noise.ljung_box_pvalue == pytest.approx(float(reference["lb_pvalue"].iloc[0]))
    assert noise.is_white
    assert not describe_noise(lfilter([1], [1, -0.3], white)).is_white


def test_too_few_samples():
    with pytest.raises(InsufficientDataError):
        describe_noise(np.ones(5))


def test_a_gaussian_residual_has_the_gaussian_moment_variances():
    noise = describe_noise(np.random.default_rng(2).normal(size=400_000) * 3 + 1)
    gaussian = [1 / w for w in MOMENT_WEIGHTS]
    # the kurtosis' from an eighth moment: its estimate converges slowly
    assert noise.moment_variances[:3] == pytest.approx(gaussian[:3], rel=0.03)
    assert noise.moment_variances[3] == pytest.approx(gaussian[3], rel=0.12)
    assert noise.moment_weights == pytest.approx([1 / v for v in noise.moment_variances])


def test_moment_variances_predict_the_spread_of_each_moment_over_samples():
    # Student-t with 12 degrees of freedom (finite eighth moment, excess kurtosis 1): the
    # skewness' and kurtosis' sampling variances are about 3 and 10 times a Gaussian's
    rng = np.random.default_rng(3)
    n = 4000
    nights = [describe_noise(rng.standard_t(12, size=n)) for _ in range(800)]
    moments = np.array([night.moments for night in nights])
    spread = n * np.array([np.var(moments[:, 0] / np.sqrt(moments[:, 1])),
                           np.var(moments[:, 1] / moments[:, 1].mean()),
                           np.var(moments[:, 2]), np.var(moments[:, 3])])
    predicted = describe_noise(rng.standard_t(12, size=2_000_000)).moment_variances
    assert spread[:3] == pytest.approx(predicted[:3], rel=0.15)
    assert spread[3] == pytest.approx(predicted[3], rel=0.3)     # an eighth moment converges slowly
    assert predicted[2] > 2 * 6 and predicted[3] > 5 * 24


def test_a_record_without_moment_variances_round_trips_and_weighs_as_a_gaussian():
    from graybox.record_json import from_dict, to_dict
    noise = describe_noise(np.random.default_rng(5).standard_t(5, size=4000))
    assert from_dict(NoiseTier, to_dict(noise)) == noise
    assert noise.moment_weights[3] < MOMENT_WEIGHTS[3] / 5        # heavy tails: weighed less
    stored = dataclasses.replace(noise, moment_variances=None)
    assert "moment_variances" not in to_dict(stored)
    assert from_dict(NoiseTier, to_dict(stored)) == stored
    assert stored.moment_weights == MOMENT_WEIGHTS


def test_a_light_tailed_residual_weighs_its_shape_at_most_four_times_a_gaussian():
    # a two-level residual's kurtosis hardly varies (its influence is near 0): the floor keeps
    # a tiny change from weighing without bound
    two_levels = np.tile([-1.0, 1.0], 5000) + np.random.default_rng(6).normal(0, 1e-3, 10_000)
    weights = describe_noise(two_levels).moment_weights
    assert weights[3] == pytest.approx(4 * MOMENT_WEIGHTS[3])


def test_sampling_zeta_quantile_of_a_gaussian_record_is_a_scaled_chi_square():
    from graybox.noise_tier import sampling_zeta_quantile
    stored = NoiseTier(0.0, 1.0, 0.0, 0.0, 20.0, 0.4, 20, 800)     # Gaussian weights
    expected = (1 / 200 + 1 / 800) * stats.chi2.isf(0.001, 4)
    assert sampling_zeta_quantile(stored, 200, 0.001) == pytest.approx(expected, rel=1e-12)
    # a moment whose variance sits under the floor weighs less than 1: the tail shortens
    light = dataclasses.replace(stored, moment_variances=(1.0, 2.0, 6.0, 1.0))
    assert sampling_zeta_quantile(light, 200, 0.001) < expected
    with pytest.raises(ValueError):
        sampling_zeta_quantile(stored, 200, 0.0)


def test_sampling_zeta_quantile_is_crossed_at_its_rate_by_healthy_gaussian_nights():
    from graybox.drift import compute_drift
    from graybox.noise_tier import sampling_zeta_quantile
    from graybox.tiers.noise import NoiseTierKind
    from tests.graybox.conftest import make_channel, make_signature
    rng = np.random.default_rng(11)
    baseline = make_signature((dataclasses.replace(make_channel(),
                                                   noise=describe_noise(rng.normal(size=4000))),))
    quantile = sampling_zeta_quantile(baseline.channels[0].noise, 2000, 0.05)
    kind = NoiseTierKind()
    zetas = []
    for _ in range(1000):
        night = dataclasses.replace(make_channel(), noise=describe_noise(rng.normal(size=2000)))
        zetas.append(float(np.sum(kind.deltas(night, baseline.channels[0]) ** 2)))
    # binomial 50 +- 7 at 5 %; the kurtosis' finite-sample tail adds a little
    assert 0.03 < np.mean(np.array(zetas) > quantile) < 0.08
    assert compute_drift(make_signature((night,)), baseline).get("omega", "noise").zeta == \
        pytest.approx(zetas[-1])


def test_the_networks_errors_described_from_its_fit_are_the_noise_tiers():
    # graybox.tiers.nonlinear.network_errors reads the output-layer fit's own prediction: the
    # noise tier describes them, its record without running the network again, to the sums'
    # rounding
    from graybox.channel_structure import ChannelStructure
    from graybox.network_settings import FitSettings, initial_weights
    from graybox.nonlinear_tier import NonlinearTier, lagged
    from graybox.noise_tier import describe_noise
    from graybox.output_layer_fit import fit_output_layers
    from graybox.tiers.fit_state import ChannelFit
    from graybox.tiers.nonlinear import network_errors

    rng = np.random.default_rng(5)
    segments = []
    for n in (3000, 800, 5):                                   # the last one has no rows
        x = rng.normal(0.0, 0.3, n)
        x[2:] += 0.4 * np.tanh(3.0 * x[:-2])
        segments.append(x)
    structure = ChannelStructure(period=0, seasonal_order=0, diff_order=0, ar_order=1,
                                 center=0.0, scale=1.0, tau=2, embedding_dim=3, hidden_units=32,
                                 nn_scale=0.6, nonlinear_needed=True, init_seed=4)
    parts = [lagged(s / structure.nn_scale, 3, 2) for s in segments]
    X, y = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    w, W = initial_weights(32, 3, 4, 4.0)
    channel = ChannelFit("c", [], 0, structure=structure, w_segments=segments)
    fit, = fit_output_layers([(X, y)], [np.concatenate([w.ravel(), W])], 32, FitSettings(),
                             keep_predictions=True)
    prediction = fit.prediction
    described = describe_noise(network_errors(channel, prediction))
    tier = NonlinearTier.from_arrays(fit.w, fit.W, fit.mse, None, fit.iterations)
    expected = describe_noise([s[6:] - 0.6 * p for s, p in
                               zip(segments, tier.predict([s / 0.6 for s in segments], 2))])
    assert described.n_obs == expected.n_obs == len(y)
    np.testing.assert_allclose(described.moments, expected.moments, rtol=1e-12, atol=1e-15)
    # the noise tier describes the errors the nonlinear tier left on the channel
    from graybox.tiers.noise import final_residual

    channel.network_errors = network_errors(channel, prediction)
    assert describe_noise(final_residual(channel, [0, 0, 0])) == described
    # a network that is not needed, or a fit without a prediction, leaves it to the noise tier
    assert network_errors(channel, None) is None
    channel.structure = dataclasses.replace(structure, nonlinear_needed=False)
    assert network_errors(channel, prediction) is None


def test_a_residual_constant_to_rounding_has_no_moments_to_describe():
    # an idle lift's speed residual: 7e-10 everywhere, off by float dust here and there
    values = np.full(1000, 6.8e-10)
    values[::7] += 1e-25
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)   # scipy's own "nearly identical"
        assert np.var(values) > 0 and np.isnan(stats.skew(values))
    with pytest.raises(InsufficientDataError, match="constant"):
        describe_noise(values)
    with pytest.raises(InsufficientDataError, match="constant"):
        describe_noise(np.zeros(1000))
