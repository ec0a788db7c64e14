"""The nonlinear tier's alarm measure: drift of the network's function on a fixed reference set.

Known answers: hidden units that are permuted and sign-flipped (``tanh`` is odd, so
``(w_j, W_1j) -> (-w_j, -W_1j)`` keeps the function) give zeta 0 although Eq. 28 on the
weights is large; a changed function gives the mean squared change of its output on the
reference set; structures stored before the measure keep Eq. 28; a residual whose mean
moved (a biased sensor on a linear white box) leaves the network's function where it was.
"""
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from graybox import FitRequest, fit_signatures
from graybox.drift import compute_drift
from graybox.models.gas_turbine import LangevinShaft
from graybox.nonlinear_tier import NonlinearTier, window_centred
from graybox.tiers import NonlinearTierKind, network_function, reference_set

from tests.graybox.conftest import make_channel, make_signature

KIND = NonlinearTierKind()


def _network(seed=3, hidden=6, dim=3):
    rng = np.random.default_rng(seed)
    return rng.normal(0, 2.0, (hidden, dim)), rng.normal(0, 0.5, hidden)


def _measured(channel, points=256):
    return replace(channel, structure=replace(channel.structure, reference_points=points))


def _with_weights(channel, w, W):
    return replace(channel, nonlinear=NonlinearTier.from_arrays(w, W, 0.05, None, 10))


def test_permuted_and_sign_flipped_hidden_units_do_not_move_the_measure():
    w, W = _network()
    baseline = _measured(make_channel(w=w, W=W))
    order = np.array([3, 0, 5, 1, 4, 2])
    flip = np.array([1, -1, -1, 1, -1, 1.0])
    same = _with_weights(baseline, flip[:, None] * w[order], flip * W[order])
    reference = reference_set(baseline)
    np.testing.assert_allclose(network_function(same.nonlinear, reference),
                               network_function(baseline.nonlinear, reference), atol=1e-12)
    assert np.sum(KIND.deltas(same, baseline) ** 2) == pytest.approx(0.0, abs=1e-24)
    # Eq. 28 on the weights calls the same function a large change
    assert np.sum(KIND.parameter_changes(same, baseline) ** 2) > 1.0


def test_a_changed_function_moves_the_measure_by_its_mean_squared_change():
    w, W = _network()
    baseline = _measured(make_channel(w=w, W=W))
    changed = _with_weights(baseline, w, W * 1.5)
    reference = reference_set(baseline)
    expected = np.mean((network_function(changed.nonlinear, reference) -
                        network_function(baseline.nonlinear, reference)) ** 2)
    zeta = float(np.sum(KIND.deltas(changed, baseline) ** 2))
    assert expected > 1e-4
    assert zeta == pytest.approx(expected, rel=1e-12)


def test_the_reference_set_is_fixed_by_the_baseline_and_lies_at_the_inputs_spread():
    w, W = _network()
    baseline = _measured(make_channel(w=w, W=W), points=4000)
    first, again = reference_set(baseline), reference_set(baseline)
    np.testing.assert_array_equal(first, again)
    assert first.shape == (4000, 3)
    # the noise tier's variance 1.0 and nn_scale 4.0 of make_channel: spread 1 / 4
    assert first.std() == pytest.approx(0.25, rel=0.03)


def test_structures_stored_before_the_measure_keep_eq_28_on_the_weights():
    w, W = _network()
    baseline = make_channel(w=w, W=W)
    assert baseline.structure.reference_points is None and reference_set(baseline) is None
    changed = _with_weights(baseline, w + 0.1, W)
    np.testing.assert_array_equal(KIND.deltas(changed, baseline),
                                  KIND.parameter_changes(changed, baseline))


def test_drift_records_eq_28_beside_the_function_space_zeta():
    w, W = _network()
    base_channel = _measured(make_channel(w=w, W=W))
    order = np.array([1, 0, 2, 3, 4, 5])
    same = _with_weights(base_channel, w[order], W[order])
    drift = compute_drift(make_signature((same,)), make_signature((base_channel,)))
    entry = drift.get("omega", "nonlinear")
    assert entry.zeta == pytest.approx(0.0, abs=1e-24)
    assert entry.parameter_zeta == pytest.approx(
        float(np.sum((w[order] - w) ** 2) + np.sum((W[order] - W) ** 2)))
    assert {c.name for c in entry.top_changes} <= {f"w_{j}_{k}" for j in (1, 2)
                                                   for k in (1, 2, 3)} | {"W1_1", "W1_2"}
    assert drift.get("omega", "linear").parameter_zeta is None
    assert type(drift).from_dict(drift.to_dict()) == drift


