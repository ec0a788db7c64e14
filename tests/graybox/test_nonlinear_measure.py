"""The nonlinear tier's alarm measure: drift of the network's function on a fixed reference set.

Known answers: hidden units that are permuted and sign-flipped (``tanh`` is odd, so
``(w_j, W_1j) -> (-w_j, -W_1j)`` keeps the function) give zeta 0 although Eq. 28 on the
weights is large; a changed function gives the mean squared change of its output on the
reference set; structures stored before the measure keep Eq. 28.
"""
from dataclasses import replace

import numpy as np
import pytest

from graybox.drift import compute_drift
from graybox.nonlinear_tier import NonlinearTier
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
