"""Solvers run in lockstep get the values they would compute alone, their evaluations
batched once every unfinished solver waits."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from graybox.lockstep import run_in_lockstep


def test_each_solver_gets_its_own_answer_and_the_evaluations_are_batched():
    targets = [1.0, -3.0, 10.0, 0.5]
    batches = []

    def batch(indices, points):
        batches.append(sorted(indices))
        # residual of problem i: (x - target_i), and (x^3 - target_i^3) / 10 for curvature
        return [np.array([p[0] - targets[i], (p[0] ** 3 - targets[i] ** 3) / 10])
                for i, p in zip(indices, points)]

    def solver(evaluate):
        return least_squares(lambda x: evaluate(x), [2.0]).x[0]

    alone = [least_squares(lambda x, t=t: np.array([x[0] - t, (x[0] ** 3 - t ** 3) / 10]), [2.0]).x[0]
             for t in targets]
    together = run_in_lockstep([solver] * len(targets), batch)
    assert together == alone                           # the very same fits
    np.testing.assert_allclose(together, targets, rtol=1e-6)
    # every batch holds all solvers still running: the first one all four
    assert batches[0] == [0, 1, 2, 3]
    assert len(batches) < sum(len(b) for b in batches)
    counts = [len(b) for b in batches]
    assert counts == sorted(counts, reverse=True)      # finished solvers drop out


def test_an_error_of_the_batch_reaches_every_solver_and_the_caller():
    def batch(indices, points):
        raise ValueError("the model failed")

    with pytest.raises(ValueError, match="the model failed"):
        run_in_lockstep([lambda evaluate: evaluate(1.0)] * 3, batch)


def test_a_solver_that_stops_early_does_not_hold_the_others():
    def batch(indices, points):
        return [p + 1 for p in points]

    def counting(steps):
        def solver(evaluate):
            x = 0
            for _ in range(steps):
                x = evaluate(x)
            return x
        return solver

    assert run_in_lockstep([counting(0), counting(3), counting(1)], batch) == [0, 3, 1]
