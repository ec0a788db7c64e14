"""Hidden-state estimates kept for the fits of one calibration.

A baseline's calibration fits the same healthy windows several times: the baseline, each
left-out refit (all windows but one) and each left-out window as a candidate. A window's
estimated hidden states depend only on its data, the model and the integrator, so the first
estimate is kept (its chained multiple-shooting starts, a few numbers per 10 minutes of
data) and later fits run the hidden states once from them instead of fitting the initial
state and chaining the chunks again (:func:`graybox.state_estimation.estimate_states`).
"""
from __future__ import annotations

import hashlib

import numpy as np

from graybox.integration import Integration
from graybox.state_estimation import WindowStates, estimate_states


class StateCache:
    """Chained hidden-state starts of the segments estimated so far, by their data.

    Lives for one :func:`graybox.calibration.fit_baselines` call; a model is told apart by
    its identity there (each request holds its model object).
    """

    def __init__(self):
        self._starts: dict[tuple, np.ndarray] = {}

    def estimate(self, model, y: np.ndarray, u: np.ndarray, dt: float,
                 integration: Integration) -> WindowStates:
        """:func:`~graybox.state_estimation.estimate_states`, once per segment's data."""
        if not model.hidden_states:
            return estimate_states(model, y, u, dt, integration)
        digest = hashlib.blake2b(np.ascontiguousarray(y).tobytes(), digest_size=16)
        digest.update(np.ascontiguousarray(u).tobytes())
        key = (id(model), float(dt), integration, y.shape, u.shape, digest.hexdigest())
        states = estimate_states(model, y, u, dt, integration, self._starts.get(key))
        self._starts[key] = states.chunk_starts
        return states
