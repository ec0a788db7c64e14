"""The nonlinear tier: the time-delay tanh network of Eq. 25, in PyTorch.

.. math:: z(t) = \\tanh\\Big(\\sum_j W_{1j} \\tanh\\big(\\sum_{k=1}^m w_{jk}\\, z(t - k\\tau)\\big)\\Big)

The network has no biases, exactly as Eq. 25, so it represents odd functions of the delay
vector. It is fitted by back-propagation with a full-batch L-BFGS written for *batches of
independent series*: every series of a batch keeps its own curvature history, step size and
stopping test, and series are padded to length buckets, so fitting a series inside a batch
gives bit for bit the weights it gets alone, while the fleet pays for one batched computation
instead of thousands of small ones.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Sequence

import numpy as np

# FitSettings and initial_weights are part of this module's public API (fit_networks' arguments)
from graybox.network_settings import FitSettings, NetworkFit, initial_weights
from graybox.output_layer_fit import fit_output_layers

#: samples per batched network computation at most: about 230 MB of tensors (measured 400-450
#: bytes per series-sample for J = 8, m = 6, with and without trained input weights)
CHUNK_SAMPLES = 2 ** 19

__all__ = ["NonlinearTier", "lagged", "lagged_segments", "window_centred", "fit_networks",
           "FitSettings", "NetworkFit", "initial_weights"]


@dataclass(frozen=True)
class NonlinearTier:
    """Fitted weights of the Eq. 25 network and how well it did.

    Attributes
    ----------
    input_weights : tuple of tuple of float
        ``w_jk``, shape (hidden units J, embedding dimension m).
    output_weights : tuple of float
        ``W_1j``, shape (J,).
    train_mse : float
        Mean squared one-step error on the fitted data, in the network's scaled units.
    heldout_gain : float or None
        ``1 - MSE_net / MSE_zero`` on held-out data (zero is the linear tier's forecast of the
        AR residual). Measured when the tier's need was decided (baselines), else None.
    iterations : int
        Optimizer iterations used.
    """

    input_weights: tuple[tuple[float, ...], ...]
    output_weights: tuple[float, ...]
    train_mse: float
    heldout_gain: float | None
    iterations: int

    #: how well the fit did (never compared): a zero-variance target gives NaN or infinity
    non_finite_fields: ClassVar[frozenset[str]] = frozenset({"train_mse", "heldout_gain"})

    @property
    def hidden_units(self) -> int:
        return len(self.output_weights)

    @property
    def embedding_dim(self) -> int:
        return len(self.input_weights[0]) if self.input_weights else 0

    def weight_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(w, W)`` as float64 arrays of shapes (J, m) and (J,)."""
        return (np.asarray(self.input_weights, dtype=float).reshape(self.hidden_units, -1),
                np.asarray(self.output_weights, dtype=float))

    def predict(self, segments: Sequence[np.ndarray] | np.ndarray, tau: int) -> list[np.ndarray]:
        """One-step predictions ``z^(t)`` for ``t >= m tau`` of every segment (scaled units)."""
        if isinstance(segments, np.ndarray):
            segments = [segments]
        w, W = self.weight_arrays()
        return [np.tanh(np.tanh(lagged(s, self.embedding_dim, tau)[0] @ w.T) @ W) for s in segments]

    @classmethod
    def from_arrays(cls, w: np.ndarray, W: np.ndarray, train_mse: float,
                    heldout_gain: float | None, iterations: int) -> "NonlinearTier":
        return cls(tuple(tuple(map(float, row)) for row in np.asarray(w)),
                   tuple(map(float, np.asarray(W))), float(train_mse),
                   None if heldout_gain is None else float(heldout_gain), int(iterations))


def lagged(x: np.ndarray, dim: int, tau: int) -> tuple[np.ndarray, np.ndarray]:
    """Design matrix of Eq. 26: rows ``[x(t - tau), ..., x(t - m tau)]`` and targets ``x(t)``."""
    x = np.asarray(x, dtype=float)
    span = dim * tau
    n = len(x) - span
    if n <= 0:
        return np.zeros((0, dim)), np.zeros(0)
    columns = [x[span - k * tau: span - k * tau + n] for k in range(1, dim + 1)]
    return np.column_stack(columns), x[span:]


def window_centred(segments: Sequence[np.ndarray], owners: Sequence[int]) -> list[np.ndarray]:
    """The AR residual the network models: each window's segments less that window's mean.

    Eq. 25 has no biases, so its function is odd and cannot hold a constant: fitted to a
    residual whose mean has moved (a night warmer than the baseline's days, an unlogged
    condition), its weights bend to approximate the offset and its function drifts, and the
    level then alarms as a "nonlinear" change. The level is the level tier's and the noise
    tier's (the network's errors keep the mean:
    :func:`graybox.tiers.nonlinear.network_errors`); the network models
    the residual's dynamics about it.
    """
    totals: dict[int, list[float]] = {}
    for segment, owner in zip(segments, owners):
        total = totals.setdefault(owner, [0.0, 0])
        total[0] += float(np.sum(segment))
        total[1] += len(segment)
    means = {owner: (t[0] / t[1] if t[1] else 0.0) for owner, t in totals.items()}
    return [segment - means[owner] for segment, owner in zip(segments, owners)]


