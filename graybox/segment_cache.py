"""What one calibration computes once per telemetry segment.

A baseline's calibration fits the same healthy windows several times: the baseline, each
left-out refit (all windows but one) and each left-out window as a candidate. With the
structure frozen by the baseline, a window's hidden states, its residual at the analysis
interval and its level tier's k-step predictions depend only on its data, the white box, the
integrator and the analysis interval, all the same in every one of those fits. So:

* the initial hidden states of all segments of a fit call are fitted side by side first
  (:meth:`SegmentCache.stage_start`, :meth:`SegmentCache.fit_starts`), and each segment's
  estimate starts from its own;
* the hidden-state estimate's chained multiple-shooting starts (a few numbers per 10 minutes
  of data) are kept for every segment, and later fits run the hidden states once from them
  instead of fitting the initial state and chaining the chunks again
  (:func:`graybox.state_estimation.estimate_states`);
* the residual and the k-step predictions of the segments of the first fit (the baseline's
  windows) are kept while :attr:`SegmentCache.storing` is on, and the later fits of the same
  segments read them. Calibration pieces are new data and are computed as before. Stiff,
  hidden-state and ProgPy white boxes spend most of a baseline there (a day's residual of the
  traction drive was computed six times in a five-day calibration).

What is kept is a window's decimated residual and its level data (a few arrays of the
window's length at the analysis interval), for the asset's baseline windows, and only for one
:func:`graybox.calibration.fit_baselines` call.
"""
from __future__ import annotations

import hashlib
from typing import Callable, TypeVar

import numpy as np

from graybox.integration import Integration
from graybox.state_estimation import (WindowStates, estimate_states, initial_hidden_together,
                                      start_fit_samples)

Value = TypeVar("Value")


class SegmentCache:
    """Per-segment results of one calibration, found by the segment's data.

    A white box is told apart by its identity: the cache holds a reference to every model it
    has seen, so an identity is never reused by another model while the cache lives.

    Attributes
    ----------
    storing : bool
        Whether new residuals and level data are kept (hidden-state starts always are).
    """

    def __init__(self, storing: bool = True):
        self.storing = storing
        self._starts: dict[tuple, np.ndarray] = {}
        self._initial: dict[tuple, np.ndarray] = {}
        self._staged: dict[tuple, tuple] = {}
        self._results: dict[tuple, object] = {}
        self._models: dict[int, object] = {}

    def _key(self, kind: str, model, arrays: tuple[np.ndarray, ...], *details,
             digest: str | None = None) -> tuple:
        """The key of ``arrays``' results of ``kind``; ``digest``, the arrays' own where
        known (a :class:`~graybox.state_estimation.WindowStates`'), saves hashing them."""
        self._models[id(model)] = model
        if digest is None:
            # SHA-256 from the array's own buffer: under half blake2b's time on a day's
            # segment with the processor's SHA instructions, and no copy of the data to hash
            hashed = hashlib.sha256()
            for array in arrays:
                hashed.update(np.ascontiguousarray(array))
            digest = hashed.hexdigest()
        return (kind, id(model), *details, tuple(a.shape for a in arrays), digest)

    def estimate(self, model, y: np.ndarray, u: np.ndarray, dt: float,
                 integration: Integration) -> WindowStates:
        """:func:`~graybox.state_estimation.estimate_states`, once per segment's data."""
        if not model.hidden_states:
            return estimate_states(model, y, u, dt, integration)
        key = self._key("states", model, (y, u), float(dt), integration)
        states = estimate_states(model, y, u, dt, integration, self._starts.get(key),
                                 self._initial.pop(key, None))
        self._starts[key] = states.chunk_starts
        # the data's digest with them: :meth:`remember` keys the segment's residual and
        # level data by it (and a decimated window's by it and the factor) without hashing
        states.digest = key[-1]
        return states

    def stage_start(self, model, y: np.ndarray, u: np.ndarray, dt: float,
                    integration: Integration) -> None:
        """Note a segment (outputs, inputs) whose initial hidden state :meth:`fit_starts`
        is to fit, unless it has been estimated already; only its first samples (those the
        fit uses) are kept."""
        if not model.hidden_states or len(y) < 2:
            return
        key = self._key("states", model, (y, u), float(dt), integration)
        if key in self._starts or key in self._initial:
            return
        n = start_fit_samples(dt)
        group = self._staged.setdefault((id(model), float(dt), integration),
                                        (model, float(dt), integration, {}))
        group[3][key] = (y[:n].copy(), u[:n].copy())

    def fit_starts(self) -> None:
        """Fit the staged segments' initial hidden states, each white box's and integrator's
        side by side (:func:`~graybox.state_estimation.initial_hidden_together`); their
        :meth:`estimate` then runs from them without fitting again. A white box whose batched
        fit fails leaves its segments to be fitted (and to fail) one by one."""
        staged, self._staged = self._staged, {}
        for model, dt, integration, segments in staged.values():
            try:
                starts = initial_hidden_together(model, list(segments.values()), dt,
                                                 integration)
            except Exception:  # noqa: BLE001 - each segment's own fit reports it
                continue
            self._initial.update(zip(segments, starts))

    def remember(self, kind: str, model, segment: WindowStates, details: tuple,
                 compute: Callable[[], Value]) -> Value:
        """``compute()`` for ``segment``, or what it gave for the same data and ``details``
        (everything else the result depends on) earlier."""
        key = self._key(kind, model, (segment.y, segment.u), *details, digest=segment.digest)
        if key in self._results:
            return self._results[key]
        value = compute()
        if self.storing:
            self._results[key] = value
        return value
