"""The white-box runs of a diagnosis' hypotheses, evaluated together where that is cheaper.

Every parameter, bias or gain hypothesis of :mod:`graybox.diagnosis` is fitted by runs of a
**trial**: the white box with one parameter changed, or the telemetry with one channel
corrected, over the window's operating periods from the hypothesis' start on
(:func:`graybox.parameter_estimation.prediction_errors`). The hypotheses are fitted side by
side (:func:`graybox.lockstep.run_in_lockstep`: each hypothesis' own screen, or its own
refinement, in its own thread, unchanged), and the runs they ask for at one time are
evaluated here as one batch (:func:`trial_errors`).

For a white box with hidden states most of a run is the fit of each period's initial hidden
state: a quarter hour of samples integrated one after another, a few rows at a time, so a
call's overhead and not its arithmetic is the cost (the EV battery's diagnosis: three
quarters of its time). The batch fits the starts of every trial's copy of one period
together (:func:`graybox.state_estimation.initial_hidden_together`, each trial with its
own parameters per row: :func:`graybox.row_parameters.row_variants`), each start exactly as
it is fitted alone: the same inputs (a trial never changes them) and the same arithmetic per
row. The rest of each run (the hidden states through the period, the k-step errors) is the
trial's own, as alone. A white box that does not compute per-row parameters as its scalar
ones, trials whose start fits begin at different guesses (an initial state read from a
parameter), a period of one trial only, or a batched fit that fails, falls back to runs one
by one. Without hidden states the runs are the trials' own, one by one.

Each trial's result is its errors or the exception its run raised (a
:class:`~graybox.exceptions.GrayBoxError` or ``FloatingPointError``: an invalid trial), so
that one invalid trial does not fail the others of its batch.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence, TypeVar

import numpy as np

from graybox.exceptions import GrayBoxError
from graybox.lockstep import run_in_lockstep
from graybox.models.base import WhiteBoxModel
from graybox.parameter_estimation import ErrorSetup, prediction_errors
from graybox.row_parameters import row_variants
from graybox.state_estimation import initial_hidden_together

Result = TypeVar("Result")


@dataclass(frozen=True)
class Trial:
    """One white-box run a hypothesis asks for.

    Attributes
    ----------
    model : WhiteBoxModel
        The trial's white box (the baseline's, or one parameter changed).
    segments : list of (y, u)
        The operating periods it runs on (the telemetry, or one channel corrected).
    first : int
        The index of ``segments[0]`` among the window's periods (the periods of one index
        have the same inputs in every trial).
    """

    model: WhiteBoxModel
    segments: list
    first: int = 0


def trial_errors(trials: Sequence[Trial], setup: ErrorSetup) -> list:
    """Each trial's :func:`~graybox.parameter_estimation.prediction_errors` (or the exception
    its run raised), the initial hidden states of each period fitted for all trials together
    (see the module docstring)."""
    starts = [[None] * len(trial.segments) for trial in trials]
    if trials and trials[0].model.hidden_states and len(trials) > 1:
        periods: dict[int, list[tuple[int, int]]] = {}
        for i, trial in enumerate(trials):
            for j, (y, _) in enumerate(trial.segments):
                if len(y) >= 2:
                    periods.setdefault(trial.first + j, []).append((i, j))
        for members in periods.values():
            if len(members) < 2:
                continue
            models = [trials[i].model for i, _ in members]
            pieces = [trials[i].segments[j] for i, j in members]
            if len({_start_guess(model) for model in models}) > 1:
                continue          # the start fits begin at different guesses: each its own
            rows = row_variants(models, *_probe_states(models[0], *pieces[0]))
            if rows is None:
                continue
            try:
                fitted = initial_hidden_together(models[0], pieces, setup.sample_interval,
                                                 setup.integration,
                                                 lambda index: rows(np.asarray(index)))
            except (GrayBoxError, FloatingPointError, ValueError, np.linalg.LinAlgError):
                continue          # each trial fits its own, and raises its own
            for (i, j), start in zip(members, fitted):
                starts[i][j] = start
    out = []
    for trial, trial_starts in zip(trials, starts):
        try:
            out.append(prediction_errors(trial.model, trial.segments, setup,
                                         starts=trial_starts))
        except (GrayBoxError, FloatingPointError) as error:
            out.append(error)
    return out


def _start_guess(model: WhiteBoxModel) -> tuple:
    """Where a hidden-state start fit of ``model`` begins (its states, outputs and the
    initial guess of each hidden state): trials batched together must share it."""
    return (tuple(model.states), tuple(model.outputs),
            tuple(float(model.initial_state.get(s, 0.0)) for s in model.hidden_states))


def _probe_states(model: WhiteBoxModel, y: np.ndarray, u: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Full states to probe a model at: the measured ones read, each hidden one near its
    initial guess (a few per cent apart from row to row, so that none sits at 0)."""
    x = np.empty((len(y), len(model.states)))
    for i, state in enumerate(model.states):
        if state in model.outputs:
            x[:, i] = y[:, model.outputs.index(state)]
        else:
            guess = float(model.initial_state.get(state, 0.0))
            x[:, i] = guess + 0.01 * max(1.0, abs(guess)) * (1 + np.arange(len(y)) % 7)
    return x, u


class Runner:
    """Where one hypothesis' runs go: straight to
    :func:`~graybox.parameter_estimation.prediction_errors`, or, while its fit runs side by
    side with others' (:func:`side_by_side`), to their shared batch."""

    def __init__(self, setup: ErrorSetup):
        self.setup = setup
        self.evaluate: Callable[[Trial], object] | None = None

    def run(self, trial: Trial):
        """The trial's errors; raises what its run raised."""
        if self.evaluate is None:
            return prediction_errors(trial.model, trial.segments, self.setup)
        value = self.evaluate(trial)
        if isinstance(value, BaseException):
            raise value
        return value


def side_by_side(tasks: Sequence[tuple[Runner, Callable[[], Result]]], setup: ErrorSetup,
                 together: bool = True) -> list[Result]:
    """Run each ``task()`` (a hypothesis' fit, whose runs go through its ``Runner``) side by
    side, their runs evaluated together (:func:`trial_errors`); each task sees exactly the
    values it would see alone. Raises the first task's error (by index), after every task
    has stopped. ``together`` False (nothing to share: a white box without hidden states):
    one after another."""
    def solver(runner: Runner, task: Callable[[], Result]):
        def solve(evaluate):
            runner.evaluate = evaluate
            try:
                return task()
            finally:
                runner.evaluate = None
        return solve

    if len(tasks) < 2 or not together:
        return [task() for _, task in tasks]
    return run_in_lockstep([solver(runner, task) for runner, task in tasks],
                           lambda indices, trials: trial_errors(trials, setup))
