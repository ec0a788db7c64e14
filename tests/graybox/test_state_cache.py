"""The calibration's hidden-state cache: a segment's second estimate is its first, run once."""
from __future__ import annotations

import numpy as np

from graybox import state_estimation
from graybox.integration import Integration
from graybox.state_cache import StateCache
from graybox.state_estimation import estimate_states, window_arrays

from test_state_estimation import DT, _simulate_hidden


def test_a_cached_segment_replays_the_same_states_without_fitting_again(monkeypatch):
    model, frame, truth, _ = _simulate_hidden(2500, 4, q0=0.4, temp0=30.0)
    y, u = window_arrays(model, frame)
    rk4 = Integration("rk4", 2)
    fresh = estimate_states(model, y, u, DT, rk4)
    assert fresh.chunk_starts.shape == (5, 1)        # 2,499 steps in chunks of 600
    cache = StateCache()
    first = cache.estimate(model, y, u, DT, rk4)
    np.testing.assert_array_equal(first.states, fresh.states)

    fits = []
    original = state_estimation._initial_hidden
    monkeypatch.setattr(state_estimation, "_initial_hidden",
                        lambda *a: fits.append(1) or original(*a))
    again = cache.estimate(model, y.copy(), u.copy(), DT, rk4)
    assert fits == []                                 # same data: no least-squares fit
    np.testing.assert_array_equal(again.states, fresh.states)
    assert again.initial_hidden == fresh.initial_hidden
    # other data, or another integrator, is estimated afresh
    cache.estimate(model, y[100:], u[100:], DT, rk4)
    cache.estimate(model, y, u, DT, Integration("rosenbrock", 2))
    assert len(fits) == 2
