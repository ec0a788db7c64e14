"""The compute floor of a nightly asset-night: the FLOPs its tiers need, and the machine's
measured matrix-multiply rate that bounds how fast they could possibly run.

The count is a lower bound: every arithmetic operation the method cannot avoid, counted
once (a ``tanh`` as one operation, a shared subexpression once), on the structure the
candidates actually had (embedding dimension, whether the network trains its input weights,
L-BFGS iterations: read from the candidate runs in the MLflow store). The rate is numpy's
float64 (and float32) matrix multiply on square matrices, the best a dense kernel reaches
here; the tiers' small, memory-bound operations reach far less, so the floor is optimistic.
"""
from __future__ import annotations

import sqlite3
import statistics
import time
from dataclasses import asdict, dataclass

import numpy as np

SECONDS_PER_DAY = 86_400
#: one-step residual: RK4 with 2 sub-steps per sample (graybox.residual.one_step_residual)
RK4_SUBSTEPS = 2
#: GasTurbineShaft.derivatives: a*mu - b*w - (c*w + d*w^2), divided by J
DERIVATIVE_FLOPS = 9
#: per RK4 sub-step: 4 derivatives, 3 input interpolations (one shared difference), 3 stage
#: states (x + h/2 k), the weighted sum of the k's and the update
RK4_STEP_FLOPS = 4 * DERIVATIVE_FLOPS + 7 + 6 + 7


@dataclass
class Structure:
    """What the candidates of a night were, as the floor needs it (means over candidates)."""

    samples: float              #: analysis-rate samples per asset-night
    ar_order: float
    embedding_dim: float
    hidden_units: float
    trained_share: float        #: share of networks that train their input weights
    iterations: float           #: L-BFGS iterations per network
    candidates: int

    @classmethod
    def assumed(cls, analysis_interval: float = 7.0) -> "Structure":
        """The brief's structure when no store is at hand: 1 Hz decimated to 7 s, J = 8,
        m = 6, a trained network, 200 iterations (the cap)."""
        return cls(SECONDS_PER_DAY / analysis_interval, 29, 6, 8, 1.0, 200, 0)


def candidate_structure(db_path, window_end: str | None = None) -> Structure | None:
    """Means over the ``role=candidate`` runs of an MLflow SQLite store, only those whose
    recorded window end starts with ``window_end`` (e.g. the day ``"2026-01-05"``) when given
    (None if none)."""
    with sqlite3.connect(f"file:{db_path}?mode=ro", uri=True) as db:
        runs = [r for (r,) in db.execute(
            "SELECT run_uuid FROM tags WHERE key = 'fleet_health.role' AND value = 'candidate'")]
        if window_end is not None:
            ending = {r for (r,) in db.execute(
                "SELECT run_uuid FROM tags WHERE key = 'fleet_health.window_end' AND value LIKE ?",
                [f"{window_end}%"])}
            runs = [r for r in runs if r in ending]
        if not runs:
            return None
        marks = ",".join("?" * len(runs))

        def mean(table: str, pattern: str) -> float:
            values = [float(v) for (v,) in db.execute(
                f"SELECT value FROM {table} WHERE key LIKE ? AND run_uuid IN ({marks})",
                [pattern, *runs])]
            return statistics.fmean(values) if values else float("nan")

        needed = [v == "True" for (v,) in db.execute(
            f"SELECT value FROM params WHERE key LIKE 'channels.%.nonlinear_needed' "
            f"AND run_uuid IN ({marks})", runs)]
    # the default null network keeps its hidden layer fixed unless the baseline needed it
    # per channel (the gas turbine has one: omega)
    return Structure(mean("metrics", "n_samples"), mean("params", "channels.%.ar_order"),
                     mean("params", "channels.%.embedding_dim"),
                     mean("params", "channels.%.hidden_units"),
                     statistics.fmean(needed) if needed else 0.0,
                     mean("metrics", "fit.%.nn_iterations"), len(runs))


def flops_per_asset_night(structure: Structure, sample_interval: float = 1.0) -> dict[str, float]:
    """FLOPs per asset-night by tier (a lower bound; see the module docstring).

    Parameters
    ----------
    structure : Structure
    sample_interval : float
        Telemetry seconds per sample (the residual runs at this rate).

    Returns
    -------
    dict
        ``residual``, ``stationarize_ar``, ``network``, ``noise`` and ``total``.
    """
    native = SECONDS_PER_DAY / sample_interval
    n, p = structure.samples, structure.ar_order
    m, J = structure.embedding_dim, structure.hidden_units
    residual = native * (RK4_SUBSTEPS * RK4_STEP_FLOPS + 1 + 1)    # + subtraction, block mean
    # differencing, autocovariances to lag p, then the innovations filter of order p
    ar = n * 2 + 2 * n * (p + 1) + 2 * n * p
    # fixed hidden layer: activations once, then per evaluation output, loss, gradient of W
    fixed = 2 * n * J * m + n * J + (structure.iterations + 2) * (4 * n * J + 9 * n)
    # trained: every evaluation runs the hidden layer forward and backward
    trained = (structure.iterations + 2) * (4 * n * J * m + 7 * n * J + 9 * n)
    network = structure.trained_share * trained + (1 - structure.trained_share) * fixed
    noise = 20 * n                   # moments, Ljung-Box autocorrelations of a few lags
    tiers = {"residual": residual, "stationarize_ar": ar, "network": network, "noise": noise}
    return {**tiers, "total": sum(tiers.values())}


@dataclass
class MatmulRate:
    """Best-of-``repeat`` numpy matrix-multiply rates in FLOP/s (all cores BLAS uses)."""

    float64: float
    float32: float
    size: int

    def to_dict(self) -> dict:
        return asdict(self)


def matmul_rate(size: int = 1024, repeat: int = 5) -> MatmulRate:
    """Measure ``2 size^3`` FLOPs per product, float64 and float32; the best of ``repeat``."""
    rates = {}
    for dtype in (np.float64, np.float32):
        rng = np.random.default_rng(0)
        a, b = (rng.standard_normal((size, size)).astype(dtype) for _ in range(2))
        a @ b                                           # warm the BLAS threads
        best = min(_seconds(lambda: a @ b) for _ in range(repeat))
        rates[np.dtype(dtype).name] = 2 * size ** 3 / best
    return MatmulRate(rates["float64"], rates["float32"], size)


def _seconds(function) -> float:
    start = time.perf_counter()
    function()
    return time.perf_counter() - start
