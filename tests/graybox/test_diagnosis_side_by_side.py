"""A diagnosis' hypotheses fitted side by side, their white-box runs batched
(:mod:`graybox.diagnosis_runs`): the same diagnosis, number for number, as the hypotheses
fitted one by one, and the models it batches are the ones that compute per-row parameters as
their scalar ones (:func:`graybox.row_parameters.row_variants`).

Tolerance: exact. Each hypothesis' fit runs unchanged and is given, for every value, what its
own run gives (each period's initial hidden state fitted by its own ``least_squares`` on its
own rows of the batch, elementwise the same arithmetic; the rest of the run its own)."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

import graybox.diagnosis_runs as runs_module
from graybox.diagnosis import diagnose_window
from graybox.integration import Integration, advance
from graybox.level_tier import fit_level, level_data
from graybox.models.base import WhiteBoxModel
from graybox.parameter_estimation import with_parameters
from graybox.row_parameters import row_variants

DT = 10.0
RK4 = Integration()


class Pack(WhiteBoxModel):
    """A charge ``q`` counted from the current (hidden), an RC voltage ``v`` (hidden,
    relaxing) and a measured temperature; the terminal voltage reads both."""

    states = ("q", "v", "temp")
    outputs = ("voltage", "temp")
    inputs = ("current",)
    default_parameters = {"capacity": 2000.0, "slope": 2.0, "r": 0.5, "tau": 200.0, "r0": 0.1,
                          "heating": 0.002}
    initial_state = {"q": 0.5}

    def derivatives(self, x, u):
        p = self.parameters
        current = u[..., 0]
        return np.stack([-current / p["capacity"],
                         p["r"] * current / p["tau"] - x[..., 1] / p["tau"],
                         p["heating"] * current ** 2 - 0.005 * x[..., 2]], axis=-1)

    def output(self, x, u):
        p = self.parameters
        voltage = 10.0 + p["slope"] * x[..., 0] - x[..., 1] - p["r0"] * u[..., 0]
        return np.stack([voltage, x[..., 2]], axis=-1)


class ScalarOnly(Pack):
    """The pack written with ``math.exp`` of a parameter: no per-row parameters."""

    def output(self, x, u):
        out = super().output(x, u)
        out[..., 0] *= math.exp(self.parameters["r0"] - 0.1)
        return out


class ReadOnce(Pack):
    """The pack that reads its resistance once, in its constructor."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.resistance = self.parameters["r0"]

    def output(self, x, u):
        p = self.parameters
        voltage = 10.0 + p["slope"] * x[..., 0] - x[..., 1] - self.resistance * u[..., 0]
        return np.stack([voltage, x[..., 2]], axis=-1)


