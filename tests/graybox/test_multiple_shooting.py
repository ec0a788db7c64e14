"""The hidden states' multiple-shooting run (``graybox.state_estimation._run_hidden``).

Known answers: with hidden dynamics affine in the hidden states the chained chunks are the
sequential run from the start (to rounding: 1e-10 of the state's scale), and the confirming
second pass runs the chunks from their chained starts alone (one row per chunk, not
``1 + n_hidden``); with nonlinear hidden dynamics every pass is a full one and the run is the
one every pass computed in full gave (the function before the confirming pass was made
lazy, kept here as the reference), to the bit.
"""
from __future__ import annotations

import numpy as np

from graybox.integration import Integration, advance
from graybox.models.base import WhiteBoxModel
from graybox import state_estimation
from graybox.state_estimation import (_chunks, _joined, _Layout, _run, _run_hidden,
                                      estimate_states, moved_chunk_starts)

RK4 = Integration("rk4", 2)


class AffineHidden(WhiteBoxModel):
    """Two hidden lags ``h1``, ``h2`` driven by ``u`` and a measured state ``m`` they heat."""

    states = ("h1", "h2", "m")
    outputs = ("y", "m")
    inputs = ("u",)
    default_parameters = {"a": 0.02, "b": 0.05, "c": 0.3, "d": 0.01}
    initial_state = {"h1": 0.0, "h2": 0.0}

    def derivatives(self, x, u):
        p = self.parameters
        dh1 = -p["a"] * x[..., 0] + p["b"] * u[..., 0]
        dh2 = -p["c"] * x[..., 1] + u[..., 0]
        dm = -p["d"] * x[..., 2] + 0.004 * x[..., 0] + 0.001 * x[..., 1]
        return np.stack([dh1, dh2, dm], axis=-1)

    def output(self, x, u):
        return np.stack([x[..., 0] + x[..., 1] + 0.5 * u[..., 0], x[..., 2]], axis=-1)


class NonlinearHidden(AffineHidden):
    """The same with a saturating first lag: its chaining needs more than one pass."""

    def derivatives(self, x, u):
        p = self.parameters
        out = super().derivatives(x, u)
        out[..., 0] = -p["a"] * np.sinh(x[..., 0]) + p["b"] * u[..., 0]
        return out


def _data(model, n=400, seed=3):
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 25 + 1), 25)[:n, None]
    x = np.empty((n, 3))
    x[0] = 0.2, -0.1, 1.0
    for t in range(1, n):
        x[t] = advance(model.derivatives, x[t - 1:t], u[t - 1:t], u[t:t + 1], 1.0, RK4)[0]
    return model.output(x, u), u, x


def _every_pass_in_full(model, layout, y, u, dt, integration, start):
    """``_run_hidden`` as it was before its confirming pass was made lazy."""
    total = len(y)
    firsts, length = _chunks(total)
    scale = np.maximum(1.0, np.abs(start))
    delta = 1e-4 * scale
    guesses = np.repeat(start[None], len(firsts), axis=0)
    for _ in range(state_estimation.MAX_PASSES):
        base, sensitivity = state_estimation._full_pass(model, layout, y, u, dt, integration,
                                                        guesses, firsts, length, delta)
        used = guesses
        chained = state_estimation._chain(start, guesses, base[:, -1], sensitivity)
        if not np.max(np.abs(chained - guesses) / scale) > state_estimation.CHAIN_TOLERANCE:
            break
        guesses = chained
    return _joined(base, firsts, length, total), used


class _Rows:
    """The model's derivatives, recording the rows of every call."""

    def __init__(self, model):
        self.model, self.rows = model, []
        self.derivatives = model.derivatives

    def __call__(self, x, u):
        self.rows.append(len(x))
        return self.derivatives(x, u)


def test_an_affine_hidden_run_is_the_sequential_run_and_confirms_with_the_chunks_alone():
    model = AffineHidden()
    layout = _Layout(model)
    y, u, x = _data(model)
    start = x[0, layout.hidden]
    rows = _Rows(model)
    model.derivatives = rows
    hidden, starts, _ = _run_hidden(model, layout, y, u, 1.0, RK4, start)
    counted = list(rows.rows)
    firsts, _ = _chunks(len(y))
    # the sequential run: one chunk over the whole window
    sequential = _run(model, layout, y, u, 1.0, RK4, start[None], np.array([0]), len(y) - 1)[0]
    np.testing.assert_allclose(hidden, sequential, rtol=0, atol=1e-10)
    np.testing.assert_allclose(starts, sequential[firsts], rtol=0, atol=1e-10)
    np.testing.assert_allclose(hidden, x[:, layout.hidden], rtol=0, atol=1e-10)
    # pass 1: every chunk and its two perturbations; pass 2: the chunks alone
    assert sorted(set(counted)) == [len(firsts), 3 * len(firsts)]
    assert counted.count(len(firsts)) == counted.count(3 * len(firsts))