def lagged_segments(segments: Sequence[np.ndarray], dim: int, tau: int,
                    scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """:func:`lagged` of every segment divided by ``scale``, the segments' rows one after
    another: the same arrays as concatenating each segment's ``lagged(s / scale, dim, tau)``,
    written once into their place instead of per segment and then copied together. ``X`` is
    held column by column (each delay's column one contiguous copy: a fifth of the time of
    writing every ``dim``-th value), which its products with the hidden weights do not see:
    the same numbers."""
    span = dim * tau
    lengths = [max(0, len(s) - span) for s in segments]
    X, y = np.empty((sum(lengths), dim), order="F"), np.empty(sum(lengths))
    row = 0
    for segment, n in zip(segments, lengths):
        if n == 0:
            continue
        x = np.asarray(segment / scale, dtype=float)
        for k in range(1, dim + 1):
            X[row: row + n, k - 1] = x[span - k * tau: span - k * tau + n]
        y[row: row + n] = x[span:]
        row += n
    return X, y


def fit_networks(problems: Sequence[tuple[np.ndarray, np.ndarray]], hidden: int,
                 initial: Sequence[tuple[np.ndarray, np.ndarray] | None] | None = None,
                 settings: FitSettings = FitSettings(),
                 random_state: int | Sequence[int] | None = 0,
                 chunk_size: int = 32, train_input_weights: bool = True,
                 chunk_samples: int = CHUNK_SAMPLES, keep_predictions: bool = False
                 ) -> list[NetworkFit]:
    """Fit one Eq. 25 network per problem, in batches of independent series.

    Parameters
    ----------
    problems : sequence of (X, y)
        Per series the design matrix (T_b, m) and targets (T_b,) from :func:`lagged`; every
        ``X`` must have the same ``m``. Lengths may differ.
    hidden : int
        Hidden units J.
    initial : sequence of (w, W) or None, optional
        Warm starts (shapes (J, m) and (J,)); None entries get random weights.
    settings : FitSettings
    random_state : int or sequence of int, optional
        Seeds the random initial weights: one seed per problem, or one int from which problem
        ``i`` gets the seed ``[random_state, i]``. A series' result depends only on its own seed
        and data, never on the rest of its batch.
    chunk_size : int, default 32
        Series per batched computation (small chunks keep activations in cache).
    chunk_samples : int, default CHUNK_SAMPLES
        Most (padded) samples of all series of a batched computation: its memory is about
        450 bytes per sample, so this bounds it whatever the series' lengths.
    train_input_weights : bool, default True
        When False the hidden layer ``w_jk`` keeps its starting values (fixed random
        features) and only ``W_1j`` is fitted: a well-posed problem with one minimum, used
        where there is no nonlinear structure to learn (see :mod:`graybox.signature_fit`).
    keep_predictions : bool, default False
        With ``train_input_weights=False``: keep each problem's network output on its rows as
        the fit's ``prediction`` (:func:`graybox.output_layer_fit.fit_output_layers`); a
        trained network's fit has none.

    Returns
    -------
    list of NetworkFit
    """
    if not problems:
        return []
    dims = {X.shape[1] for X, _ in problems}
    if len(dims) != 1:
        raise ValueError(f"all problems of a batch need the same embedding dimension, got {dims}")
    dim = dims.pop()
    initial = list(initial) if initial is not None else [None] * len(problems)
    if random_state is None or isinstance(random_state, (int, np.integer)):
        seeds = [None if random_state is None else [int(random_state), i] for i in range(len(problems))]
    else:
        seeds = list(random_state)
    starts = []
    for start, seed in zip(initial, seeds):
        if start is None:
            w, W = initial_weights(hidden, dim, seed, settings.init_scale)
        else:
            w, W = (np.asarray(a, dtype=float) for a in start)
            if w.shape != (hidden, dim) or W.shape != (hidden,):
                raise ValueError(f"warm start shapes {w.shape}, {W.shape} do not match "
                                 f"J={hidden}, m={dim}")
        starts.append(np.concatenate([w.ravel(), W]))
    if not train_input_weights:
        # one minimum: Levenberg-Marquardt on the output weights, series by series, no torch
        return fit_output_layers(problems, starts, hidden, settings, keep_predictions)
    # Series are padded to a length bucket and batched only with series of the same bucket:
    # every array shape a series meets then depends on its own length alone, so its float
    # rounding (and hence its optimization path) is the same in any batch as alone.
    from graybox.network_training import fit_chunk, single_thread  # torch loads only here

    buckets: dict[int, list[int]] = {}
    for index, (_, y) in enumerate(problems):
        buckets.setdefault(_bucket(len(y)), []).append(index)
    results: list[NetworkFit | None] = [None] * len(problems)
    with single_thread():
        for length, members in sorted(buckets.items()):
            size = max(1, min(chunk_size, chunk_samples // length))
            for first in range(0, len(members), size):
                chunk = members[first: first + size]
                fits = fit_chunk([problems[i] for i in chunk], [starts[i] for i in chunk],
                                 hidden, dim, settings, length, train_input_weights)
                for index, fit in zip(chunk, fits):
                    results[index] = fit
    return results


def _bucket(length: int) -> int:
    """Padded length: the next multiple of 1/16 of the next power of two (<= 6.25 % padding)."""
    if length <= 256:
        return 256
    step = 1 << (int(np.ceil(np.log2(length))) - 4)
    return int(np.ceil(length / step)) * step
