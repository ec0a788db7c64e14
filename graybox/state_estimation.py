"""The white box's full state over a window: measured states read, hidden states estimated.

A model whose states are all outputs (every state measured) needs nothing here: its state at
every sample is the telemetry. A model with hidden states (a battery's state of charge and RC
voltages) is run through the window as an open-loop predictor of them:

1. **The window's initial hidden state** is fitted by least squares
   (``scipy.optimize.least_squares``) over the window's first :data:`INITIAL_FIT_SECONDS`
   (at least :data:`INITIAL_FIT_MIN_SAMPLES` samples, at most :data:`INITIAL_FIT_MAX_SAMPLES`:
   a logger faster than 1 Hz fits its start to fewer seconds): the hidden start that makes the model
   reproduce the computed outputs (and the measured states' one-step changes) best, each
   scaled by its spread. The model's ``initial_state`` gives the search's start. The
   segments of one fit call (a calibration's pieces, a night's candidates of every asset)
   are fitted side by side (:func:`initial_hidden_together`): each by its own fit, their
   function evaluations batched into one run of every segment. Each evaluation's runs are
   time-parallel (:func:`_run_chained`): chunks chained as step 2 chains them, guessed from
   the segment's previous evaluation.
2. **From it the hidden states run through the window** by the model's own dynamics, the
   measured states reset to the telemetry at every sample (so only the hidden part is
   open-loop). Sequential in time, this is computed by multiple shooting: the window is cut
   into chunks of :data:`CHUNK_SAMPLES` that are integrated side by side from guessed starts,
   each with the sensitivity of its end to its start (forward differences), and the chunks'
   starts are chained by one Newton step per pass (exact after one pass when the hidden
   dynamics are affine in the hidden states, as an equivalent circuit's are), until every
   chunk starts where the previous one ends.

The estimate is the white box's own (no measurement update after the start): a hidden state's
error grows with its model's error over the window, and the one-step residual, which takes
differences of the outputs (:mod:`graybox.residual`), is insensitive to it to first order.
The fitted initial hidden state is recorded with the signature.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from graybox.exceptions import InsufficientDataError
from graybox.integration import (STIFF_HINT, Integration, IntegrationError, advance,
                                 check_finite_prediction)
from graybox.lockstep import run_in_lockstep

INITIAL_FIT_SECONDS = 900.0
INITIAL_FIT_MIN_SAMPLES = 20
#: the start fit's samples at most (a 1-Hz logger's 900 s): each of its evaluations ran
#: them one after another (before its runs were time-parallel), so a 10-Hz servo's 9,000 at
#: 32 RK4 sub-steps cost 150 s of CPU a segment. A faster logger so fits its start to fewer
#: seconds: as many samples of the outputs that read the start (the servo's 14-Hz velocity
#: is read within a second), less of a slow hidden mode's drift (no zoo plant logged faster
#: than 1 Hz has one)
INITIAL_FIT_MAX_SAMPLES = 900
#: samples per multiple-shooting chunk: a chunk's steps run one after another, the chunks
#: side by side, and each step costs about the same whatever the number of chunks (a
#: small white box's call is mostly overhead), so short chunks are fast: 20 instead of
#: 600 fits a battery baseline day 2.8 times faster with the same drifts to 6 digits
CHUNK_SAMPLES = 20
MAX_PASSES = 6
#: a long window's first multiple-shooting pass moves every this many chunks' starts only
#: (:func:`_run_hidden`), at least :data:`SENSITIVITY_SAMPLES` of them, and gives every
#: chunk their common sensitivity where they have one
SENSITIVITY_STRIDE = 8
SENSITIVITY_SAMPLES = 8
#: sampled chunk sensitivities agreeing to this (in the states' scales) are one: forward
#: differences of 1e-4 of the scale agree to about 1e-11 where the dynamics are the same
COMMON_SENSITIVITY_TOLERANCE = 1e-8
#: the start fit's time-parallel runs (:func:`_run_chained`) chain their chunks to this
#: fraction of each hidden state's scale: far below the fit's forward-difference step (1e-6
#: of the scale), whose errors move together with the point's (the same guesses, moved)
START_CHAIN_TOLERANCE = 1e-10
#: chained chunk starts agree with their predecessors' ends to this fraction of the hidden
#: state's scale
CHAIN_TOLERANCE = 1e-6
#: segments whose initial hidden states are fitted side by side
#: (:func:`initial_hidden_together`)
SEGMENTS_TOGETHER = 16
#: a prediction further than this many times the channel's range from the data diverges
DIVERGENCE_RANGES = 100.0


@dataclass
class WindowStates:
    """One segment's telemetry and the model's full state over it.

    Attributes
    ----------
    y : ndarray (T, n_outputs)
        Measured outputs, in the model's ``outputs`` order.
    u : ndarray (T, n_inputs)
    states : ndarray (T, n_states)
        Measured states as read; hidden states estimated.
    initial_hidden : dict of str to float
        The fitted hidden state at the first sample (empty without hidden states).
    chunk_starts : ndarray (n_chunks, n_hidden), optional
        The chained hidden states at the multiple-shooting chunks' first samples: the run
        again from them is the same estimate (:class:`graybox.segment_cache.SegmentCache`).
    chunk_sensitivity : ndarray (n_chunks, n_hidden, n_hidden), optional
        Each chunk's end state's derivative in its start (the chaining's last): a move of
        the initial hidden state carried to every chunk's start by their product
        (:func:`moved_chunk_starts`). Only where the chaining ran here.
    digest : str, optional
        A digest of ``y`` and ``u`` (the segment cache's, :class:`graybox.segment_cache.
        SegmentCache`, which finds the segment's later results by it without hashing its
        data again); a decimated window's names the full one's and the factor.
    """

    y: np.ndarray
    u: np.ndarray
    states: np.ndarray
    initial_hidden: dict
    chunk_starts: np.ndarray | None = None
    chunk_sensitivity: np.ndarray | None = None
    digest: str | None = None

    def decimated(self, factor: int) -> "WindowStates":
        """Every ``factor``-th sample."""
        return WindowStates(self.y[::factor], self.u[::factor], self.states[::factor],
                            self.initial_hidden, self.chunk_starts, self.chunk_sensitivity,
                            None if self.digest is None else f"{self.digest}/{factor}")


def window_arrays(model, frame: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Outputs (T, n_outputs) and inputs (T, n_inputs) of a telemetry frame.

    Raises
    ------
    TelemetryError
        Naming every column of the model the frame lacks.
    """
    model.check_columns(frame.columns)
    y = frame.loc[:, list(model.output_columns)].to_numpy(dtype=float)
    u = frame.loc[:, list(model.input_columns)].to_numpy(dtype=float).reshape(len(frame), -1)
    return y, u


def estimate_states(model, y: np.ndarray, u: np.ndarray, dt: float,
                    integration: Integration, chunk_starts: np.ndarray | None = None,
                    start: np.ndarray | None = None) -> WindowStates:
    """The full state over one segment (see the module docstring).

    ``chunk_starts``, an earlier estimate's of the same data, model and integration, skips
    the fit and the chaining: the hidden states are run once from them. ``start``, the
    initial hidden state already fitted (:func:`initial_hidden_together`), skips the fit.

    Raises
    ------
    InsufficientDataError
        If the segment has fewer than 2 samples.
    IntegrationError
        If the hidden states' run diverges.
    """
    layout = _Layout(model)
    states = np.zeros((len(y), len(model.states)))
    # column by column: ``y`` is often column-major (a frame's block), and one fancy-indexed
    # copy of it took 2 ms a day at 1 Hz against 0.1 ms, in every white-box run a diagnosis
    # makes (the same values either way)
    for state, output in zip(layout.measured, layout.measured_outputs):
        states[:, state] = y[:, output]
    if not layout.hidden.size:
        return WindowStates(y, u, states, {})
    if len(y) < 2:
        raise InsufficientDataError("estimating hidden states needs at least 2 samples")
    sensitivity = None
    if chunk_starts is None:
        if start is None:
            start = _initial_hidden(model, layout, y, u, dt, integration)
        hidden, chunk_starts, sensitivity = _run_hidden(model, layout, y, u, dt, integration,
                                                        start)
    else:
        start = chunk_starts[0]
        hidden = _run_chunks(model, layout, y, u, dt, integration, chunk_starts)
    states[:, layout.hidden] = hidden
    if not np.all(np.isfinite(hidden)):
        raise IntegrationError(f"{type(model).__name__}: the hidden states "
                               f"{list(model.hidden_states)} are not finite over the window: "
                               f"the model diverges from the start fitted to the data")
    return WindowStates(y, u, states, dict(zip(model.hidden_states, map(float, start))),
                        chunk_starts, sensitivity)


def moved_chunk_starts(window: WindowStates, move: np.ndarray) -> np.ndarray:
    """The chunk starts of ``window``'s hidden run with its initial hidden state moved by
    ``move`` (small), to first order: the move carried from chunk to chunk by each chunk's
    sensitivity (the chaining of :func:`estimate_states` at its converged starts, whose
    ends are the next chunks' starts). Run from them (``estimate_states(...,
    chunk_starts=...)``), a chunk pass instead of a chaining's several."""
    moves = np.empty_like(window.chunk_starts)
    moves[0] = move
    for c in range(1, len(moves)):
        moves[c] = window.chunk_sensitivity[c - 1] @ moves[c - 1]
    return window.chunk_starts + moves


def predict_one_step(model, states: np.ndarray, u: np.ndarray, dt: float,
                     integration: Integration) -> np.ndarray:
    """Every sample's full state predicted from the estimated state one sample earlier:
    (T - 1, n_states). A prediction that is not finite from a finite start is an
    :class:`IntegrationError` (:func:`graybox.integration.check_finite_prediction`)."""
    predicted = advance(model.derivatives, states[:-1], u[:-1], u[1:], dt, integration)
    check_finite_prediction(model, states[:-1], u[:-1], u[1:], predicted)
    return predicted


def check_prediction(model, measured: np.ndarray, predicted: np.ndarray, what: str) -> None:
    """Raise :class:`IntegrationError` if a predicted output of a finite measurement is not
    finite, or lies more than :data:`DIVERGENCE_RANGES` times its channel's scale (its range
    in the window, at least its magnitude) from the data.

    A channel that reads exactly 0 throughout has no scale, and only an infinite prediction
    of it diverges. The magnitude floor keeps a wrong constant from reading as divergence: a channel without
    dynamics whose level parameter is off by 7x on a quiet window (SKAB's vibration at another
    operating point, range 0.002 g, level 0.03 g, parameter 0.2 g) is a bias to tune, not a
    blow-up; a blow-up passes 100 times the magnitude within a few steps.

    A gap in the telemetry (a missing sample or input) leaves its prediction missing, which is
    not divergence; a prediction that is missing where its data is not, is.
    """
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        span = np.nanmax(measured, axis=0) - np.nanmin(measured, axis=0)
        scale = np.maximum(span, np.nanmax(np.abs(measured), axis=0))
        distance = np.abs(predicted - measured) / scale
        # a channel at exactly 0 throughout (a stopped pump's flow in a short operating
        # period) gives no scale: there only an infinite prediction diverges
        overflow = np.isinf(predicted) | ((scale > 0) & (distance > DIVERGENCE_RANGES))
    bad = np.isfinite(measured) & overflow
    if bad.any():
        channel = model.outputs[int(np.argmax(bad.sum(axis=0)))]
        raise IntegrationError(
            f"{type(model).__name__}: the {what} of channel {channel!r} diverges "
            f"({int(bad.sum())} predictions are infinite or lie more than "
            f"{DIVERGENCE_RANGES:g} times the channel's range from the data). Check the "
            f"model's signs and units; {STIFF_HINT}")


class _Layout:
    """Where the measured and hidden states sit in the state vector."""

    def __init__(self, model):
        self.measured = np.array([i for i, s in enumerate(model.states) if s in model.outputs],
                                 dtype=int)
        self.measured_outputs = np.array([model.outputs.index(model.states[i])
                                          for i in self.measured], dtype=int)
        self.hidden = np.array([i for i, s in enumerate(model.states) if s not in model.outputs],
                               dtype=int)
        self.computed_outputs = np.array([j for j, o in enumerate(model.outputs)
                                          if o not in model.states], dtype=int)
        self.guess = np.array([float(model.initial_state.get(model.states[i], 0.0))
                               for i in self.hidden])
        self.n_states = len(model.states)


def _run(model, layout: _Layout, y, u, dt, integration, starts: np.ndarray,
         first: np.ndarray, length: int, last: np.ndarray | int | None = None) -> np.ndarray:
    """Hidden states of runs ``b`` from sample ``first[b]`` for ``length`` steps, the measured
    states reset to the telemetry at each sample: (B, length + 1, n_hidden). Runs past their
    ``last`` sample (default: the window's end) repeat it."""
    last = len(y) - 1 if last is None else last
    out = np.empty((len(starts), length + 1, len(layout.hidden)))
    out[:, 0] = starts
    full = np.zeros((len(starts), layout.n_states))
    # the measured states' columns once (not every step's rows of every output)
    measured = y[:, layout.measured_outputs]
    measured_at, hidden_at = _columns(layout.measured), _columns(layout.hidden)
    hidden = starts
    for j in range(length):
        now = np.minimum(first + j, last)
        after = np.minimum(first + j + 1, last)
        full[:, measured_at] = measured[now]
        full[:, hidden_at] = hidden
        step = advance(model.derivatives, full, u[now], u[after], dt, integration)
        moving = first + j < last
        # the same values as ``np.where`` gives; most steps of most runs move every row
        hidden = (step[:, hidden_at] if np.all(moving) else
                  np.where(moving[:, None], step[:, hidden_at], hidden))
        out[:, j + 1] = hidden
    return out


def _columns(index: np.ndarray) -> np.ndarray | slice:
    """``index`` as a slice where it is a contiguous run (a view, not a gathered copy)."""
    if len(index) and np.array_equal(index, np.arange(index[0], index[0] + len(index))):
        return slice(int(index[0]), int(index[0]) + len(index))
    return index


def _moved(starts: np.ndarray, moves: np.ndarray, sensitivity: np.ndarray) -> np.ndarray:
    """Chunk starts (R, n_chunks, n_hidden): ``starts`` (n_chunks, n_hidden), chained, with
    the first moved by ``moves[r]`` and each next by its predecessor's move carried by the
    predecessor's ``sensitivity`` (n_chunks, n_hidden, n_hidden)."""
    carried = np.empty((len(moves),) + starts.shape)
    carried[:, 0] = moves
    for c in range(1, len(starts)):
        carried[:, c] = (sensitivity[c - 1] * carried[:, c - 1, None, :]).sum(axis=-1)
    return starts + carried


def _chain_rows(starts: np.ndarray, guesses: np.ndarray, ends: np.ndarray,
                sensitivity: np.ndarray) -> np.ndarray:
    """:func:`_chain` of every row: ``starts`` (R, n_hidden), ``guesses`` and ``ends``
    (R, n_chunks, n_hidden), ``sensitivity`` (R, n_chunks, n_hidden, n_hidden). Row by row
    (no row's arithmetic depends on another's)."""
    chained = guesses.copy()
    chained[:, 0] = starts
    for c in range(1, guesses.shape[1]):
        move = chained[:, c - 1] - guesses[:, c - 1]
        chained[:, c] = ends[:, c - 1] + (sensitivity[:, c - 1] * move[:, None, :]).sum(axis=-1)
    return chained


def _run_chained(model_of: Callable[[np.ndarray], object], layout: _Layout, y, u, dt,
                 integration, starts: np.ndarray, first: np.ndarray, steps: int,
                 last: np.ndarray, owner: np.ndarray, guesses: np.ndarray,
                 sensitivity: np.ndarray, known: np.ndarray, scale: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_run`'s hidden states of runs ``r`` from ``starts[r]`` at sample ``first[r]``
    for ``steps`` steps (held past ``last[r]``), time-parallel: (R, steps + 1, n_hidden).

    Each run is cut into chunks of :data:`CHUNK_SAMPLES` steps, run side by side from
    ``guesses[r]`` (R, n_chunks, n_hidden; the first chunk's is the start), and chained as
    :func:`_run_hidden` chains a window's chunks, pass after pass, until every chunk starts
    where its predecessor ends within :data:`START_CHAIN_TOLERANCE` of the state's scale
    (``scale``, or the state's magnitude where larger). Run ``r`` chains with the chunk
    sensitivities of run ``owner[r]`` (an evaluation's forward differences with its
    point's): ``sensitivity[o]`` (n_chunks, n_hidden, n_hidden) where ``known[o]``, else
    computed by a pass that also runs the owner's chunks from starts moved by 1e-4 of the
    scale along each hidden state. A pass with known sensitivities runs the chunks alone;
    when it does not chain, the next pass computes them anew (as :func:`_run_hidden`'s
    lazy passes). An owner's runs end together, when all of them chain. Runs that diverge
    (a chunk's end not finite) or do not chain within ``2 * MAX_PASSES`` passes are run
    sequentially instead (:func:`_run`), as is every run before this one was time-parallel.

    Returns
    -------
    hidden : ndarray (R, steps + 1, n_hidden)
    chained : ndarray (R, n_chunks, n_hidden)
        The chunks' starts of the runs returned.
    sensitivity : ndarray (R, n_chunks, n_hidden, n_hidden)
        The owners' chunk sensitivities the runs chained with.
    chained_ok : ndarray (R,) of bool
        Whether the run was chained (not run sequentially).
    """
    count, chunks, n_hidden = guesses.shape
    length = CHUNK_SAMPLES
    chunk_first = first[:, None] + length * np.arange(chunks)
    guesses, sensitivity, known = guesses.copy(), sensitivity.copy(), known.copy()
    hidden = np.empty((count, steps + 1, n_hidden))
    active = np.ones(count, dtype=bool)
    chained_ok = np.zeros(count, dtype=bool)
    delta = 1e-4 * scale
    for _ in range(2 * MAX_PASSES):
        rows = np.flatnonzero(active)
        if not rows.size:
            break
        fresh = rows[(owner[rows] == rows) & ~known[rows]]
        batch = np.concatenate([guesses[rows]] + [guesses[fresh] + delta[i] * np.eye(n_hidden)[i]
                                                  for i in range(n_hidden)])
        which = np.concatenate([rows] + [fresh] * n_hidden)
        runs = _run(model_of(np.repeat(which, chunks)), layout, y, u, dt, integration,
                    batch.reshape(-1, n_hidden),
                    np.concatenate([chunk_first[rows]] + [chunk_first[fresh]] * n_hidden
                                   ).ravel(),
                    length, np.repeat(last[which], chunks))
        runs = runs.reshape(len(which), chunks, length + 1, n_hidden)
        ends = runs[:len(rows), :, -1]
        if fresh.size:
            at = np.searchsorted(rows, fresh)
            moved_ends = runs[len(rows):, :, -1].reshape(n_hidden, len(fresh), chunks, n_hidden)
            sensitivity[fresh] = np.stack([(moved_ends[i] - ends[at]) / delta[i]
                                           for i in range(n_hidden)], axis=-1)
            known[fresh] = True
        chained = _chain_rows(starts[rows], guesses[rows], ends, sensitivity[owner[rows]])
        with np.errstate(invalid="ignore"):
            off = (np.abs(chained - guesses[rows])
                   / np.maximum(scale, np.abs(guesses[rows]))).max(axis=(1, 2))
        off = np.where(np.isnan(off), np.inf, off)
        worst = np.zeros(count)
        np.maximum.at(worst, owner[rows], off)
        done = worst[owner[rows]] <= START_CHAIN_TOLERANCE
        diverged = ~np.isfinite(worst[owner[rows]])
        ended = rows[done]
        hidden[ended] = np.concatenate(
            [runs[:len(rows)][done, :, :-1].reshape(len(ended), chunks * length, n_hidden),
             runs[:len(rows)][done, -1:, -1]], axis=1)[:, :steps + 1]
        chained_ok[ended] = True
        active[rows[done | diverged]] = False
        going = ~(done | diverged)
        guesses[rows[going]] = chained[going]
        # a pass with the owners' earlier sensitivities that did not chain: the next
        # computes them anew; a pass that computed them: the next tries them alone
        stale = rows[going & (owner[rows] == rows)]
        known[stale] = np.isin(stale, fresh)
    sequential = np.flatnonzero(~chained_ok)
    if sequential.size:
        hidden[sequential] = _run(model_of(sequential), layout, y, u, dt, integration,
                                  starts[sequential], first[sequential], steps, last[sequential])
    return hidden, guesses, sensitivity, chained_ok


def start_fit_samples(dt: float) -> int:
    """Samples at a segment's start that its initial hidden state is fitted to (at most)."""
    return max(INITIAL_FIT_MIN_SAMPLES,
               min(INITIAL_FIT_MAX_SAMPLES, int(np.ceil(INITIAL_FIT_SECONDS / dt))))


class _StartFit:
    """The least-squares problem of the initial hidden states of several segments at once.

    Segment ``b``'s errors are those of its first :data:`INITIAL_FIT_SECONDS` (its computed
    outputs and its measured states' one-step changes, each scaled by the segment's own
    spread); a batch of trial starts, each for one segment, is run side by side, the shorter
    segments' rows padded with zero errors.
    """

    def __init__(self, model, layout: _Layout, pieces: Sequence[tuple[np.ndarray, np.ndarray]],
                 dt: float, integration: Integration,
                 variants: Callable[[np.ndarray], object] | None = None,
                 time_parallel: bool = True):
        self.model, self.layout, self.dt, self.integration = model, layout, dt, integration
        # the runs of an evaluation chunked and chained (:func:`_run_chained`), or sequential
        self.time_parallel = time_parallel
        # per segment: the trial start evaluated last, its chunks' chained starts and their
        # sensitivities, from which the next evaluation's chunks are guessed
        self.memory: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self.scale = np.maximum(1.0, np.abs(layout.guess))
        # each segment's own variant of the model: ``variants(segments)`` is the model of
        # rows whose segments are those (:func:`graybox.row_parameters.row_variants`)
        self.variants = variants
        self.n = np.array([min(len(y), start_fit_samples(dt)) for y, _ in pieces])
        self.offset = np.concatenate([[0], np.cumsum(self.n)[:-1]])
        self.y = np.concatenate([y[:n] for (y, _), n in zip(pieces, self.n)])
        self.u = np.concatenate([u[:n] for (_, u), n in zip(pieces, self.n)])
        out_scales, step_scales = [], []
        for (y, _), n in zip(pieces, self.n):
            computed = y[:n, layout.computed_outputs]
            out_scales.append(np.maximum(np.std(computed, axis=0), 1e-6 * np.maximum(
                1, np.abs(computed).max(axis=0, initial=0))))
            change = np.diff(y[:n, layout.measured_outputs], axis=0)
            step_scales.append(np.maximum(np.std(change, axis=0), 1e-9) if len(change)
                               else np.ones(len(layout.measured_outputs)))
        self.out_scale, self.step_scale = np.array(out_scales), np.array(step_scales)

    def _model(self, piece: np.ndarray):
        """The model of rows of segments ``piece``."""
        return self.model if self.variants is None else self.variants(piece)

    def own_rows(self, piece: int) -> np.ndarray:
        """Where segment ``piece``'s own errors sit in a row of :meth:`errors` (the rest is
        padding), in the order it has alone."""
        length, n = int(self.n.max()), int(self.n[piece])
        computed, measured = len(self.layout.computed_outputs), len(self.layout.measured)
        rows = [np.arange(n * computed)]
        if measured and length > 1:
            rows.append(length * computed + np.arange((n - 1) * measured))
        return np.concatenate(rows)

    def hidden_runs(self, batch: np.ndarray, piece: np.ndarray, count: int) -> np.ndarray:
        """The hidden states (R, length, n_hidden) of the trial starts ``batch[r]`` of
        segments ``piece[r]``, each run over its segment's fitted samples (then held). Rows
        ``r``, ``r + count``, ``r + 2 count``... are one segment's: an evaluation's point and
        its forward differences.

        Time-parallel (:func:`_run_chained`) unless made sequential or the segments are no
        longer than a chunk: each segment's chunks are guessed from its previous
        evaluation's chained ones, moved by their sensitivities (exact for hidden dynamics
        affine in the hidden states, when one pass of the chunks alone confirms them).
        """
        layout, steps = self.layout, int(self.n.max()) - 1
        first, last = self.offset[piece], self.offset[piece] + self.n[piece] - 1
        if not self.time_parallel or steps <= CHUNK_SAMPLES:
            return _run(self._model(piece), layout, self.y, self.u, self.dt, self.integration,
                        batch, first, steps, last)
        chunks = -(-steps // CHUNK_SAMPLES)
        n_hidden = len(layout.hidden)
        owner = np.tile(np.arange(count), len(batch) // count)
        guesses = np.repeat(batch[:, None], chunks, axis=1)
        sensitivity = np.zeros((len(batch), chunks, n_hidden, n_hidden))
        known = np.zeros(len(batch), dtype=bool)
        for k in range(count):
            memory = self.memory.get(int(piece[k]))
            if memory is not None:
                point, starts, moving = memory
                rows = owner == k
                guesses[rows] = _moved(starts, batch[rows] - point, moving)
                sensitivity[k], known[k] = moving, True
        guesses[:, 0] = batch
        hidden, chained, sensitivity, ok = _run_chained(
            lambda rows: self._model(piece[rows]), layout, self.y, self.u, self.dt,
            self.integration, batch, first, steps, last, owner, guesses, sensitivity, known,
            self.scale)
        for k in range(count):
            if ok[k]:
                self.memory[int(piece[k])] = (batch[k].copy(), chained[k], sensitivity[k])
            else:
                self.memory.pop(int(piece[k]), None)
        return hidden

    def errors(self, batch: np.ndarray, piece: np.ndarray,
               hidden: np.ndarray | None = None) -> np.ndarray:
        """Scaled errors (R, n_errors) of the trial starts ``batch[r]`` of segments
        ``piece[r]``, from their hidden runs ``hidden`` (default: run here, sequentially)."""
        layout, length = self.layout, int(self.n.max())
        first, last = self.offset[piece], self.offset[piece] + self.n[piece] - 1
        if hidden is None:
            hidden = _run(self._model(piece), layout, self.y, self.u, self.dt,
                          self.integration, batch, first, length - 1, last)
        at = np.minimum(first[:, None] + np.arange(length), last[:, None])     # (R, length)
        valid = np.arange(length)[None] < self.n[piece][:, None]
        full = np.zeros(hidden.shape[:2] + (layout.n_states,))
        full[..., layout.measured] = self.y[at][..., layout.measured_outputs]
        full[..., layout.hidden] = hidden
        u = self.u[at]
        parts = []
        if layout.computed_outputs.size:
            predicted = self._model(np.repeat(piece, length)).output(
                full.reshape(-1, layout.n_states), u.reshape(-1, u.shape[-1]))
            predicted = predicted.reshape(len(batch), length, -1)[..., layout.computed_outputs]
            error = ((self.y[at][..., layout.computed_outputs] - predicted)
                     / self.out_scale[piece][:, None])
            parts.append(np.where(valid[..., None], error, 0.0).reshape(len(batch), -1))
        if layout.measured.size and length > 1:
            onestep = advance(self._model(np.repeat(piece, length - 1)).derivatives,
                              full[:, :-1].reshape(-1, layout.n_states),
                              u[:, :-1].reshape(-1, u.shape[-1]),
                              u[:, 1:].reshape(-1, u.shape[-1]), self.dt, self.integration)
            onestep = onestep.reshape(len(batch), length - 1, -1)[..., layout.measured]
            error = ((self.y[at[:, 1:]][..., layout.measured_outputs] - onestep)
                     / self.step_scale[piece][:, None])
            parts.append(np.where(valid[:, 1:, None], error, 0.0).reshape(len(batch), -1))
        return np.concatenate(parts, axis=1)

    def errors_and_jacobians(self, z: np.ndarray, delta: np.ndarray,
                             pieces: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The errors of segments ``pieces[b]`` (default all) at starts ``z[b]``
        (B, n_errors) and their forward-difference Jacobians (B, n_errors, n_hidden), in one
        batched run."""
        count, n_hidden = z.shape
        pieces = np.arange(count) if pieces is None else np.asarray(pieces)
        batch = np.concatenate([z] + [z + delta[i] * np.eye(n_hidden)[i]
                                      for i in range(n_hidden)])
        # a trial start whose run diverges overflows: its errors count as large, and a
        # start fit that ends there fails the prediction's own check (check_prediction)
        with np.errstate(all="ignore"):
            rows = np.tile(pieces, n_hidden + 1)
            e = self.errors(batch, rows, self.hidden_runs(batch, rows, count))
            e = np.where(np.isfinite(e), e, 1e6)
            base = e[:count]
            jacobian = np.stack([(e[(i + 1) * count:(i + 2) * count] - base) / delta[i]
                                 for i in range(n_hidden)], axis=-1)
        return base, jacobian


def start_fit_problem(model, y: np.ndarray, u: np.ndarray, dt: float,
                      integration: Integration, start: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The least-squares problem of a segment's initial hidden state, as
    :func:`estimate_states` solves it, at ``start``.

    Returns
    -------
    errors : ndarray (m,)
        The fit's scaled errors.
    jacobian : ndarray (m, n_hidden)
        Their forward differences in the start (the solver's own step).
    series : ndarray (m,) of int
        Each error's series: ``i < n_c`` the computed output ``computed[i]``, ``n_c + j``
        the measured state ``j``'s one-step change.
    scales : ndarray (n_c + n_measured,)
        The spread each series' errors are divided by.
    """
    layout = _Layout(model)
    problem = _StartFit(model, layout, [(y, u)], dt, integration)
    scale = np.maximum(1.0, np.abs(layout.guess))
    errors, jacobian = problem.errors_and_jacobians(np.asarray(start, dtype=float)[None],
                                                    1e-6 * scale)
    n, computed = int(problem.n[0]), len(layout.computed_outputs)
    series = [np.tile(np.arange(computed), n)]
    if layout.measured.size and n > 1:
        series.append(computed + np.tile(np.arange(len(layout.measured)), n - 1))
    own = problem.own_rows(0)
    scales = np.concatenate([problem.out_scale[0], problem.step_scale[0]])
    return errors[0, own], jacobian[0, own], np.concatenate(series), scales


def _initial_hidden(model, layout: _Layout, y, u, dt, integration) -> np.ndarray:
    problem = _StartFit(model, layout, [(y, u)], dt, integration)
    scale = np.maximum(1.0, np.abs(layout.guess))
    cache = {}

    def evaluate(z):
        key = z.tobytes()
        if key not in cache:
            e, jacobian = problem.errors_and_jacobians(z[None], 1e-6 * scale)
            cache.clear()
            cache[key] = (e[0], jacobian[0])
        return cache[key]

    with np.errstate(all="ignore"):     # the solver's steps from a diverging run's errors
        fit = least_squares(lambda z: evaluate(z)[0], layout.guess,
                            jac=lambda z: evaluate(z)[1], x_scale=scale, max_nfev=50)
    return fit.x


def initial_hidden_together(model, pieces: Sequence[tuple[np.ndarray, np.ndarray]], dt: float,
                            integration: Integration,
                            variants: Callable[[np.ndarray], object] | None = None
                            ) -> np.ndarray:
    """The initial hidden states of several segments (outputs ``y`` and inputs ``u`` each, as
    :func:`estimate_states` takes them), :data:`SEGMENTS_TOGETHER` at a time: (B, n_hidden).

    Each segment's start is fitted by its own ``least_squares``, exactly as
    :func:`estimate_states` fits it alone, but the fits run in lockstep
    (:func:`graybox.lockstep.run_in_lockstep`): their function evaluations (each a run of
    the start and its forward differences) are batched into one run of every segment side by
    side. One problem over the stacked starts (a block-diagonal Jacobian) was tried first:
    its trust region is shared, and a start the data do not determine (a state of charge
    above the OCV table's last breakpoint) wandered to another, equally good, minimum.
    Each segment has at least 2 samples.

    ``variants``: each segment fitted with its own variant of ``model`` (differing in number
    parameters only: a diagnosis' trial models), ``variants(index)`` the model whose rows
    are those of segments ``index`` (:func:`graybox.row_parameters.row_variants`, indexed
    by segment). A Rosenbrock integrator's inputs' difference step is the batch's largest
    input: segments of different inputs fitted together are not each fitted as alone (the
    same inputs, a segment's variants, are).
    """
    layout = _Layout(model)
    n_hidden = len(layout.hidden)
    scale = np.maximum(1.0, np.abs(layout.guess))
    starts = []
    for group in range(0, len(pieces), SEGMENTS_TOGETHER):
        local = (None if variants is None else
                 lambda index, group=group: variants(np.asarray(index) + group))
        problem = _StartFit(model, layout, pieces[group:group + SEGMENTS_TOGETHER], dt,
                            integration, local)
        own = [problem.own_rows(b) for b in range(len(problem.n))]

        def batch(indices, points, problem=problem, own=own):
            e, jacobian = problem.errors_and_jacobians(np.array(points), 1e-6 * scale,
                                                       np.array(indices))
            return [(e[k, own[b]], jacobian[k, own[b]]) for k, b in enumerate(indices)]

        def solver(evaluate_at):
            cache = {}

            def evaluate(z):
                key = z.tobytes()
                if key not in cache:
                    value = evaluate_at(z.copy())
                    cache.clear()
                    cache[key] = value
                return cache[key]

            # numpy's error state is per thread: set here, in the solver's own
            with np.errstate(all="ignore"):
                return least_squares(lambda z: evaluate(z)[0], layout.guess,
                                     jac=lambda z: evaluate(z)[1], x_scale=scale,
                                     max_nfev=50).x

        starts.extend(run_in_lockstep([solver] * len(problem.n), batch))
    return np.array(starts).reshape(len(pieces), n_hidden)


def _chunks(total: int) -> tuple[np.ndarray, int]:
    """The multiple-shooting chunks' first samples and their length."""
    length = min(CHUNK_SAMPLES, total - 1)
    return np.arange(0, total - 1, length), length


def _joined(runs: np.ndarray, firsts: np.ndarray, length: int, total: int) -> np.ndarray:
    """The chunks' runs (n_chunks, length + 1, n_hidden) as one (total, n_hidden): each
    sample from the chunk that starts at or before it (``firsts`` those of :func:`_chunks`,
    every ``length``-th sample), the last from the last chunk's end."""
    flat = np.concatenate([runs[:, :length].reshape(-1, runs.shape[-1]), runs[-1:, length]])
    return flat[:total]


def _run_chunks(model, layout: _Layout, y, u, dt, integration,
                chunk_starts: np.ndarray) -> np.ndarray:
    """The hidden states at every sample, each chunk run from its given start."""
    firsts, length = _chunks(len(y))
    runs = _run(model, layout, y, u, dt, integration, chunk_starts, firsts, length)
    return _joined(runs, firsts, length, len(y))


def _run_hidden(model, layout: _Layout, y, u, dt, integration, start: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The hidden states at every sample, started from ``start`` (multiple shooting), the
    chunks' chained starts and their ends' sensitivities to them (the last computed).

    A pass runs every chunk from its guessed start and, beside it, from the start moved by
    ``delta`` along each hidden state (the sensitivity of its end); the chained starts are the
    next pass's guesses. A pass after the first runs the chunks from their guesses alone
    first and chains them with the previous pass's sensitivities: when that already agrees
    within :data:`CHAIN_TOLERANCE` the pass ends there, its runs those a full pass would
    have given (the runs do not depend on the perturbed ones); otherwise the perturbed runs
    follow and the pass chains with its own sensitivities, as a full pass does. With hidden
    dynamics affine in the hidden states (an equivalent circuit) the sensitivities do not
    change from pass to pass, and the second, confirming, pass costs a quarter of a full
    one for three hidden states.

    The first pass of a window of at least :data:`SENSITIVITY_SAMPLES` strides of
    :data:`SENSITIVITY_STRIDE` chunks moves only every :data:`SENSITIVITY_STRIDE`-th
    chunk's start: when those chunks' sensitivities are one (hidden dynamics affine with
    constant coefficients, as an equivalent circuit's: each chunk's is the same product of
    the same steps' propagators), every chunk is given it (:func:`_common_sensitivity`) and
    the pass chains with it; otherwise the other chunks' moved runs complete it as a full
    pass (the same runs).
    """
    total = len(y)
    firsts, length = _chunks(total)
    n_hidden = len(layout.hidden)
    scale = np.maximum(1.0, np.abs(start))
    delta = 1e-4 * scale
    guesses = np.repeat(start[None], len(firsts), axis=0)
    sensitivity = None
    # the last chunk may be shorter (its sensitivity is never chained with): not sampled
    sampled = np.arange(0, len(firsts) - 1, SENSITIVITY_STRIDE)
    passes = MAX_PASSES
    if len(sampled) >= SENSITIVITY_SAMPLES:
        passes -= 1
        batch = np.concatenate([guesses] + [guesses[sampled] + delta[i] * np.eye(n_hidden)[i]
                                            for i in range(n_hidden)])
        runs = _run(model, layout, y, u, dt, integration, batch,
                    np.concatenate([firsts] + [firsts[sampled]] * n_hidden), length)
        base, used = runs[:len(firsts)], guesses
        ends = base[:, -1]
        moved = np.empty((n_hidden, len(firsts), n_hidden))
        moved[:, sampled] = runs[len(firsts):, -1].reshape(n_hidden, len(sampled), n_hidden)
        common = _common_sensitivity(np.stack([(moved[i, sampled] - ends[sampled]) / delta[i]
                                               for i in range(n_hidden)], axis=-1), scale)
        if common is not None:
            sensitivity = np.repeat(common[None], len(firsts), axis=0)
        else:
            # the other chunks' moved runs: the pass is then the full pass
            rest = np.setdiff1d(np.arange(len(firsts)), sampled)
            batch = np.concatenate([guesses[rest] + delta[i] * np.eye(n_hidden)[i]
                                    for i in range(n_hidden)])
            moved[:, rest] = _run(model, layout, y, u, dt, integration, batch,
                                  np.tile(firsts[rest], n_hidden), length
                                  )[:, -1].reshape(n_hidden, len(rest), n_hidden)
            sensitivity = np.stack([(moved[i] - ends) / delta[i] for i in range(n_hidden)],
                                   axis=-1)
        chained = _chain(start, guesses, ends, sensitivity)
        if not np.max(np.abs(chained - guesses) / scale) > CHAIN_TOLERANCE:
            return _joined(base, firsts, length, total), used, sensitivity
        guesses = chained
    for _ in range(passes):
        if sensitivity is not None:
            base, used = _run(model, layout, y, u, dt, integration, guesses, firsts,
                              length), guesses
            chained = _chain(start, guesses, base[:, -1], sensitivity)
            if not np.max(np.abs(chained - guesses) / scale) > CHAIN_TOLERANCE:
                break
        base, sensitivity = _full_pass(model, layout, y, u, dt, integration, guesses, firsts,
                                       length, delta)
        used = guesses
        chained = _chain(start, guesses, base[:, -1], sensitivity)
        mismatch = np.max(np.abs(chained - guesses) / scale)
        if not mismatch > CHAIN_TOLERANCE:   # chained, or diverged (NaN): stop either way
            break
        guesses = chained
    return _joined(base, firsts, length, total), used, sensitivity


def _full_pass(model, layout: _Layout, y, u, dt, integration, guesses: np.ndarray,
               firsts: np.ndarray, length: int, delta: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """A full pass of :func:`_run_hidden`: every chunk run from its guessed start and, beside
    it, from the start moved by ``delta`` along each hidden state. Returns the runs from the
    guesses (K, length + 1, n_hidden) and their ends' sensitivities to the starts
    (K, n_hidden, n_hidden)."""
    n_hidden = len(delta)
    batch = np.concatenate([guesses] + [guesses + delta[i] * np.eye(n_hidden)[i]
                                        for i in range(n_hidden)])
    runs = _run(model, layout, y, u, dt, integration, batch,
                np.tile(firsts, n_hidden + 1), length)
    base = runs[:len(firsts)]
    ends = base[:, -1]
    sensitivity = np.stack([(runs[(i + 1) * len(firsts):(i + 2) * len(firsts), -1] - ends)
                            / delta[i] for i in range(n_hidden)], axis=-1)
    return base, sensitivity


def _common_sensitivity(sensitivity: np.ndarray, scale: np.ndarray) -> np.ndarray | None:
    """The chunks' common sensitivity (n_hidden, n_hidden), their mean, when every one of
    ``sensitivity`` (K, n_hidden, n_hidden) is within :data:`COMMON_SENSITIVITY_TOLERANCE`
    of it (each entry in the states' ``scale``); else ``None``."""
    mean = sensitivity.mean(axis=0)
    relative = scale[None, None, :] / scale[None, :, None]
    with np.errstate(invalid="ignore"):
        spread = np.max(np.abs(sensitivity - mean) * relative)
    return mean if spread <= COMMON_SENSITIVITY_TOLERANCE else None


def _chain(start: np.ndarray, guesses: np.ndarray, ends: np.ndarray,
           sensitivity: np.ndarray) -> np.ndarray:
    """The chunks' chained starts: the first at ``start``, each next one the previous chunk's
    end moved by its sensitivity times the previous start's move from its guess.

    The moves from the guesses obey ``m[c] = (ends[c-1] - guesses[c]) + S[c-1] m[c-1]``, a
    linear recurrence, computed as a prefix composition of its affine maps in
    ``log2(n_chunks)`` array steps (a day's 4,320 chunks: 13 instead of 4,320 Python steps);
    the same starts to rounding. Where that is not finite (a diverging run's chunks), one
    chunk after another.
    """
    moves = np.empty_like(guesses)
    moves[0] = start - guesses[0]
    moves[1:] = ends[:-1] - guesses[1:]
    maps = np.empty_like(sensitivity)
    maps[0] = 0.0
    maps[1:] = sensitivity[:-1]
    stride = 1
    with np.errstate(all="ignore"):
        while stride < len(guesses):
            moves[stride:] = (maps[stride:] @ moves[:-stride, :, None])[..., 0] + moves[stride:]
            maps[stride:] = maps[stride:] @ maps[:-stride]
            stride *= 2
    if np.all(np.isfinite(moves)):
        return guesses + moves
    chained = guesses.copy()
    chained[0] = start
    for c in range(1, len(guesses)):
        chained[c] = ends[c - 1] + sensitivity[c - 1] @ (chained[c - 1] - guesses[c - 1])
    return chained