def _shaft_window(day, bias=0.0, n=2880, seed=11):
    """A linear shaft (:class:`LangevinShaft`) driven by a wandering fuel rate and a noisy
    torque, logged every 10 s, its speed read ``bias`` rad/s high."""
    model = LangevinShaft()
    p = model.default_parameters
    rng = np.random.default_rng([seed, day])
    dt = 10.0
    fuel = 1.0 + 0.1 * np.sin(2 * np.pi * np.arange(n) / 900) + 0.01 * rng.standard_normal(n)
    phi = np.exp(-p["gamma"] * dt)
    omega = np.empty(n)
    omega[0] = p["omega_ref"]
    for t in range(1, n):
        target = p["omega_ref"] + p["fuel_gain"] * (fuel[t - 1] - p["fuel_ref"]) / p["gamma"]
        omega[t] = target + phi * (omega[t - 1] - target) + 0.3 * rng.standard_normal()
    index = pd.date_range("2026-01-01", periods=n, freq="10s", tz="UTC") + pd.Timedelta(days=day)
    return pd.DataFrame({"omega": omega + bias, "fuel_rate": fuel}, index=index)


def test_a_residual_whose_mean_moved_leaves_the_networks_function_where_it_was():
    """A linear white box and a sensor read 2 rad/s high: the one-step residual moves by a
    constant, its dynamics not at all. The network (Eq. 25: odd, no biases) models each
    window's AR residual about that window's mean, so its function and the linear tier stay
    exactly where the unbiased night puts them; the move is the noise tier's (its mean) and
    the level tier's."""
    model = LangevinShaft()
    baseline = fit_signatures([FitRequest(model, [_shaft_window(d) for d in range(3)],
                                          asset_id="S")])[0]
    night, biased = fit_signatures([FitRequest(model, [_shaft_window(3, bias=b)],
                                               baseline=baseline, asset_id="S")
                                    for b in (0.0, 2.0)])
    plain, moved = compute_drift(night, baseline), compute_drift(biased, baseline)
    for tier in ("nonlinear", "linear"):
        assert moved.get("omega", tier).zeta == pytest.approx(
            plain.get("omega", tier).zeta, rel=1e-6, abs=1e-12), tier
    # the one-step residual moved by (1 - exp(-gamma dt)) x 2 rad/s; the AR residual the
    # noise tier describes by that, scaled, times 1 - sum(a_i)
    structure, linear = baseline.channel("omega").structure, biased.channel("omega").linear
    expected = (2.0 * (1 - np.exp(-0.06 * 10.0)) / structure.scale
                * (1 - sum(linear.coefficients)))
    shift = biased.channel("omega").noise.mean - night.channel("omega").noise.mean
    assert shift == pytest.approx(expected, rel=1e-3)
    assert moved.get("omega", "noise").zeta > 10 * plain.get("omega", "noise").zeta
    assert moved.get("omega", "level").zeta > 10 * plain.get("omega", "level").zeta
    assert baseline.channel("omega").structure.centred_network is True


def test_a_structure_stored_before_centring_keeps_its_networks_input_as_it_was():
    """A signature stored before 2026-11-30 has no ``centred_network``: it reads as None,
    writes as it was read, and its candidates' networks model the residual as it is, the
    mean included (as they were calibrated): the biased night's network moves."""
    from graybox.record_json import from_dict, to_dict
    from graybox.signature import Signature

    model = LangevinShaft()
    fitted = fit_signatures([FitRequest(model, [_shaft_window(d) for d in range(3)],
                                        asset_id="S")])[0]
    stored = to_dict(fitted)
    for channel in stored["channels"]:
        del channel["structure"]["centred_network"]
    baseline = from_dict(Signature, stored)
    assert baseline.channel("omega").structure.centred_network is None
    assert to_dict(baseline) == stored
    night, biased = fit_signatures([FitRequest(model, [_shaft_window(3, bias=b)],
                                               baseline=baseline, asset_id="S")
                                    for b in (0.0, 2.0)])
    plain, moved = compute_drift(night, baseline), compute_drift(biased, baseline)
    assert moved.get("omega", "nonlinear").zeta > 10 * plain.get("omega", "nonlinear").zeta


def test_each_windows_segments_lose_that_windows_pooled_mean():
    # window 1 in two operating segments (its 5 samples' mean: 2), window 0 in one (10)
    segments = [np.array([1.0, 2.0]), np.array([10.0]), np.array([0.0, 3.0, 4.0])]
    out = window_centred(segments, [1, 0, 1])
    np.testing.assert_allclose(out[0], [-1.0, 0.0])
    np.testing.assert_allclose(out[1], [0.0])
    np.testing.assert_allclose(out[2], [-2.0, 1.0, 2.0])
