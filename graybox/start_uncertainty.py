"""What a hidden start's estimation noise adds to a value fitted on the k-step errors.

A white box with hidden states (a battery's charge and RC voltage) predicts from each
operating period's initial hidden state, fitted on the period's first minutes
(:mod:`graybox.state_estimation`) and then run open loop through it. A value fitted on the
period's k-step errors (a diagnosis hypothesis' parameter, bias or gain) is then a
two-stage estimate: the start's error, one draw per period, moves every error of the period
together. Each error's own share is tiny, so the errors' autocorrelation hardly shows it
(a battery probe: 2,945 effective samples of 2,976), but summed over the period it is not:
on that pack the fitted series resistance scattered 2.7 times as widely as its Gauss-Newton
interval said, and exactly as said with the start held at the truth.

The correction is the two-step estimator's (Murphy and Topel, 1985): with ``J`` the errors'
slope in the value (the start refitted, as a diagnosis runs each trial), ``K_p`` their
slope in period ``p``'s start (the start held), ``C_p`` the start's covariance from its own
least-squares fit and ``W`` the rows' weights, the value's variance is

    1 / (J' W J) + sum_p (J' W K_p) C_p (K_p' W J) / (J' W J)^2,

the first term the one the interval had. The second does not depend on a common scale of
``W``. The overlap of the start's rows with the k-step errors' first rows is left out (a
quarter hour against a period of hours).
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from scipy import linalg

from graybox.integration import Integration
from graybox.parameter_estimation import ErrorSetup, prediction_errors
from graybox.state_estimation import (WindowStates, estimate_states, moved_chunk_starts,
                                      start_fit_problem)

#: a start is moved by this fraction of its scale (at least 1) to read the errors' slope in it
START_STEP = 1e-4


def start_covariance(model, y: np.ndarray, u: np.ndarray, dt: float,
                     integration: Integration, start: np.ndarray,
                     output_spread: Mapping[str, float] | None = None) -> np.ndarray:
    """The covariance (n_hidden, n_hidden) of a period's fitted initial hidden state.

    The start fit's least-squares covariance at ``start``, ``(G'G)^-1 G' S G (G'G)^-1``:
    ``G`` its errors' Jacobian in the start, ``S`` each error's variance. The fit weighs
    series of unlike spread alike (a computed voltage's errors and a measured temperature's
    one-step changes, which the start may not move), so ``S`` is per series: for a computed
    output its ``output_spread`` where given, else (and for the measured states' changes)
    the mean square of its errors here. Why the spread is given: a window the baseline's
    white box does not fit (the alarmed one a diagnosis explains) has errors of the fault's
    size in its first minutes, which a hypothesis at its estimate no longer has; the
    baseline's healthy error spread is what the start's noise is under the hypothesis. A
    start the data do not determine (a singular ``G'G``) is given the pseudo-inverse's
    finite part: its undetermined direction does not move the errors either.
    """
    errors, jacobian, series, scales = start_fit_problem(model, y, u, dt, integration, start)
    n_hidden = jacobian.shape[1]
    if len(errors) <= n_hidden:
        return np.zeros((n_hidden, n_hidden))
    computed = [o for o in model.outputs if o not in model.states]
    spread = np.zeros(len(errors))
    for k in np.unique(series):
        rows = series == k
        given = (output_spread or {}).get(computed[k]) if k < len(computed) else None
        spread[rows] = ((given / scales[k]) ** 2 if given is not None
                        else np.mean(errors[rows] ** 2))
    inverse = linalg.pinvh(jacobian.T @ jacobian)
    middle = jacobian.T @ (spread[:, None] * jacobian)
    return inverse @ middle @ inverse


def start_slopes(model, segments: Sequence[tuple[np.ndarray, np.ndarray]], setup: ErrorSetup,
                 drift: Mapping[str, Sequence[str]], states: Sequence[WindowStates],
                 reference: Mapping[str, tuple]) -> dict[str, np.ndarray]:
    """Per output channel, the k-step errors' slope in each period's initial hidden state:
    (N_channel, n_periods * n_hidden), column ``p * n_hidden + i`` that of period ``p``'s
    hidden state ``i`` (zero on the other periods' rows).

    ``states``: each period's estimate (:func:`graybox.state_estimation.estimate_states`
    at the telemetry rate), whose initial hidden state is moved; ``reference``:
    :func:`graybox.parameter_estimation.prediction_errors` of the same model, segments,
    setup and states (the errors the slopes are read from). One run per hidden state moves
    every period's start at once (a period's errors depend on its own start alone); an
    estimate that kept its chunks' sensitivities is run once from its moved chunk starts
    (:func:`graybox.state_estimation.moved_chunk_starts`), another is chained again.
    """
    starts = [np.array([w.initial_hidden[h] for h in model.hidden_states]) for w in states]
    n_hidden = len(model.hidden_states)
    periods = {c: reference[c][2] for c in reference}
    out = {c: np.zeros((len(reference[c][0]), len(starts) * n_hidden)) for c in reference}
    for i in range(n_hidden):
        steps = [START_STEP * max(1.0, abs(float(s[i]))) for s in starts]
        moves = [step * np.eye(n_hidden)[i] for step in steps]
        if all(w.chunk_sensitivity is not None for w in states):
            moved = [estimate_states(model, y, u, setup.sample_interval, setup.integration,
                                     chunk_starts=moved_chunk_starts(w, move))
                     for (y, u), w, move in zip(segments, states, moves)]
            errors = prediction_errors(model, segments, setup, drift, states=moved)
        else:
            errors = prediction_errors(model, segments, setup, drift,
                                       starts=[s + move for s, move in zip(starts, moves)])
        for c in reference:
            slope = errors[c][0] - reference[c][0]
            for p, step in enumerate(steps):
                rows = periods[c] == p
                out[c][rows, p * n_hidden + i] = slope[rows] / step
    return out
