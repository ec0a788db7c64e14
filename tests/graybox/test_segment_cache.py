"""The calibration's segment cache: a segment's second hidden-state estimate is its first, run
once; its residual and level data are computed once while the cache stores, and a calibration
with the cache gives exactly the fits it gives without."""
from __future__ import annotations

import numpy as np
import pandas as pd

from graybox import state_estimation
from graybox.integration import Integration
from graybox import signature_fit
from graybox.calibration import fit_baselines
from graybox import segment_cache
from graybox.segment_cache import SegmentCache
from graybox.signature_fit import FitRequest
from graybox.state_estimation import estimate_states, window_arrays

from test_state_estimation import DT, _simulate_hidden


def test_a_cached_segment_replays_the_same_states_without_fitting_again(monkeypatch):
    model, frame, truth, _ = _simulate_hidden(2500, 4, q0=0.4, temp0=30.0)
    y, u = window_arrays(model, frame)
    rk4 = Integration("rk4", 2)
    fresh = estimate_states(model, y, u, DT, rk4)
    # 2,499 steps in chunks of CHUNK_SAMPLES, one hidden state
    assert fresh.chunk_starts.shape == (-(-2499 // state_estimation.CHUNK_SAMPLES), 1)
    cache = SegmentCache()
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


def test_remember_computes_once_per_data_and_details_while_storing():
    model, frame, _, _ = _simulate_hidden(600, 4, q0=0.4, temp0=30.0)
    segment = estimate_states(model, *window_arrays(model, frame), DT, Integration("rk4", 2))
    calls = []
    cache = SegmentCache()
    compute = lambda: calls.append(1) or len(calls)          # noqa: E731
    assert cache.remember("residual", model, segment, (1,), compute) == 1
    assert cache.remember("residual", model, segment, (1,), compute) == 1
    assert cache.remember("residual", model, segment, (2,), compute) == 2   # other details
    assert cache.remember("level", model, segment, (1,), compute) == 3      # other kind
    cache.storing = False
    assert cache.remember("residual", model, segment, (3,), compute) == 4
    assert cache.remember("residual", model, segment, (3,), compute) == 5   # not kept
    assert cache.remember("residual", model, segment, (1,), compute) == 1   # still found


def test_a_calibration_reads_each_baseline_window_once_and_fits_what_it_fits_without(
        monkeypatch, tmp_path):
    import graybox as gb
    from graybox.simulation import demo_fleet, write_fleet

    write_fleet(demo_fleet(n_vehicles=1, days=3), tmp_path)
    model = gb.load_model("graybox.models:GasTurbineShaft", columns={"omega": "shaft_speed"})
    days = gb.read_window(tmp_path, "T-001", model.required_columns, start="2026-01-01",
                          end="2026-01-04").split("1D")
    request = FitRequest(model, days, asset_id="T-001")
    days = [window.frame for window in days]
    calls = []
    original = signature_fit.residual_frame
    monkeypatch.setattr(signature_fit, "residual_frame", lambda *a, **k: calls.append(
        (a[1].index[0], len(a[1]))) or original(*a, **k))
    cached = fit_baselines([request])[0]
    # each whole window's residual once (the baseline's fit; without the cache also in two
    # left-out refits and as a whole-day candidate), each piece's once
    assert [calls.count((day.index[0], len(day))) for day in days] == [1, 1, 1]
    assert len(calls) == len(set(calls)) > 3

    monkeypatch.setattr(signature_fit, "residual_frame", original)

    class Forgetting(SegmentCache):
        """Keeps nothing: every fit computes every segment again, as before the cache."""

        def remember(self, kind, model, segment, details, compute):
            return compute()

    monkeypatch.setattr("graybox.calibration.SegmentCache", Forgetting)
    uncached = fit_baselines([request])[0]
    assert cached[0].to_json() == uncached[0].to_json()
    assert cached[1].to_json() == uncached[1].to_json()


def test_a_segments_results_are_found_by_its_estimates_digest_without_hashing_again(
        monkeypatch):
    model, frame, _, _ = _simulate_hidden(600, 4, q0=0.4, temp0=30.0)
    y, u = window_arrays(model, frame)
    rk4 = Integration("rk4", 2)
    cache = SegmentCache()
    states = cache.estimate(model, y, u, DT, rk4)
    hashed = []
    original = segment_cache.hashlib.sha256
    monkeypatch.setattr(segment_cache.hashlib, "sha256",
                        lambda *a: hashed.append(1) or original(*a))
    computed = []
    value = cache.remember("residual", model, states, ("a",), lambda: computed.append(1) or 7)
    again = cache.remember("residual", model, states, ("a",), lambda: computed.append(1) or 8)
    assert (value, again, computed, hashed) == (7, 7, [1], [])
    # a decimated window is its own segment, by factor; the same factor finds it again
    five = cache.remember("level", model, states.decimated(5), (), lambda: 5)
    three = cache.remember("level", model, states.decimated(3), (), lambda: 3)
    assert (five, three, hashed) == (5, 3, [])
    assert cache.remember("level", model, states.decimated(5), (), lambda: 0) == 5
    # the same data estimated again carries the same digest; other data another
    assert cache.estimate(model, y.copy(), u.copy(), DT, rk4).digest == states.digest
    assert cache.estimate(model, y[1:], u[1:], DT, rk4).digest != states.digest
    # a window without a digest (not the cache's estimate) is hashed, as before
    plain = estimate_states(model, y, u, DT, rk4)
    assert plain.digest is None
    assert cache.remember("residual", model, plain, ("a",), lambda: 9) == 7
    assert hashed
