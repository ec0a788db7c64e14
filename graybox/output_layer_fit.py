"""The output layer of an Eq. 25 network whose hidden layer is fixed, by Levenberg-Marquardt.

With the hidden weights ``w`` fixed (the null network of :mod:`graybox.signature_fit`), the
hidden activations ``H = tanh(X w^T)`` are data and the network is ``tanh(H W)``: a
generalised linear model in the ``J`` output weights. Its loss, the same as the batched
L-BFGS minimises for a full network,

.. math:: L(W) = \\frac{1}{T} \\sum_t \\big(y_t - \\tanh(h_t \\cdot W)\\big)^2 + \\lambda |W|^2,

has one minimum, which Gauss-Newton steps reach in a handful of iterations: each needs one
``T x J`` product and a ``J x J`` solve, instead of L-BFGS's dozens of autograd passes (a
1-Hz night: ~40 iterations, 0.1 s; here a few milliseconds). Levenberg-Marquardt damping keeps
every step a descent. Each series is fitted on its own, so its result never depends on the
others of a call.

The curvature ``J^T J`` (half a step's cost) only shapes the step; the gradient and the loss,
which decide where the fit stops, are computed afresh every iteration. It is kept from one
iteration to the next while the fit converges quickly (each step's relative decrease at most
:data:`KEEP_CURVATURE` of the previous one's) and taken afresh after a slower step or a refused
one, and for the last step: the fit stops only on a step taken with a fresh curvature. Near
the minimum the slopes ``1 - tanh^2`` hardly move, so a warm-started fit (every candidate,
calibration refit and piece) takes its curvature twice: on 60 of the traction drive's fits
28 % less time, one iteration more or fewer, and the same minimum to the fit's tolerance
(outputs 1e-8 to 4e-5 of their RMS from the fit that takes it every iteration, the gradient
at the end as small).
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from graybox.network_settings import FitSettings, NetworkFit

#: the curvature is kept while each step's relative decrease of the loss is at most this
#: fraction of the previous step's (module docstring)
KEEP_CURVATURE = 0.05


def fit_output_layers(problems: Sequence[tuple[np.ndarray, np.ndarray]],
                      starts: Sequence[np.ndarray], hidden: int,
                      settings: FitSettings, keep_predictions: bool = False
                      ) -> list[NetworkFit]:
    """Fit ``W`` of each problem with its hidden layer fixed at its start.

    Parameters
    ----------
    problems : sequence of (X, y)
        Design matrices (T, m) and targets (T,).
    starts : sequence of ndarray
        Flat start weights ``[w.ravel(), W]`` of each problem; ``w`` stays as it is.
    hidden : int
        Hidden units J.
    settings : FitSettings
        ``weight_decay`` (lambda), ``tolerance`` and ``max_iter`` as for the full network.
    keep_predictions : bool, default False
        Keep each problem's network output on its rows at the fitted weights (computed by the
        fit anyway) as the fit's ``prediction``: an array of the series' length per problem.

    Returns
    -------
    list of NetworkFit
    """
    out = []
    for (X, y), start in zip(problems, starts):
        X, y = np.asarray(X, dtype=float), np.asarray(y, dtype=float)
        dim = X.shape[1]
        w = np.asarray(start[: hidden * dim], dtype=float).reshape(hidden, dim)
        H = X @ w.T
        np.tanh(H, out=H)       # in place: a second array of T x J would be a fresh mapping
        W, prediction, iterations = _levenberg_marquardt(
            H, y, np.asarray(start[hidden * dim:], dtype=float), settings)
        out.append(NetworkFit(w.copy(), W, float(np.mean((y - prediction) ** 2)), iterations,
                              prediction if keep_predictions else None))
    return out


def _loss(H: np.ndarray, y: np.ndarray, W: np.ndarray,
          decay: float) -> tuple[float, np.ndarray]:
    """The loss at ``W`` and the network's prediction there."""
    prediction = np.tanh(H @ W)
    return float(np.mean((y - prediction) ** 2) + decay * (W @ W)), prediction


def _levenberg_marquardt(H: np.ndarray, y: np.ndarray, W: np.ndarray, settings: FitSettings
                         ) -> tuple[np.ndarray, np.ndarray, int]:
    """The minimising ``W``, the prediction there and the iterations taken."""
    n = len(y)
    decay = settings.weight_decay
    identity = np.eye(H.shape[1])
    # the curvature only shapes the step (the gradient and loss, which decide the minimum,
    # stay in float64): single precision halves its T x J^2 cost, the largest of a step
    H_single = H.astype(np.float32)
    # J's T x J values are written in place every iteration: allocated afresh, an array that
    # large is a new mapping whose pages the kernel faults in and zeroes each time
    J = np.empty_like(H_single)
    loss, prediction = _loss(H, y, W, decay)
    damping = 1e-3
    iterations = 0
    curvature, stale, previous = None, True, None
    for _ in range(settings.max_iter):
        residual = y - prediction
        slope = 1.0 - prediction ** 2                          # d prediction / d (H W)
        gradient = -2.0 * (H.T @ (slope * residual)) / n + 2.0 * decay * W
        if np.abs(gradient).max() <= settings.tolerance:
            break
        fresh = stale
        if fresh:
            np.multiply(H_single, slope.astype(np.float32)[:, None], out=J)   # d pred / d W
            curvature = 2.0 * (J.T @ J).astype(float) / n + 2.0 * decay * identity
            stale = False
        improved = False
        while damping < 1e12:
            step = np.linalg.solve(curvature + damping * np.diag(np.diag(curvature)) +
                                   damping * 1e-12 * identity, -gradient)
            trial = W + step
            trial_loss, trial_prediction = _loss(H, y, trial, decay)
            if trial_loss < loss:
                improved = True
                break
            damping *= 10.0
            stale = True                                       # a refused step: afresh next
        if not improved:
            break                                              # at the minimum to precision
        relative = (loss - trial_loss) / max(abs(loss), 1e-300)
        W, loss, prediction = trial, trial_loss, trial_prediction
        damping = max(damping / 10.0, 1e-12)
        iterations += 1
        if relative <= settings.tolerance:
            if fresh:
                break
            # converged by a kept curvature's step: the last step is taken with a fresh one,
            # as every step was before, so the fit stops where it did to its tolerance
            stale = True
            continue
        # a slow step: the kept curvature no longer describes the loss well enough
        stale = stale or (previous is not None and relative > KEEP_CURVATURE * previous)
        previous = relative
    return W, prediction, iterations
