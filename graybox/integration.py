"""How the residual integrates the white box over one sample: the method, its sub-steps, and the
error estimate that chooses them.

Three methods, all vectorised over every starting point of a window at once:

``rk4``
    Classical Runge-Kutta, the seed's integrator (:func:`graybox.rk4.rk4_step`). Accurate and
    cheap while the sub-step ``h`` is short against the model's fastest time constant; beyond
    ``h |lambda| ~ 2.8`` it is unstable and its prediction grows without bound.
``rosenbrock``
    The two-stage, second-order, L-stable Rosenbrock method ROS2 (Verwer, Spee, Blom and
    Hundsdorfer 1999) with the Jacobian ``df/dx`` by forward differences at every starting
    point and the inputs' time derivative as its non-autonomous term. A state far faster than
    the sample (a 6-ms armature at 1 Hz) relaxes to its quasi-static value within the step
    instead of diverging; slow states are integrated to second order.
``rosenbrock_w``
    The same ROS2 with the Jacobian, the inputs' term and the stage matrix ``I - gamma h J``
    (inverted) taken at the sample's start and then every :data:`JACOBIAN_SUBSTEPS` sub-steps,
    shared by the sub-steps in between. ROS2 is a W-method: second order for any matrix in
    place of the Jacobian (Verwer et al. 1999; with ``J = 0`` it is Heun's method), so the
    shared sub-steps keep its order, and where the Jacobian changes little over them (a
    linear armature's rows do not change at all) they keep its stability too. A shared
    sub-step costs two model evaluations and two 3 x 3 products per starting point instead of
    six evaluations, a factorisation and two solves. Once per sample was tried first: on the
    traction drive's data its current prediction differed from ROS2's by 0.12 A RMS (1.2 A
    at drive starts, where the rolling resistance's ``tanh`` of the speed changes its slope
    within the sample), as far as either is from a 64-sub-step reference, but the noise
    tier's ratios of the zoo's connection-resistance faults fell by a quarter; every 4
    sub-steps the difference is 0.003 A (0.011 A at drive starts). It is taken at the
    sub-steps ROS2's own error estimate chooses, when its own estimate passes there too
    (:func:`choose_integration`), never at fewer: step doubling estimates about 3/4 of a
    second-order method's error, and on the drive's data both methods sit at the bound
    with 8 sub-steps. Signatures that recorded ``rosenbrock`` keep it.

The inputs are linear inside a sample (a first-order hold). :func:`choose_integration` picks
the method and the sub-steps from a step-doubling error estimate at the data's own states: a
prediction with ``s`` sub-steps against one with ``2 s``; the estimate must stay below
:data:`ERROR_FRACTION` of the channel's sample-to-sample change (what the residual measures).
The model's ``integrator`` declaration narrows the choice (``"auto"``: RK4 first, then
Rosenbrock, given as ``rosenbrock_w`` at the sub-steps ROS2's estimate takes where that
method's estimate passes there too). When no method reaches the bound within
:data:`MAX_SUBSTEPS` sub-steps the error names the model and the channel.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from graybox.batched_lu import (LARGEST, apply_columns, inverse_columns, inverse_entries,
                                 lu_factor)
from graybox.exceptions import GrayBoxError
from graybox.rk4 import rk4_step

METHODS = ("rk4", "rosenbrock", "rosenbrock_w")
#: sub-steps of ``rosenbrock_w`` that share one Jacobian (module docstring)
JACOBIAN_SUBSTEPS = 4
#: sub-steps per sample the seed used (the residual of a model without hidden states keeps it
#: wherever it is accurate, so existing baselines are reproduced bit for bit)
DEFAULT_SUBSTEPS = 2
MAX_SUBSTEPS = 64
#: the step-doubling error estimate, as a fraction of the RMS sample-to-sample change
ERROR_FRACTION = 0.01
#: starting points the error estimate is evaluated at
ERROR_POINTS = 256
#: the most a state of a plant may grow per sample (linearised) before the model is wrong
MAX_GROWTH = 10.0
_GAMMA = 1.0 + 1.0 / np.sqrt(2.0)


class IntegrationError(GrayBoxError):
    """The white box cannot be integrated accurately, or its prediction diverges."""


@dataclass(frozen=True)
class Integration:
    """The integrator of a signature's residual (candidates use their baseline's).

    Attributes
    ----------
    method : str
        ``"rk4"`` or ``"rosenbrock"``.
    substeps : int
        Integration steps per telemetry sample.
    """

    method: str = "rk4"
    substeps: int = DEFAULT_SUBSTEPS

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"integration method must be one of {METHODS}, got {self.method!r}")
        if not 1 <= self.substeps <= MAX_SUBSTEPS:
            raise ValueError(f"substeps must be in 1..{MAX_SUBSTEPS}, got {self.substeps}")


def advance(f, x: np.ndarray, u0: np.ndarray, u1: np.ndarray, dt: float,
            integration: Integration = Integration()) -> np.ndarray:
    """Integrate ``dx/dt = f(x, u)`` over one sample from every row of ``x``.

    Parameters
    ----------
    f : callable
        ``f(x, u)`` on arrays of shape (N, n_states) and (N, n_inputs).
    x : ndarray of shape (N, n_states)
        States at the start of the sample.
    u0, u1 : ndarray of shape (N, n_inputs)
        Inputs at the start and the end of the sample (linear in between).
    dt : float
        Sample interval in seconds.
    integration : Integration

    Returns
    -------
    ndarray of shape (N, n_states)
    """
    substeps = integration.substeps
    if integration.method == "rosenbrock_w":
        return _ros2_per_sample(f, x, u0, u1, dt, substeps)
    h = dt / substeps
    state = x
    change = u1 - u0        # the inputs' change over the sample, taken once
    for step in range(substeps):
        begin = step / substeps
        ua = u0 + change * begin
        ub = u0 + change * (begin + 1.0 / substeps)
        if integration.method == "rk4":
            um = u0 + change * (begin + 0.5 / substeps)
            state = rk4_step(f, state, ua, um, ub, h)
        else:
            state = _ros2_step(f, state, ua, ub, h)
    return state


def jacobian(f, x: np.ndarray, u: np.ndarray, fx: np.ndarray | None = None) -> np.ndarray:
    """``df/dx`` at every row of ``x`` by forward differences: (N, n, n)."""
    fx = f(x, u) if fx is None else fx
    n = x.shape[-1]
    out = np.empty(x.shape + (n,))
    for j in range(n):
        delta = 1e-7 * np.maximum(1.0, np.abs(x[..., j]))
        shifted = x.copy()
        shifted[..., j] += delta
        out[..., j] = (f(shifted, u) - fx) / delta[..., None]
    return out


def _ros2_step(f, x: np.ndarray, ua: np.ndarray, ub: np.ndarray, h: float) -> np.ndarray:
    n = x.shape[-1]
    fx = f(x, ua)
    jacobian_x = jacobian(f, x, ua, fx)
    # the non-autonomous term: df/du along the inputs' (constant) rate over the step
    rate = (ub - ua) / h
    epsilon = 1e-7 * max(1.0, float(np.max(np.abs(ua), initial=0.0)))
    f_t = (f(x, ua + epsilon * rate) - fx) / epsilon if ua.shape[-1] else 0.0
    # both stages solve with one matrix: factor it once
    lu = lu_factor((np.eye(n) - _GAMMA * h * jacobian_x).reshape(-1, n, n))
    k1 = lu.solve((fx + _GAMMA * h * f_t).reshape(-1, n)).reshape(x.shape)
    k2 = lu.solve((f(x + h * k1, ub) - 2.0 * k1 - _GAMMA * h * f_t).reshape(-1, n)).reshape(x.shape)
    return x + 1.5 * h * k1 + 0.5 * h * k2


def _ros2_per_sample(f, x: np.ndarray, u0: np.ndarray, u1: np.ndarray, dt: float,
                     substeps: int) -> np.ndarray:
    """ROS2 over one sample in ``substeps`` sub-steps, the Jacobian, the inputs' term and the
    inverted stage matrix taken at the sample's start and again every
    :data:`JACOBIAN_SUBSTEPS` sub-steps (``rosenbrock_w``)."""
    n = x.shape[-1]
    h = dt / substeps
    # rows of states held column by column (each state's values contiguous, as the white box
    # reads them and apply_columns sums them): the same operations element by element, so the
    # same numbers, on contiguous columns instead of every n-th value
    by_column = x.ndim == 2
    columns = np.asfortranarray if by_column else np.asarray
    x, u0, u1 = columns(x), columns(u0), columns(u1)
    # the non-autonomous term: df/du along the inputs' (constant) rate over the sample
    change = u1 - u0        # the inputs' change over the sample, taken once
    rate = change / dt
    state = x
    for step in range(substeps):
        begin = step / substeps
        ua = u0 + change * begin
        ub = u0 + change * (begin + 1.0 / substeps)
        slope = columns(f(state, ua))
        if step % JACOBIAN_SUBSTEPS == 0:
            epsilon = 1e-7 * max(1.0, float(np.max(np.abs(ua), initial=0.0)))
            f_t = ((columns(f(state, ua + epsilon * rate)) - slope) / epsilon
                   if ua.shape[-1] else 0.0)
            shift = _GAMMA * h * f_t
            inverse = _stage_inverse(f, state, ua, slope, _GAMMA * h)
        k1 = apply_columns(inverse, slope + shift)
        k2 = apply_columns(inverse, columns(f(state + h * k1, ub)) - 2.0 * k1 - shift)
        state = state + 1.5 * h * k1 + 0.5 * h * k2
    # row by row again, as the callers' reductions over rows read it
    return np.ascontiguousarray(state) if by_column else state


def _stage_inverse(f, x: np.ndarray, u: np.ndarray, fx: np.ndarray, gh: float) -> np.ndarray:
    """``inverse_columns(I - gh J)`` with ``J = jacobian(f, x, u, fx)``, the matrix built
    entry by entry (the same numbers as :func:`jacobian` and the subtraction, without the
    batch of ``n x n`` matrices in between) where the inverse is taken that way too."""
    n = x.shape[-1]
    if n > LARGEST or x.ndim != 2:
        return inverse_columns(np.eye(n) - gh * jacobian(f, x, u, fx))
    identity = np.eye(n)
    entries = np.empty((n, n, len(x)))
    for j in range(n):
        delta = 1e-7 * np.maximum(1.0, np.abs(x[..., j]))
        shifted = x.copy(order="K")      # held as ``x`` is (column by column in ROS2-W)
        shifted[..., j] += delta
        difference = f(shifted, u) - fx
        for i in range(n):
            entries[i, j] = identity[i, j] - gh * (difference[..., i] / delta)
    return inverse_entries(entries)


def error_estimate(f, x: np.ndarray, u0: np.ndarray, u1: np.ndarray, dt: float,
                   integration: Integration) -> np.ndarray:
    """Step-doubling estimate of the integration error per state: RMS over the rows of the
    difference between ``integration`` and the same method with twice the sub-steps."""
    with np.errstate(all="ignore"):   # a diverging model overflows here; the bound says so
        coarse = advance(f, x, u0, u1, dt, integration)
        fine = advance(f, x, u0, u1, dt, Integration(integration.method, 2 * integration.substeps))
        return np.sqrt(np.mean((coarse - fine) ** 2, axis=0))


#: what a white box that is not finite at the data's states is told to check
#: what a stiff white box does about it (a class attribute, not a fleet.toml setting)
STIFF_HINT = ('a stiff model declares integrator = "rosenbrock" as a class attribute of its '
              'white box')
_FINITE_ADVICE = ("A white box must be finite wherever the plant runs: check square roots and "
                  "logarithms of quantities that can turn negative, divisions that can reach "
                  "zero, and tables read beyond their breakpoints")


def _finite_rows(*arrays: np.ndarray) -> np.ndarray:
    """Rows at which every array (each (N, k)) is finite."""
    return np.logical_and.reduce([np.isfinite(a).all(axis=1) for a in arrays])


def _first_row(model, x: np.ndarray, u: np.ndarray, row: int) -> str:
    return (f"states {dict(zip(model.states, np.round(x[row], 6).tolist()))}, inputs "
            f"{dict(zip(model.inputs, np.round(u[row], 6).tolist()))}")


def check_finite_derivatives(model, x: np.ndarray, u: np.ndarray) -> None:
    """Raise :class:`IntegrationError` where ``derivatives(x, u)`` is not finite at a row
    whose states and inputs are."""
    start = _finite_rows(x, u)
    with np.errstate(all="ignore"):
        slopes = np.asarray(model.derivatives(x[start], u[start]))
    undefined = np.flatnonzero(start)[~np.isfinite(slopes).all(axis=1)]
    if undefined.size:
        raise IntegrationError(
            f"{type(model).__name__}: derivatives(x, u) is not finite at {undefined.size} of "
            f"the data's states (the first: {_first_row(model, x, u, undefined[0])}). "
            f"{_FINITE_ADVICE}")


def check_finite_outputs(model, x: np.ndarray, u: np.ndarray, y: np.ndarray) -> None:
    """Raise :class:`IntegrationError` where the outputs ``y = output(x, u)`` are missing
    (NaN) at a row whose states and inputs are finite (as
    :func:`check_finite_prediction`, for the output map)."""
    rows = np.flatnonzero(_finite_rows(x, u) & np.isnan(y).any(axis=1))
    if rows.size:
        raise IntegrationError(
            f"{type(model).__name__}: output(x, u) is not finite at {rows.size} of the "
            f"predicted states (the first: {_first_row(model, x, u, rows[0])}). "
            f"{_FINITE_ADVICE}")


def check_finite_prediction(model, x: np.ndarray, u0: np.ndarray, u1: np.ndarray,
                            predicted: np.ndarray) -> None:
    """Raise :class:`IntegrationError` where the prediction over one sample is missing
    (NaN) although its start (states and both inputs) is finite: the white box is undefined
    at the data's states or within the sample (a square root of a quantity that turns
    negative, a division that reaches zero, a table read beyond its breakpoints). Left
    alone, those samples would read as gaps in the telemetry and drop out of the analysis
    unseen. A prediction that only grows large is
    :func:`graybox.state_estimation.check_prediction`'s to judge."""
    rows = np.flatnonzero(_finite_rows(x, u0, u1) & np.isnan(predicted).any(axis=1))
    if not rows.size:
        return
    check_finite_derivatives(model, x[rows], u0[rows])
    raise IntegrationError(
        f"{type(model).__name__}: the prediction over one sample is not finite from "
        f"{rows.size} of the data's states, though derivatives(x, u) is finite there (the "
        f"first: {_first_row(model, x, u0, rows[0])}): the white box is not finite within "
        f"the sample, or its integration diverges ({STIFF_HINT}). {_FINITE_ADVICE}")


