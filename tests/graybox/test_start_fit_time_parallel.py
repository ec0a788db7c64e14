"""The start fit's time-parallel runs (``graybox.state_estimation._run_chained``, used by
``_StartFit.hidden_runs``) against the sequential runs they replace.

Known answers: a time-parallel run is the sequential run (``_run``) to 1e-9 of the state's
scale, with hidden dynamics affine and nonlinear in the hidden states; a run that diverges
is run sequentially, and gives the sequential run's non-finite values. The fitted starts
(``least_squares`` on errors from chained runs) are the sequential fit's to 1e-6 relative,
on an affine model, a nonlinear one and the battery pack (measured: 2-3e-7 of the scale at
most; the chained runs differ from the sequential ones at rounding, the forward differences
of 1e-6 of the scale amplify it, and the solver's own tolerances, 1e-8, let its last iterate
differ by more); a start the data do not determine (a state of charge above the OCV table's
last breakpoint) is left where the sequential fit leaves it.
"""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks.zoo.families.ev_battery import BatteryWhiteBox
from graybox import state_estimation
from graybox.integration import Integration
from graybox.state_estimation import (_Layout, _run, _run_chained, _StartFit,
                                      initial_hidden_together)
from tests.graybox.test_hidden_starts_together import _noise, _segments
from tests.graybox.test_multiple_shooting import AffineHidden, NonlinearHidden

RK4 = Integration("rk4", 2)


