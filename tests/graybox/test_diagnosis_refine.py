"""The refinement of one screened hypothesis (``graybox.diagnosis._refine``) on hypotheses
whose weighted errors are known functions of the free value, each call of which stands for
one white-box run: it reaches the least-squares minimum that a bounded scalar search finds
independently, and it runs no more values than the known answers below."""
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from graybox.diagnosis import REFINE_XTOL, SCREEN_REACH, _Objective, _refine, _Rows, _screen

N = 200
T = np.linspace(0.0, 20.0, N)


def objective(errors, runs: list) -> _Objective:
    """A parameter hypothesis (scale 1) whose weighted errors at ``x`` are ``errors(x)``;
    ``runs`` collects every value run."""
    def weighted(x: float) -> np.ndarray:
        runs.append(x)
        return errors(x)
    rows = _Rows(np.ones(N), np.array([0, N]), np.array([1.0]))
    return _Objective("parameter", "p", 1.0, 1.0, weighted, (-np.inf, np.inf), rows)


def test_a_screened_value_far_out_that_explains_more_than_the_baseline_is_the_fit():
    # a sensor bias 40 spreads out: the errors are linear in it, so the screened value is the
    # minimum; refined from the baseline, the trust region walked 1, 3, 7, 15, 31 (6 runs)
    rng = np.random.default_rng(3)
    noise = rng.normal(0.0, 1.0, N)
    runs = []
    bias = objective(lambda x: noise + 40.0 - x, runs)
    screened = _screen(bias, bias.weighted(0.0))
    assert abs(screened.value) > SCREEN_REACH
    runs.clear()
    fit = _refine(bias, screened)
    assert runs == [screened.value]          # its one run: no step is left to take
    assert fit.value == pytest.approx(40.0 + noise.mean(), abs=1e-6)   # a finite difference's


def test_a_curved_hypothesis_is_refined_to_the_least_squares_minimum_in_few_runs():
    # a decay rate 1.6 times the baseline's: the errors bend away from linear, and a
    # Gauss-Newton step on the secant falls short; the refinement's value is the minimum
    # of |errors|^2 / 2 to REFINE_XTOL, found on 4 runs from the screened value
    rng = np.random.default_rng(5)
    data = 5.0 * np.exp(-0.16 * T) + rng.normal(0.0, 0.05, N)

    def errors(x):
        return (data - 5.0 * np.exp(-0.1 * (1.0 + x) * T)) / 0.05

    runs = []
    decay = objective(errors, runs)
    screened = _screen(decay, errors(0.0))
    runs.clear()
    fit = _refine(decay, screened)
    best = minimize_scalar(lambda x: 0.5 * errors(x) @ errors(x), bounds=(0.0, 2.0),
                           method="bounded", options={"xatol": 1e-12})
    assert abs(screened.value - best.x) > 0.05        # the screening alone is off
    assert fit.value == pytest.approx(best.x, abs=10 * REFINE_XTOL * abs(best.x))
    assert 0.5 * errors(fit.value) @ errors(fit.value) == pytest.approx(best.fun, rel=1e-8)
    assert len(runs) == 4


def test_a_screened_value_far_out_that_explains_less_than_the_baseline_is_not_a_start():
    # a value screened far out along the baseline's slope lands where the white box fails
    # (errors far worse than healthy): the refinement starts from the baseline instead and
    # finds the minimum near it
    rng = np.random.default_rng(7)
    noise = rng.normal(0.0, 1.0, N)

    def errors(x):
        # a valley at x = 0.5, a cliff past x = 2 (the run there fails: large errors)
        return noise + 30.0 * (x - 0.5) * (1.0 + 1e4 * max(x - 2.0, 0.0) ** 2)

    runs = []
    hypothesis = objective(errors, runs)
    _screen(hypothesis, errors(0.0))                  # the baseline and its finite difference
    screened = hypothesis.record(25.0, errors(0.0), np.full(N, 30.0))   # as if screened there
    runs.clear()
    fit = _refine(hypothesis, screened)
    assert runs[0] == 25.0
    best = minimize_scalar(lambda x: 0.5 * errors(x) @ errors(x), bounds=(-1.0, 2.0),
                           method="bounded", options={"xatol": 1e-12})
    assert fit.value == pytest.approx(best.x, abs=10 * REFINE_XTOL)