def _check_growth(model, x: np.ndarray, u: np.ndarray, dt: float) -> None:
    """Raise if the linearised model grows by more than :data:`MAX_GROWTH` per sample at
    most of the data's states: no accurate prediction exists, and an L-stable method would
    hide it (it damps every fast mode, growing ones too)."""
    with np.errstate(all="ignore"):
        slopes = jacobian(model.derivatives, x, u)
        eigenvalues = np.linalg.eigvals(np.where(np.isfinite(slopes), slopes, 0.0))
    rate = float(np.median(eigenvalues.real.max(axis=1)))
    if rate * dt > np.log(MAX_GROWTH):
        # the state that feeds itself most
        worst = np.argmax(np.median(np.diagonal(slopes, axis1=1, axis2=2), axis=0))
        raise IntegrationError(
            f"{type(model).__name__}: state {model.states[int(worst)]!r} grows by a factor "
            f"{np.exp(min(rate * dt, 700)):.3g} per {dt:g}-s sample at the data's states (the "
            f"model's Jacobian has an eigenvalue with real part {rate:.3g} /s): a plant observed "
            f"at this rate does not. Check the model's signs and units")


def choose_integration(model, x: np.ndarray, u: np.ndarray, dt: float,
                       change: np.ndarray, judged: np.ndarray | None = None) -> Integration:
    """The cheapest method and sub-steps whose error estimate is below the bound.

    Parameters
    ----------
    model : WhiteBoxModel
    x : ndarray of shape (T, n_states)
        Full states of the data (measured, and hidden ones estimated).
    u : ndarray of shape (T, n_inputs)
    dt : float
    change : ndarray of shape (n_states,)
        RMS sample-to-sample change of each state in the data (the error's unit).
    judged : ndarray of bool, shape (T,), optional
        Rows the error may be estimated at: of the :data:`ERROR_POINTS` spread over the
        data, those outside it are left out (a segment's first rows, where a hidden start is
        least determined: :func:`graybox.signature_fit._integrate`). Default: every row.

    Raises
    ------
    IntegrationError
        Naming the model, the state and what to do, when no method reaches the bound.
    """
    take = np.unique(np.linspace(0, len(x) - 2, min(ERROR_POINTS, len(x) - 1)).round().astype(int))
    if judged is not None and judged[take].any():
        # the points stay where they are over the data, those outside the judged rows
        # dropped: the other points and so the choice elsewhere unchanged
        take = take[judged[take]]
    x0, u0, u1 = x[take], u[take], u[take + 1]
    check_finite_derivatives(model, x0, u0)
    _check_growth(model, x0, u0, dt)
    methods = {"auto": METHODS[:2], "rk4": ("rk4",), "rosenbrock": ("rosenbrock",)}[
        model.integrator]
    bound = ERROR_FRACTION * np.maximum(change, 1e-12)

    def within(candidate: Integration) -> tuple[bool, np.ndarray]:
        error = error_estimate(model.derivatives, x0, u0, u1, dt, candidate)
        return bool(np.all(np.isfinite(error)) and np.all(error <= bound)), error

    worst = None
    for method in methods:
        substeps = DEFAULT_SUBSTEPS
        while substeps <= MAX_SUBSTEPS // 2:
            candidate = Integration(method, substeps)
            accurate, error = within(candidate)
            if accurate:
                # the sub-steps ROS2's estimate takes, each cheaper with a shared Jacobian
                # where that passes its own estimate there too (module docstring)
                shared = Integration("rosenbrock_w", substeps)
                if method == "rosenbrock" and within(shared)[0]:
                    return shared
                return candidate
            ratio = np.where(np.isfinite(error), error / bound, np.inf)
            worst = (method, substeps, int(np.argmax(ratio)), float(np.max(ratio)))
            substeps *= 2
    method, substeps, state, ratio = worst
    advice = (_stiff_advice(model, x0, u0, dt) if method == "rosenbrock" else
              STIFF_HINT)
    raise IntegrationError(
        f"{type(model).__name__}: state {model.states[state]!r} cannot be integrated over the "
        f"{dt:g}-s sample: with {method} and {substeps} sub-steps the error estimate is "
        f"{ratio:.3g} times the bound ({ERROR_FRACTION:g} of its sample-to-sample change). "
        f"Check the model's signs and units (a state that grows without bound has no accurate "
        f"prediction); {advice}")