def _fitted(model, pieces, time_parallel, monkeypatch):
    """The starts of ``pieces`` fitted together, with time-parallel or sequential runs."""
    original = _StartFit.__init__

    def made(self, *args, **kwargs):
        original(self, *args, time_parallel=time_parallel, **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(_StartFit, "__init__", made)
        return initial_hidden_together(model, pieces, 1.0, RK4)


def _drives(model, starts, n, rng, noise, level=1.0):
    """Runs of ``model`` from each full state of ``starts`` under a stepped input."""
    runs = []
    for x0 in starts:
        drive = level * np.repeat(rng.uniform(-1, 1, n // 25 + 1), 25)[:n, None]
        runs.append((x0, drive, _noise(model, drive, noise, rng)))
    return _segments(model, runs)


@pytest.mark.parametrize("model_class", [AffineHidden, NonlinearHidden])
def test_a_chained_run_is_the_sequential_run(model_class):
    model = model_class()
    layout = _Layout(model)
    rng = np.random.default_rng(4)
    (y, u), = _drives(model, [[0.3, -0.2, 1.0]], 900, rng, [0.01, 0.01])
    starts = np.array([[0.3, -0.2], [1.2, 0.4], [-0.8, 2.0]])
    first = np.zeros(3, dtype=int)
    last = np.array([899, 899, 600])          # the third run shorter: held past its end
    sequential = _run(model, layout, y, u, 1.0, RK4, starts, first, 899, last)
    chunks = -(-899 // state_estimation.CHUNK_SAMPLES)
    hidden, chained, _, ok = _run_chained(
        lambda rows: model, layout, y, u, 1.0, RK4, starts, first, 899, last,
        np.arange(3), np.repeat(starts[:, None], chunks, axis=1),
        np.zeros((3, chunks, 2, 2)), np.zeros(3, dtype=bool), np.ones(2))
    assert ok.all()
    np.testing.assert_allclose(hidden, sequential, rtol=0, atol=1e-9)
    np.testing.assert_allclose(chained[:, 0], starts, rtol=0, atol=0)


def test_an_affine_evaluation_guessed_from_the_last_chains_with_the_chunks_alone():
    model = AffineHidden()
    layout = _Layout(model)
    rng = np.random.default_rng(6)
    pieces = _drives(model, [[0.3, -0.2, 1.0], [-1.0, 0.5, 2.0]], 900, rng, [0.01, 0.01])
    problem = _StartFit(model, layout, pieces, 1.0, RK4)
    delta = 1e-6 * problem.scale
    runs = []
    original = state_estimation._run

    def recorded(model, layout, y, u, dt, integration, starts, *rest):
        runs.append(len(starts))
        return original(model, layout, y, u, dt, integration, starts, *rest)

    z = np.array([[0.0, 0.0], [0.5, 0.5]])
    problem.errors_and_jacobians(z, delta)
    state_estimation._run = recorded
    try:
        moved, jacobian = problem.errors_and_jacobians(z + [[0.4, -0.3], [-0.2, 0.1]], delta)
    finally:
        state_estimation._run = original
    chunks = -(-899 // state_estimation.CHUNK_SAMPLES)
    # one pass of every run's chunks from their moved guesses: 2 segments x 3 runs
    assert runs == [2 * 3 * chunks]
    sequential = _StartFit(model, layout, pieces, 1.0, RK4, time_parallel=False)
    expected, expected_jacobian = sequential.errors_and_jacobians(
        z + [[0.4, -0.3], [-0.2, 0.1]], delta)
    np.testing.assert_allclose(moved, expected, rtol=0, atol=1e-8)
    np.testing.assert_allclose(jacobian, expected_jacobian, rtol=1e-6, atol=1e-6)


def test_a_diverging_run_is_run_sequentially():
    model = NonlinearHidden({"a": -0.5})       # sinh growth: blows up within the window
    layout = _Layout(model)
    rng = np.random.default_rng(8)
    y = rng.normal(0, 1, (300, 2))
    u = rng.uniform(-1, 1, (300, 1))
    starts = np.array([[3.0, 0.0]])
    first, last = np.zeros(1, dtype=int), np.array([299])
    with np.errstate(all="ignore"):
        sequential = _run(model, layout, y, u, 1.0, RK4, starts, first, 299, last)
        chunks = -(-299 // state_estimation.CHUNK_SAMPLES)
        hidden, _, _, ok = _run_chained(
            lambda rows: model, layout, y, u, 1.0, RK4, starts, first, 299, last,
            np.zeros(1, dtype=int), np.repeat(starts[:, None], chunks, axis=1),
            np.zeros((1, chunks, 2, 2)), np.zeros(1, dtype=bool), np.ones(2))
    assert not ok[0]
    assert not np.all(np.isfinite(sequential))
    np.testing.assert_array_equal(hidden, sequential)


@pytest.mark.parametrize("model_class", [AffineHidden, NonlinearHidden])
def test_the_starts_are_the_sequential_fits(model_class, monkeypatch):
    model = model_class()
    rng = np.random.default_rng(9)
    starts = [[0.3, -0.2, 1.0], [-1.0, 0.5, 2.0], [1.5, 1.0, 0.0], [0.0, -2.0, 3.0]]
    pieces = _drives(model, starts, 1200, rng, [0.02, 0.01])
    sequential = _fitted(model, pieces, False, monkeypatch)
    parallel = _fitted(model, pieces, True, monkeypatch)
    np.testing.assert_allclose(parallel, sequential, rtol=1e-6, atol=1e-6)
    # and near the truth (``h2`` decays within seconds: a few samples determine it)
    np.testing.assert_allclose(sequential, np.array(starts)[:, :2], atol=0.2)


def test_the_battery_packs_starts_and_an_undetermined_one_are_the_sequential_fits(
        monkeypatch):
    truth = BatteryWhiteBox({"r0": 0.085, "r1": 0.02, "r2": 0.03, "capacity": 2.6e5})
    model, rng = BatteryWhiteBox(), np.random.default_rng(7)
    runs = []
    # the last: a full pack parked, above the OCV table's last breakpoint (the voltage does
    # not depend on the state of charge there: any value is a minimum)
    for soc, v1, v2, level in [(0.8, 1.0, 2.0, 60.0), (0.3, -0.5, 0.0, -120.0),
                               (0.55, 0.0, 0.5, 0.05), (0.12, 2.0, 3.0, 20.0),
                               (0.65, 0.2, -1.0, 150.0), (1.0, 0.0, 0.0, 0.5)]:
        n = 1200
        current = level * np.repeat(rng.uniform(0, 2, n // 30 + 1), 30)[:n]
        u = np.column_stack([current, np.full(n, 15.0)])
        runs.append(([soc, v1, v2, 25.0], u, _noise(truth, u, [0.05, 0.05], rng)))
    pieces = _segments(truth, runs)
    sequential = _fitted(model, pieces, False, monkeypatch)
    parallel = _fitted(model, pieces, True, monkeypatch)
    np.testing.assert_allclose(parallel, sequential, rtol=1e-6, atol=1e-6)
    # the undetermined start stays where the sequential fit leaves it (measured: 3e-12
    # apart; the search reached the flat part from the determined one, on paths that differ
    # at rounding), not somewhere else on the flat part
    assert sequential[-1, 0] > 1.0
    assert parallel[-1, 0] == pytest.approx(sequential[-1, 0], rel=1e-9)
