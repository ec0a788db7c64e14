"""The initial hidden states of several segments fitted as one batched least-squares problem
are the per-segment fits' (:func:`graybox.state_estimation.initial_hidden_together`).

Tolerances: each segment's problem is independent, so the stacked problem's minimiser is the
per-segment minimisers; the fits differ only in the trust-region path and where the stopping
tests (relative 1e-8 on cost and step) fire. For a linear model the problem is linear and
both land on its solution to within those tests (we require 1e-6 relative, against a
standard error of the start of about 1e-2 from the noise); for the battery pack the
piecewise-linear OCV table leaves it piecewise linear, and we require 1e-6 of state of charge
(0.2 A s of a 75-Ah pack) and 1e-4 V of the RC voltages (a five-hundredth of the 0.05-V voltage
noise), far below what the data determine.
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
    x = np.empty((len(current), len(x0)))
    x[0] = x0
    for t in range(1, len(current)):
        x[t] = advance(model.derivatives, x[t - 1:t], current[t - 1:t], current[t:t + 1], 1.0,
                       Integration("rk4", 8))[0]
    y = model.output(x, current)
    return y + rng.normal(0, noise, y.shape), current


def _separately(model, pieces):
    layout = _Layout(model)
    return np.array([_initial_hidden(model, layout, y, u, 1.0, RK4) for y, u in pieces])


def test_a_linear_hidden_state_is_fitted_together_as_alone_and_near_the_truth():
    model, rng = LinearHidden(), np.random.default_rng(3)
    truths = [-4.0, 0.0, 2.5, 7.0, 1.0]
    # lengths shorter than, equal to and longer than the 900-s fit span: padded rows
    lengths = [1500, 300, 900, 1200, 40]
    pieces = []
    for h0, n in zip(truths, lengths):
        drive = np.repeat(rng.uniform(-3, 3, n // 60 + 1), 60)[:n, None]
        pieces.append(_segment(model, [h0, 20.0], drive, [0.05, 0.02], rng))
    alone = _separately(model, pieces)
    together = initial_hidden_together(model, pieces, 1.0, RK4)
    assert together.shape == (5, 1)
    np.testing.assert_allclose(together, alone, rtol=1e-6, atol=1e-6)
    # and both are the truth to the noise's precision (0.05 over >= 40 samples)
    np.testing.assert_allclose(together[:, 0], truths, atol=0.05)


def test_the_battery_packs_starts_fitted_together_are_the_separate_fits():
    truth = BatteryWhiteBox({"r0": 0.085, "r1": 0.02, "r2": 0.03, "capacity": 2.6e5})
    model, rng = BatteryWhiteBox(), np.random.default_rng(7)
    pieces = []
    for soc, v1, v2, level in [(0.8, 1.0, 2.0, 60.0), (0.3, -0.5, 0.0, -120.0),
                               (0.55, 0.0, 0.5, 0.05), (0.12, 2.0, 3.0, 20.0),
                               (0.65, 0.2, -1.0, 150.0)]:
        n = 1200
        # a drive-like current around ``level`` (parked: a standby trickle), ambient 15 C
        current = level * np.repeat(rng.uniform(0, 2, n // 30 + 1), 30)[:n]
        u = np.column_stack([current, np.full(n, 15.0)])
        pieces.append(_segment(truth, [soc, v1, v2, 25.0], u, [0.05, 0.05], rng))
    alone = _separately(model, pieces)
    together = initial_hidden_together(model, pieces, 1.0, RK4)
    np.testing.assert_allclose(together[:, 0], alone[:, 0], rtol=0, atol=1e-6)
    np.testing.assert_allclose(together[:, 1:], alone[:, 1:], rtol=0, atol=1e-4)


def test_the_battery_packs_groups_do_not_change_the_starts(monkeypatch):
    model, rng = BatteryWhiteBox(), np.random.default_rng(11)
    pieces = []
    for soc in (0.2, 0.4, 0.6, 0.9):
        current = np.repeat(rng.uniform(-50, 100, 31), 30)[:900]
        u = np.column_stack([current, np.full(900, 20.0)])
        pieces.append(_segment(model, [soc, 0.0, 0.0, 22.0], u, [0.05, 0.05], rng))
    all_at_once = initial_hidden_together(model, pieces, 1.0, RK4)
    monkeypatch.setattr(state_estimation, "SEGMENTS_TOGETHER", 3)   # groups of 3 and 1
    in_groups = initial_hidden_together(model, pieces, 1.0, RK4)
    np.testing.assert_allclose(in_groups[:, 0], all_at_once[:, 0], rtol=0, atol=1e-6)
    np.testing.assert_allclose(in_groups[:, 1:], all_at_once[:, 1:], rtol=0, atol=1e-4)


def test_a_cached_start_is_used_without_fitting_again(monkeypatch):
    model, rng = LinearHidden(), np.random.default_rng(5)
    drive = np.repeat(rng.uniform(-3, 3, 21), 60)[:1200, None]
    y, u = _segment(model, [3.0, 20.0], drive, [0.05, 0.02], rng)
    cache = SegmentCache(storing=False)
    cache.fit_starts(model, [(y, u)], 1.0, RK4)
    fits = []
    monkeypatch.setattr(state_estimation, "_initial_hidden", lambda *a: fits.append(1))
    states = cache.estimate(model, y, u, 1.0, RK4)
    assert fits == []
    assert states.initial_hidden["h"] == pytest.approx(3.0, abs=0.05)
    # the start is used once: the same data again replays the chained chunks
    again = cache.estimate(model, y, u, 1.0, RK4)
    np.testing.assert_array_equal(again.states, states.states)
    assert fits == []