def _stiff_advice(model, x: np.ndarray, u: np.ndarray, dt: float) -> str:
    """What a model that even the implicit method cannot integrate over ``dt`` shows at the
    data's states: its fastest mode against the sample (a lightly damped one rings within
    it: every sub-step must follow the ringing), and a Jacobian that is not smooth (a
    square root or an ``abs`` at zero: an infinite slope, which no sub-step size resolves)."""
    with np.errstate(all="ignore"):
        slopes = jacobian(model.derivatives, x, u)
    finite = np.all(np.isfinite(slopes), axis=(1, 2))
    parts = ["the implicit method (\"rosenbrock\", chosen) is already in use"]
    if finite.any():
        eigenvalues = np.linalg.eigvals(slopes[finite])
        fastest = np.abs(eigenvalues).max(axis=1)
        row = int(np.argsort(fastest)[len(fastest) // 2])          # the median state's
        mode = eigenvalues[row][np.argmax(np.abs(eigenvalues[row]))]
        hertz = abs(mode.imag) / (2 * np.pi)
        if hertz * dt > 0.25:    # a quarter of a period or more within a sample
            damping = -mode.real / abs(mode)
            parts.append(f"its fastest mode rings at {hertz:.3g} Hz (damping ratio "
                         f"{damping:.2g}), {hertz * dt:.2g} periods within a sample")
        size = np.abs(slopes[finite])
        usual = np.median(size, axis=0)                      # each slope's, over the states
        jumps = size.max(axis=0) / np.where(usual > 0, usual, np.inf)
        if not finite.all() or jumps.max() > 1e3:
            parts.append("its Jacobian is not smooth: at some of the data's states its slopes "
                         "are infinite or a thousand times their usual size (a square root or "
                         "an abs at zero, a switch)")
    return ("; ".join(parts) + ". Write the fast part quasi-static at the sample rate (a "
            "velocity from the force balance, a pressure at its steady value) or give the "
            "non-smooth terms a smooth core (an orifice laminar near zero pressure drop)")
