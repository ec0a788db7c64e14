"""The initial hidden states of several segments fitted side by side, their evaluations
batched (:func:`graybox.state_estimation.initial_hidden_together`), are the per-segment fits'.

Tolerance: each segment's ``least_squares`` runs unchanged and is given, for each point, the
values the per-segment fit computes (its own rows of the batched run, elementwise the same
arithmetic), so the starts agree to rounding: we require 1e-12. (A single problem over the
stacked starts, tried first, agreed to 1e-7 on these cases but not on a state the data do
not determine, a state of charge above the OCV table's last breakpoint:
``test_an_undetermined_start_stays_where_the_separate_fit_leaves_it``.)
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from benchmarks.zoo.families.ev_battery import BatteryWhiteBox
from graybox.integration import Integration, advance
from graybox.models.base import WhiteBoxModel
from graybox.segment_cache import SegmentCache
from graybox import state_estimation
from graybox.state_estimation import _initial_hidden, _Layout, initial_hidden_together

RK4 = Integration("rk4", 2)


class LinearHidden(WhiteBoxModel):
    """A hidden first-order lag ``h`` driven by ``u`` and a measured state ``m`` it heats;
    the output ``y = h + 0.5 u`` (feed-through)."""

    states = ("h", "m")
    outputs = ("y", "m")
    inputs = ("u",)
    default_parameters = {"a": 0.02, "b": 0.05, "c": 0.01, "d": 0.004}
    initial_state = {"h": 0.0}

    def derivatives(self, x, u):
        p = self.parameters
        dh = -p["a"] * x[..., 0] + p["b"] * u[..., 0]
        dm = -p["c"] * x[..., 1] + p["d"] * x[..., 0]
        return np.stack([dh, dm], axis=-1)

    def output(self, x, u):
        return np.stack([x[..., 0] + 0.5 * u[..., 0], x[..., 1]], axis=-1)


def _segment(model, x0, current, noise, rng):
    """The model's own run from ``x0`` under ``current`` (T, n_inputs) and its noisy
    outputs: (y, u)."""
    return _segments(model, [(x0, current, _noise(model, current, noise, rng))])[0]


def _noise(model, current, noise, rng):
    """The output noise of a run under ``current``: draw it in a test's loop where
    :func:`_segment` would (right after the run's current), so the draws stay the same."""
    return rng.normal(0, noise, (len(current), len(model.outputs)))


def _segments(model, runs):
    """(y, u) of :func:`_segment` for each ``(x0, current, drawn noise)`` of ``runs``: the runs
    advanced side by side, one row each (the models' arithmetic is row by row, so a row is its
    run alone), the rows of a shorter run past its end dropped."""
    length = max(len(current) for _, current, _ in runs)
    # the shorter runs' inputs held at their last value to the longest's end
    inputs = np.stack([np.concatenate([current, np.repeat(current[-1:], length - len(current),
                                                          axis=0)]) for _, current, _ in runs])
    x = np.empty((len(runs), length, len(runs[0][0])))
    x[:, 0] = [x0 for x0, _, _ in runs]
    for t in range(1, length):
        x[:, t] = advance(model.derivatives, x[:, t - 1], inputs[:, t - 1], inputs[:, t], 1.0,
                          Integration("rk4", 8))
    return [(model.output(x[k, :len(current)], current) + drawn, current)
            for k, (_, current, drawn) in enumerate(runs)]


def _separately(model, pieces):
    layout = _Layout(model)
    return np.array([_initial_hidden(model, layout, y, u, 1.0, RK4) for y, u in pieces])


def _together_and_alone(model, pieces):
    """The hidden starts of ``pieces`` fitted together and each alone (:func:`_separately`)."""
    alone = _separately(model, pieces)
    return initial_hidden_together(model, pieces, 1.0, RK4), alone


def test_a_linear_hidden_state_is_fitted_together_as_alone_and_near_the_truth():
    model, rng = LinearHidden(), np.random.default_rng(3)
    truths = [-4.0, 0.0, 2.5, 7.0, 1.0]
    # lengths shorter than, equal to and longer than the 900-s fit span: padded rows
    lengths = [1500, 300, 900, 1200, 40]
    runs = []
    for h0, n in zip(truths, lengths):
        drive = np.repeat(rng.uniform(-3, 3, n // 60 + 1), 60)[:n, None]
        runs.append(([h0, 20.0], drive, _noise(model, drive, [0.05, 0.02], rng)))
    together, alone = _together_and_alone(model, _segments(model, runs))
    assert together.shape == (5, 1)
    np.testing.assert_allclose(together, alone, rtol=1e-12, atol=1e-12)
    # and both are the truth to the noise's precision (0.05 over >= 40 samples)
    np.testing.assert_allclose(together[:, 0], truths, atol=0.05)


def test_the_battery_packs_starts_fitted_together_are_the_separate_fits():
    truth = BatteryWhiteBox({"r0": 0.085, "r1": 0.02, "r2": 0.03, "capacity": 2.6e5})
    model, rng = BatteryWhiteBox(), np.random.default_rng(7)
    runs = []
    for soc, v1, v2, level in [(0.8, 1.0, 2.0, 60.0), (0.3, -0.5, 0.0, -120.0),
                               (0.55, 0.0, 0.5, 0.05), (0.12, 2.0, 3.0, 20.0),
                               (0.65, 0.2, -1.0, 150.0)]:
        n = 1200
        # a drive-like current around ``level`` (parked: a standby trickle), ambient 15 C
        current = level * np.repeat(rng.uniform(0, 2, n // 30 + 1), 30)[:n]
        u = np.column_stack([current, np.full(n, 15.0)])
        runs.append(([soc, v1, v2, 25.0], u, _noise(truth, u, [0.05, 0.05], rng)))
    together, alone = _together_and_alone(model, _segments(truth, runs))
    np.testing.assert_allclose(together, alone, rtol=1e-12, atol=1e-12)


def test_the_battery_packs_groups_do_not_change_the_starts(monkeypatch):
    model, rng = BatteryWhiteBox(), np.random.default_rng(11)
    runs = []
    for soc in (0.2, 0.4, 0.6, 0.9):
        current = np.repeat(rng.uniform(-50, 100, 31), 30)[:900]
        u = np.column_stack([current, np.full(900, 20.0)])
        runs.append(([soc, 0.0, 0.0, 22.0], u, _noise(model, u, [0.05, 0.05], rng)))
    pieces = _segments(model, runs)
    all_at_once = initial_hidden_together(model, pieces, 1.0, RK4)
    monkeypatch.setattr(state_estimation, "SEGMENTS_TOGETHER", 3)   # groups of 3 and 1
    in_groups = initial_hidden_together(model, pieces, 1.0, RK4)
    np.testing.assert_allclose(in_groups, all_at_once, rtol=1e-12, atol=1e-12)


def test_an_undetermined_start_stays_where_the_separate_fit_leaves_it():
    # a full pack parked: above the table's last breakpoint the output does not depend on
    # the state of charge, so any value there is a minimum; beside well-determined segments
    # (whose successful steps widened a shared trust region) it must not wander
    model, rng = BatteryWhiteBox(), np.random.default_rng(13)
    runs = []
    for soc, level in [(0.3, 80.0), (0.5, -60.0), (0.7, 120.0), (1.0, 0.5), (0.4, 40.0)]:
        current = level * np.repeat(rng.uniform(0, 2, 31), 30)[:900]
        u = np.column_stack([current, np.full(900, 18.0)])
        runs.append(([soc, 0.0, 0.0, 22.0], u, _noise(model, u, [0.05, 0.05], rng)))
    together, alone = _together_and_alone(model, _segments(model, runs))
    np.testing.assert_allclose(together, alone, rtol=1e-12, atol=1e-12)


def test_a_cached_start_is_used_without_fitting_again(monkeypatch):
    model, rng = LinearHidden(), np.random.default_rng(5)
    drive = np.repeat(rng.uniform(-3, 3, 21), 60)[:1200, None]
    y, u = _segment(model, [3.0, 20.0], drive, [0.05, 0.02], rng)
    cache = SegmentCache(storing=False)
    cache.stage_start(model, y, u, 1.0, RK4)
    cache.fit_starts()
    fits = []
    monkeypatch.setattr(state_estimation, "_initial_hidden", lambda *a: fits.append(1))
    states = cache.estimate(model, y, u, 1.0, RK4)
    assert fits == []
    assert states.initial_hidden["h"] == pytest.approx(3.0, abs=0.05)
    # the start is used once: the same data again replays the chained chunks
    again = cache.estimate(model, y, u, 1.0, RK4)
    np.testing.assert_array_equal(again.states, states.states)
    assert fits == []
