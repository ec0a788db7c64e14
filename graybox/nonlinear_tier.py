"""The nonlinear tier: the time-delay tanh network of Eq. 25, in PyTorch.

.. math:: z(t) = \\tanh\\Big(\\sum_j W_{1j} \\tanh\\big(\\sum_{k=1}^m w_{jk}\\, z(t - k\\tau)\\big)\\Big)

The network has no biases, exactly as Eq. 25, so it represents odd functions of the delay
vector. It is fitted by back-propagation with a full-batch L-BFGS written for *batches of
independent series*: every series of a batch keeps its own curvature history, step size and
stopping test, so fitting a series inside a batch gives the same weights as fitting it alone,
while the fleet pays for one batched computation instead of thousands of small ones.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import torch

from graybox.exceptions import InsufficientDataError


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
        Standard deviation of random initial weights, divided by sqrt(fan-in).
    """

    max_iter: int = 200
    tolerance: float = 1e-9
    weight_decay: float = 1e-4
    history: int = 10
    init_scale: float = 1.0


@dataclass(frozen=True)
class NetworkFit:
    """Raw result of one series' fit."""

    w: np.ndarray
    W: np.ndarray
    mse: float
    iterations: int


def initial_weights(hidden: int, dim: int, seed, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Random starting weights ``(w, W)``: normal, standard deviation ``scale / sqrt(fan-in)``."""
    rng = np.random.default_rng(seed)
    return (rng.normal(0.0, scale / np.sqrt(dim), (hidden, dim)),
            rng.normal(0.0, scale / np.sqrt(hidden), hidden))


def _forward(theta: torch.Tensor, X: torch.Tensor, hidden: int, dim: int) -> torch.Tensor:
    batch = theta.shape[0]
    w = theta[:, : hidden * dim].reshape(batch, hidden, dim)
    W = theta[:, hidden * dim:].reshape(batch, hidden, 1)
    return torch.tanh(torch.bmm(torch.tanh(torch.bmm(X, w.transpose(1, 2))), W))[..., 0]


def fit_networks(problems: Sequence[tuple[np.ndarray, np.ndarray]], hidden: int,
                 initial: Sequence[tuple[np.ndarray, np.ndarray] | None] | None = None,
                 settings: FitSettings = FitSettings(),
                 random_state: int | Sequence[int] | None = 0,
                 chunk_size: int = 32) -> list[NetworkFit]:
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
    results = []
    for first in range(0, len(problems), chunk_size):
        chunk = slice(first, first + chunk_size)
        results.extend(_fit_chunk(problems[chunk], starts[chunk], hidden, dim, settings))
    return results


def _fit_chunk(problems, starts, hidden, dim, settings: FitSettings) -> list[NetworkFit]:
    batch = len(problems)
    length = max(len(y) for _, y in problems)
    if min(len(y) for _, y in problems) == 0:
        raise InsufficientDataError("a series has no samples after embedding")
    X = torch.zeros(batch, length, dim, dtype=torch.float64)
    y = torch.zeros(batch, length, dtype=torch.float64)
    mask = torch.zeros(batch, length, dtype=torch.float64)
    for b, (Xb, yb) in enumerate(problems):
        X[b, : len(yb)] = torch.from_numpy(np.ascontiguousarray(Xb, dtype=float))
        y[b, : len(yb)] = torch.from_numpy(np.ascontiguousarray(yb, dtype=float))
        mask[b, : len(yb)] = 1.0 / len(yb)
    theta = torch.from_numpy(np.stack(starts)).to(torch.float64)
    decay = settings.weight_decay

    def evaluate(params: torch.Tensor, need_grad: bool = True):
        params = params.detach().requires_grad_(need_grad)
        with torch.set_grad_enabled(need_grad):
            error = ((y - _forward(params, X, hidden, dim)) ** 2 * mask).sum(dim=1)
            loss = error + decay * (params ** 2).sum(dim=1)
            grad = torch.autograd.grad(loss.sum(), params)[0] if need_grad else None
        return loss.detach(), error.detach(), grad

    theta, iterations = _batched_lbfgs(theta, evaluate, settings)
    _, error, _ = evaluate(theta, need_grad=False)
    out = []
    for b in range(batch):
        params = theta[b].numpy()
        out.append(NetworkFit(params[: hidden * dim].reshape(hidden, dim).copy(),
                              params[hidden * dim:].copy(), float(error[b]), int(iterations[b])))
    return out


def _batched_lbfgs(theta: torch.Tensor, evaluate, settings: FitSettings):
    """Minimize a sum of independent losses; each row of ``theta`` is its own problem.

    Standard L-BFGS two-loop recursion and a backtracking Armijo line search, with every
    quantity (history, step, convergence) kept per row.
    """
    batch = theta.shape[0]
    loss, _, grad = evaluate(theta)
    active = torch.ones(batch, dtype=torch.bool)
    iterations = torch.zeros(batch, dtype=torch.long)
    s_hist, y_hist = [], []
    for _ in range(settings.max_iter):
        active &= grad.abs().amax(dim=1) > settings.tolerance
        if not active.any():
            break
        direction = -_two_loop(grad, s_hist, y_hist)
        slope = (grad * direction).sum(dim=1)
        bad = slope >= 0  # not a descent direction: fall back to steepest descent
        direction[bad] = -grad[bad]
        slope = (grad * direction).sum(dim=1)
        step = torch.ones(batch, dtype=theta.dtype)
        if not s_hist:
            step = torch.clamp(1.0 / grad.abs().sum(dim=1), max=1.0)
        step = torch.where(active, step, torch.zeros_like(step))
        accepted = ~active
        new_theta, new_loss, new_grad = theta, loss, grad
        for _ in range(30):
            trial = theta + step[:, None] * direction
            trial_loss, _, trial_grad = evaluate(trial)
            ok = (trial_loss <= loss + 1e-4 * step * slope) & ~accepted
            new_theta = torch.where(ok[:, None], trial, new_theta)
            new_loss = torch.where(ok, trial_loss, new_loss)
            new_grad = torch.where(ok[:, None], trial_grad, new_grad)
            accepted |= ok
            if accepted.all():
                break
            step = torch.where(accepted, step, step * 0.5)
        moved = accepted & active
        # rows whose line search failed have converged as far as float precision allows
        active &= moved
        s, yv = new_theta - theta, new_grad - grad
        curvature = (s * yv).sum(dim=1)
        keep = moved & (curvature > 1e-12)
        s_hist.append(torch.where(keep[:, None], s, torch.zeros_like(s)))
        y_hist.append(torch.where(keep[:, None], yv, torch.zeros_like(yv)))
        if len(s_hist) > settings.history:
            s_hist.pop(0)
            y_hist.pop(0)
        relative = (loss - new_loss) / torch.clamp(loss.abs(), min=1e-300)
        iterations += moved.long()
        theta, loss, grad = new_theta, new_loss, new_grad
        active &= relative > settings.tolerance
    return theta, iterations


def _two_loop(grad: torch.Tensor, s_hist, y_hist) -> torch.Tensor:
    q = grad.clone()
    alphas = []
    rhos = []
    for s, y in zip(reversed(s_hist), reversed(y_hist)):
        sy = (s * y).sum(dim=1)
        rho = torch.where(sy > 0, 1.0 / torch.where(sy > 0, sy, torch.ones_like(sy)), torch.zeros_like(sy))
        alpha = rho * (s * q).sum(dim=1)
        q = q - alpha[:, None] * y
        alphas.append(alpha)
        rhos.append(rho)
    gamma = torch.ones(grad.shape[0], dtype=grad.dtype)
    for s, y in zip(reversed(s_hist), reversed(y_hist)):
        sy, yy = (s * y).sum(dim=1), (y * y).sum(dim=1)
        usable = (sy > 0) & (yy > 0) & (gamma == 1.0)
        gamma = torch.where(usable, sy / torch.where(yy > 0, yy, torch.ones_like(yy)), gamma)
    r = gamma[:, None] * q
    for (s, y), alpha, rho in zip(zip(s_hist, y_hist), reversed(alphas), reversed(rhos)):
        beta = rho * (y * r).sum(dim=1)
        r = r + s * (alpha - beta)[:, None]
    return r