def pack_frame(model, seed, n=1500, bias=0.0):
    """The pack's run under a stepped current, its outputs with sensor noise."""
    rng = np.random.default_rng(seed)
    current = np.repeat(rng.uniform(-20.0, 20.0, n // 30 + 1), 30)[:n, None]
    x = np.empty((n, 3))
    x[0] = (0.6, 0.0, 0.5)
    for t in range(1, n):
        x[t] = advance(model.derivatives, x[t - 1:t], current[t - 1:t], current[t:t + 1], DT,
                       Integration("rk4", 4))[0]
    y = model.output(x, current) + rng.normal(0.0, (0.01, 0.02), (n, 2))
    y[:, 0] += bias
    index = pd.date_range("2026-01-01", periods=n, freq="10s", tz="UTC")
    return pd.DataFrame({"voltage": y[:, 0], "temp": y[:, 1], "current": current[:, 0]},
                        index=index)


@pytest.fixture(scope="module")
def levels():
    # (no drifting hidden state's change among the features: the charge's drift is not
    # what this test is about)
    data = level_data(Pack(), [pack_frame(Pack(), 0)], DT, 12, integration=RK4,
                      drift={c: () for c in Pack.outputs})
    return {c: fit_level(errors, features, 12, None, segments, drifting=())
            for c, (errors, features, segments) in data.items()}


def test_hypotheses_fitted_side_by_side_are_the_ones_fitted_alone(levels, monkeypatch):
    window = [pack_frame(with_parameters(Pack(), {"r0": 0.13}), 1)]
    batches = []
    batched = runs_module.initial_hidden_together

    def counting(model, pieces, *args, **kwargs):
        batches.append(len(pieces))
        return batched(model, pieces, *args, **kwargs)

    monkeypatch.setattr(runs_module, "initial_hidden_together", counting)
    together = diagnose_window(Pack(), levels, window)
    # every parameter, bias and gain hypothesis screened on one batch; the refined ones
    # batched too
    assert batches[0] == 6 + 2 * 2 and len(batches) > 1
    assert (together.best.kind, together.best.target) == ("parameter", "r0")
    monkeypatch.setattr(runs_module, "row_variants", lambda *args: None)
    batches.clear()
    alone = diagnose_window(Pack(), levels, window)
    assert batches == []
    assert together.hypotheses == alone.hypotheses
    assert (together.effective_samples, together.n_obs) == (alone.effective_samples,
                                                            alone.n_obs)


def test_variants_are_batched_only_where_the_class_computes_per_row_parameters():
    rng = np.random.default_rng(0)
    x = np.column_stack([rng.uniform(0.2, 0.9, 20), rng.normal(0.0, 1.0, 20),
                         rng.uniform(20.0, 30.0, 20)])
    u = rng.normal(0.0, 10.0, (20, 1))
    changes = [{}, {"r0": 0.12}, {"capacity": 2100.0}, {"tau": 180.0}]
    variants = [with_parameters(Pack(), c) for c in changes]
    rows = row_variants(variants, x, u)
    assert rows is not None
    index = np.array([2, 0, 1, 3, 1])
    model = rows(index)
    expected = np.concatenate([variants[i].output(x[k:k + 1], u[k:k + 1])
                               for k, i in enumerate(index)])
    np.testing.assert_array_equal(model.output(x[:5], u[:5]), expected)
    for kind in (ScalarOnly, ReadOnce):
        assert row_variants([with_parameters(kind(), c) for c in changes], x, u) is None
    # a variant the probe cannot tell from the first (a heating the probe's zero current
    # does not reach) is not batched: a model that ignored it would pass unseen
    quiet = [with_parameters(Pack(), c) for c in ({}, {"heating": 0.003})]
    assert row_variants(quiet, x, np.zeros_like(u)) is None


def test_errors_from_states_or_starts_estimated_before_are_the_errors_estimated_here():
    # the diagnosis estimates the baseline's states once (for the innovations and the
    # k-step errors) and a batch fits the trials' starts: either, handed in, gives the errors
    # prediction_errors computes from scratch
    from graybox.parameter_estimation import ErrorSetup, prediction_errors
    from graybox.state_estimation import estimate_states, window_arrays

    frame = pack_frame(Pack(), 2)
    segments = [window_arrays(Pack(), frame)]
    setup = ErrorSetup(DT, 1, 12, 3, RK4)
    alone = prediction_errors(Pack(), segments, setup)
    states = [estimate_states(Pack(), *segments[0], DT, RK4)]
    start = np.array([states[0].initial_hidden[s] for s in Pack().hidden_states])
    for given in (dict(states=states), dict(starts=[start])):
        again = prediction_errors(Pack(), segments, setup, **given)
        for channel, (errors, features, positions) in alone.items():
            np.testing.assert_array_equal(again[channel][0], errors)
            np.testing.assert_array_equal(again[channel][1], features)
            np.testing.assert_array_equal(again[channel][2], positions)


class GuessFromParameter(Pack):
    """The pack whose charge's initial guess is a parameter that its dynamics read too."""

    default_parameters = {**Pack.default_parameters, "full": 1.0}

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.initial_state = {"q": 0.5 * self.parameters["full"]}

    def derivatives(self, x, u):
        rates = super().derivatives(x, u)
        rates[..., 0] = rates[..., 0] / self.parameters["full"]
        return rates


def test_trials_whose_start_fits_begin_elsewhere_are_fitted_one_by_one(monkeypatch):
    from graybox.diagnosis_runs import Trial, trial_errors
    from graybox.parameter_estimation import ErrorSetup, prediction_errors
    from graybox.state_estimation import window_arrays

    batches = []
    batched = runs_module.initial_hidden_together
    monkeypatch.setattr(runs_module, "initial_hidden_together",
                        lambda model, pieces, *a, **k: batches.append(len(pieces))
                        or batched(model, pieces, *a, **k))
    segments = [window_arrays(Pack(), pack_frame(Pack(), 3))]
    setup = ErrorSetup(DT, 1, 12, 3, RK4)
    models = [with_parameters(GuessFromParameter(), {"full": f}) for f in (1.0, 1.2)]
    results = trial_errors([Trial(m, segments) for m in models], setup)
    assert batches == []
    for model, result in zip(models, results):
        alone = prediction_errors(model, segments, setup)
        np.testing.assert_array_equal(result["voltage"][0], alone["voltage"][0])
    # the same guess: batched, and the same errors
    models = [with_parameters(Pack(), {"r0": r}) for r in (0.1, 0.12)]
    results = trial_errors([Trial(m, segments) for m in models], setup)
    assert batches == [2]
    for model, result in zip(models, results):
        alone = prediction_errors(model, segments, setup)
        np.testing.assert_array_equal(result["voltage"][0], alone["voltage"][0])


def test_diagnose_on_a_fitted_hidden_state_baseline_ranks_the_resistance_first():
    """End to end on a baseline as the product fits it (``GrayBox``, uncalibrated): the
    signature carries the output channels' level tiers, and ``diagnose`` reads them, fits
    each period's hidden start for every trial, and names the pack's grown series resistance
    (r0 0.1 -> 0.13 ohm) first, its estimate within 0.2 % of the truth; on a healthy window of
    the same pack the best hypothesis explains five orders of magnitude less.

    The interval's width is pinned over seeds in test_start_uncertainty.py (it was 2.1 times
    too narrow before the hidden start's estimation noise was counted in it)."""
    from graybox.diagnosis import diagnose
    from graybox.estimator import GrayBox

    baseline = GrayBox(Pack(), calibrate=False).fit(
        [pack_frame(Pack(), seed) for seed in (10, 11, 12)]).signature_
    assert all(baseline.channel(c).level is not None for c in Pack.outputs)
    faulty = diagnose(baseline, [pack_frame(with_parameters(Pack(), {"r0": 0.13}), 13)],
                      Pack())
    best = faulty.best
    assert (best.kind, best.target) == ("parameter", "r0")
    assert best.estimate == pytest.approx(0.13, rel=0.002)
    assert best.score > 1e5
    healthy = diagnose(baseline, [pack_frame(Pack(), 14)], Pack())
    assert healthy.best is None or healthy.best.score < 1e-4 * best.score
