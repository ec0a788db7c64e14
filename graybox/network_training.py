"""Batched full-batch L-BFGS training of Eq. 25 networks in PyTorch (see
:func:`graybox.nonlinear_tier.fit_networks`, the public entry point)."""
from __future__ import annotations

import contextlib

import numpy as np
import torch

from graybox.exceptions import InsufficientDataError
from graybox.network_settings import FitSettings, NetworkFit


@contextlib.contextmanager
def single_thread():
    """Run torch on one thread, then restore the caller's setting.

    These computations are many small tensor operations; with 2 threads, OpenMP's spin-waits
    cost more than they save, and on a busy machine they made fits 5 times slower (measured:
    106 s against 19 s for 4 baselines). Parallelism belongs to processes (the flows' batches).
    """
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


def _forward(theta: torch.Tensor, X: torch.Tensor, hidden: int, dim: int) -> torch.Tensor:
    batch = theta.shape[0]
    w = theta[:, : hidden * dim].reshape(batch, hidden, dim)
    return _output(torch.tanh(torch.bmm(X, w.transpose(1, 2))), theta)


def _output(activations: torch.Tensor, theta: torch.Tensor) -> torch.Tensor:
    hidden = activations.shape[-1]
    W = theta[:, -hidden:].reshape(theta.shape[0], 1, hidden)
    # the output layer as a product and sum, not a second bmm: a (B, T, J) @ (B, J, 1) bmm
    # rounds differently for different batch sizes, which would make results batch-dependent
    return torch.tanh((activations * W).sum(dim=-1))


def fit_chunk(problems, starts, hidden, dim, settings: FitSettings, length: int,
               train_input_weights: bool) -> list[NetworkFit]:
    batch = len(problems)
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

    if train_input_weights:
        def predict(params):
            return _forward(params, X, hidden, dim)
        trained = slice(0, theta.shape[1])
    else:
        # fixed hidden layer: its activations never change, so compute them once and fit
        # only the output weights (a much smaller computation per evaluation)
        w = theta[:, : hidden * dim].reshape(batch, hidden, dim)
        activations = torch.tanh(torch.bmm(X, w.transpose(1, 2)))

        def predict(params):
            return _output(activations, params)
        trained = slice(hidden * dim, theta.shape[1])

    def evaluate(params: torch.Tensor, need_grad: bool = True):
        free = params[:, trained].detach().requires_grad_(need_grad)
        with torch.set_grad_enabled(need_grad):
            full = torch.cat([params[:, : trained.start], free], dim=1)
            error = ((y - predict(full)) ** 2 * mask).sum(dim=1)
            loss = error + decay * (free ** 2).sum(dim=1)
            grad = torch.autograd.grad(loss.sum(), free)[0] if need_grad else None
        return loss.detach(), error.detach(), grad

    free, iterations = _batched_lbfgs(theta[:, trained].clone(), lambda f, need_grad=True: evaluate(
        torch.cat([theta[:, : trained.start], f], dim=1), need_grad), settings)
    theta = torch.cat([theta[:, : trained.start], free], dim=1)
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
