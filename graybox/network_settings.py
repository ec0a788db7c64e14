"""Records of the network tier's training: its settings, one series' raw fit, start weights.

Kept apart from the training code (:mod:`graybox.network_training`, which imports torch) so
that settings can be read, stored and compared without loading torch.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FitSettings:
    """How the network is trained; the same settings must serve a baseline and its candidates.

    Attributes
    ----------
    max_iter : int
        L-BFGS iterations at most.
    tolerance : float
        Stop when the largest gradient entry is below this, or the loss falls by less than
        ``tolerance`` (relative) over an iteration.
    weight_decay : float
        L2 penalty on all weights; keeps flat directions (e.g. ``w_j`` when ``W_1j = 0``) pinned.
    history : int
        L-BFGS memory.
    init_scale : float
        Standard deviation of random initial weights, divided by sqrt(fan-in). With inputs
        scaled to a quarter of their standard deviation (the estimator's default), 4 gives
        the hidden units unit-variance pre-activations: inside tanh's nonlinear range.
    """

    max_iter: int = 200
    tolerance: float = 1e-9
    weight_decay: float = 1e-4
    history: int = 10
    init_scale: float = 4.0


@dataclass(frozen=True)
class NetworkFit:
    """Raw result of one series' fit.

    ``prediction`` is the network's output on the fitted design's rows at ``(w, W)``,
    ``tanh(tanh(X w^T) W)``, where the fit computed it that way (the output-layer fit) and
    was asked to keep it, else None.
    """

    w: np.ndarray
    W: np.ndarray
    mse: float
    iterations: int
    prediction: np.ndarray | None = None


def initial_weights(hidden: int, dim: int, seed, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Random starting weights ``(w, W)``: normal, standard deviation ``scale / sqrt(fan-in)``."""
    rng = np.random.default_rng(seed)
    return (rng.normal(0.0, scale / np.sqrt(dim), (hidden, dim)),
            rng.normal(0.0, scale / np.sqrt(hidden), hidden))