def test_the_lazy_confirming_pass_gives_every_full_passs_run_to_the_bit():
    for model in (AffineHidden(), NonlinearHidden()):
        layout = _Layout(model)
        y, u, x = _data(model, n=600, seed=5)
        start = x[0, layout.hidden] + np.array([0.05, -0.02])
        for integration in (RK4, Integration("rosenbrock", 2)):
            lazy = _run_hidden(model, layout, y, u, 1.0, integration, start)
            full = _every_pass_in_full(model, layout, y, u, 1.0, integration, start)
            assert np.array_equal(lazy[0], full[0]) and np.array_equal(lazy[1], full[1])


def test_a_nonlinear_hidden_run_takes_full_passes_until_it_chains():
    model = NonlinearHidden()
    layout = _Layout(model)
    y, u, x = _data(model, n=600, seed=5)
    rows = _Rows(model)
    model.derivatives = rows
    _run_hidden(model, layout, y, u, 1.0, RK4, x[0, layout.hidden] + np.array([0.5, 0.0]))
    firsts, _ = _chunks(len(y))
    # more than one full pass, each lazy pass before it failed to chain (then the full one)
    full = rows.rows.count(3 * len(firsts))
    assert full >= 2
    assert rows.rows.count(len(firsts)) in (full - 1, full)


def test_a_moved_start_carried_by_the_chunks_sensitivities_is_the_run_from_it():
    """An affine hidden run from a moved start, its chunk starts found from the estimate's
    kept sensitivities (no chaining), is the sequential run from that start; a nonlinear one
    to first order in the move."""
    for model, tolerance in ((AffineHidden(), 1e-9), (NonlinearHidden(), 1e-6)):
        layout = _Layout(model)
        y, u, x = _data(model, n=600, seed=5)
        start = x[0, layout.hidden]
        window = estimate_states(model, y, u, 1.0, RK4, start=start)
        firsts, _ = _chunks(len(y))
        move = np.array([1e-3, -2e-3])
        sequential = _run(model, layout, y, u, 1.0, RK4, (start + move)[None], np.array([0]),
                          len(y) - 1)[0]
        moved = moved_chunk_starts(window, move)
        np.testing.assert_allclose(moved, sequential[firsts], rtol=0, atol=tolerance)
        assert np.max(np.abs(moved - window.chunk_starts)) > 1e-4


def _long():
    """A window of at least ``SENSITIVITY_SAMPLES`` strides of ``SENSITIVITY_STRIDE`` chunks:
    its first pass samples the chunks' sensitivities."""
    return (state_estimation.SENSITIVITY_SAMPLES * state_estimation.SENSITIVITY_STRIDE + 3) \
        * state_estimation.CHUNK_SAMPLES + 7


def test_an_affine_long_run_chains_with_its_sampled_common_sensitivity():
    # known answer: the sequential run to 1e-10 of the scale, from a first pass that moves
    # every 8th chunk only and a confirming pass of the chunks alone; the common sensitivity
    # is every chunk's (the full pass's) to 1e-8
    model = AffineHidden()
    layout = _Layout(model)
    y, u, x = _data(model, n=_long(), seed=7)
    start = x[0, layout.hidden]
    rows = _Rows(model)
    model.derivatives = rows
    hidden, starts, sensitivity = _run_hidden(model, layout, y, u, 1.0, RK4, start)
    counted = sorted(set(rows.rows))
    model.derivatives = rows.derivatives
    firsts, _ = _chunks(len(y))
    sampled = len(np.arange(0, len(firsts) - 1, state_estimation.SENSITIVITY_STRIDE))
    assert counted == [len(firsts), len(firsts) + 2 * sampled]
    sequential = _run(model, layout, y, u, 1.0, RK4, start[None], np.array([0]), len(y) - 1)[0]
    np.testing.assert_allclose(hidden, sequential, rtol=0, atol=1e-10)
    np.testing.assert_allclose(starts, sequential[firsts], rtol=0, atol=1e-10)
    full = _every_pass_in_full(model, layout, y, u, 1.0, RK4, start)
    np.testing.assert_allclose(hidden, full[0], rtol=0, atol=1e-10)
    # each chunk's own sensitivity, as a full pass computes it at the chained starts
    delta = 1e-4 * np.maximum(1.0, np.abs(start))
    batch = np.concatenate([starts] + [starts + delta[i] * np.eye(2)[i] for i in range(2)])
    runs = _run(model, layout, y, u, 1.0, RK4, batch, np.tile(firsts, 3), _chunks(len(y))[1])
    ends = runs[:len(firsts), -1]
    chunk_by_chunk = np.stack([(runs[(i + 1) * len(firsts):(i + 2) * len(firsts), -1] - ends)
                               / delta[i] for i in range(2)], axis=-1)
    np.testing.assert_allclose(sensitivity[:-1], chunk_by_chunk[:-1], rtol=0, atol=1e-8)


def test_a_nonlinear_long_run_whose_sensitivities_differ_is_the_full_passes_run_to_the_bit():
    model = NonlinearHidden()
    layout = _Layout(model)
    y, u, x = _data(model, n=_long(), seed=7)
    start = x[0, layout.hidden] + np.array([0.3, 0.0])
    hidden, starts, _ = _run_hidden(model, layout, y, u, 1.0, RK4, start)
    full = _every_pass_in_full(model, layout, y, u, 1.0, RK4, start)
    assert np.array_equal(hidden, full[0]) and np.array_equal(starts, full[1])
