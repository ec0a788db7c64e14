"""Telemetry of a linear white box's true plant, for the flow tests of multichannel and
intermittent assets.

The plant is the model's own ``dx/dt = A x + B u`` plus white process noise, integrated
exactly over each sample with the inputs linear between samples (the first-order hold the
one-step residual assumes), then observed with white sensor noise. Inputs are not noisy:
the setpoint is a command, held for minutes at a time.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd
from flowtest_config import config_text
from scipy.linalg import expm

from graybox.models import LinearStateSpace

#: the PumpLoop pumps (``P-*``) of the multichannel and intermittent flow tests
PUMPS = '''[classes.pump]
model = "graybox.models:PumpLoop"
assets = ["P-*"]'''


def pump_config(root, db, extra: str = "") -> str:
    """A fleet.toml of the pumps (not retried), telemetry at ``root``, store the SQLite file
    ``db``; ``extra`` ends the pump class (e.g. ``grid = { intermittent = true }``)."""
    return config_text(root, db, retries=0, classes=PUMPS, extra=extra)


def discretize(model: LinearStateSpace, dt: float, process_std) -> tuple:
    """``(Phi, Gamma0, Gamma1, chol(Q))`` of ``x[k+1] = Phi x[k] + Gamma0 u[k] +
    Gamma1 (u[k+1] - u[k]) / dt + w[k]``, ``w ~ N(0, Q)`` (Van Loan)."""
    A, B = model.A, model.B
    n, m = B.shape
    block = np.zeros((n + 2 * m, n + 2 * m))
    block[:n, :n], block[:n, n:n + m] = A, B
    block[n:n + m, n + m:] = np.eye(m)
    E = expm(block * dt)
    phi, gamma0, gamma1 = E[:n, :n], E[:n, n:n + m], E[:n, n + m:]
    qc = np.diag(np.asarray(process_std, float) ** 2)
    loan = expm(np.block([[-A, qc], [np.zeros((n, n)), A.T]]) * dt)
    q = loan[n:, n:].T @ loan[:n, n:]
    return phi, gamma0, gamma1, np.linalg.cholesky((q + q.T) / 2)


def simulate(model: LinearStateSpace, u: np.ndarray, dt: float, process_std, sensor_std,
             rng: np.random.Generator) -> np.ndarray:
    """Observed states (T, n_states) under inputs ``u`` (T, n_inputs), from equilibrium."""
    phi, gamma0, gamma1, chol = discretize(model, dt, process_std)
    x = -np.linalg.solve(model.A, model.B @ u[0])
    du = np.diff(u, axis=0, append=u[-1:]) / dt
    drive = u @ gamma0.T + du @ gamma1.T
    noise = rng.standard_normal((len(u), len(x))) @ chol.T
    out = np.empty((len(u), len(x)))
    for k in range(len(u)):
        out[k] = x
        x = phi @ x + drive[k] + noise[k]
    return out + rng.standard_normal(out.shape) * np.asarray(sensor_std, float)


def holds(n: int, dt: float, rng: np.random.Generator, low: float, high: float,
          shortest: float, longest: float) -> np.ndarray:
    """A setpoint that holds each value for ``shortest`` to ``longest`` seconds."""
    values = np.empty(n)
    i = 0
    while i < n:
        length = int(rng.uniform(shortest, longest) / dt)
        values[i:i + length] = round(rng.uniform(low, high), 2)
        i += length
    return values


def pump_period(model: LinearStateSpace, start: pd.Timestamp, seconds: float, dt: float,
                rng: np.random.Generator, longest_hold: float = 900.0,
                inlet_offset: float = 0.0) -> pd.DataFrame:
    """One operating period of a :class:`~graybox.models.PumpLoop`: the pressure setpoint
    held 5 to ``longest_hold / 60`` minutes at a time, a slowly varying inlet temperature
    (``inlet_offset`` degC above the daily cycle: a warmer day)."""
    n = int(seconds / dt)
    t = np.arange(n) * dt
    day_seconds = ((start - start.normalize()).total_seconds() + t)
    setpoint = holds(n, dt, rng, 4.0, 8.0, 300.0, longest_hold)
    inlet = 18.0 + inlet_offset + 4.0 * np.sin(2 * np.pi * day_seconds / 86_400.0)
    u = np.column_stack([setpoint, inlet])
    x = simulate(model, u, dt, process_std=[0.05, 0.05, 0.02, 0.01],
                 sensor_std=[0.01, 0.01, 0.005, 0.005], rng=rng)
    frame = pd.DataFrame(x, columns=list(model.states))
    frame["pdisch_setpoint"], frame["inlet_temperature"] = setpoint, inlet
    frame.insert(0, "timestamp", start + pd.to_timedelta(t, unit="s"))
    return frame


def pump_days(start: pd.Timestamp, days: int, ran: dict[int, float], dt: float = 5.0,
              seed: int = 7, inlet_offsets: Sequence[float] = ()) -> pd.DataFrame:
    """``days`` days of a healthy :class:`~graybox.models.PumpLoop` from ``start``, sampled
    every ``dt`` seconds: 90 minutes from 06:00 and from 13:00, except on the days of ``ran``
    (day -> seconds), which run that long from 09:00 (a machine that ran too little); day
    ``k``'s inlet ``inlet_offsets[k]`` degC warmer (none without them)."""
    from graybox.models import PumpLoop

    rng = np.random.default_rng(seed)
    frames = []
    for k in range(days):
        day = start + pd.Timedelta(days=k)
        periods = ([(pd.Timedelta("9h"), ran[k])] if k in ran else
                   [(pd.Timedelta("6h"), 5_400.0), (pd.Timedelta("13h"), 5_400.0)])
        warmer = inlet_offsets[k] if k < len(inlet_offsets) else 0.0
        frames += [pump_period(PumpLoop(), day + offset, seconds, dt, rng,
                               inlet_offset=warmer) for offset, seconds in periods]
    return pd.concat(frames, ignore_index=True)


def fit_pump_baseline(tmp_path, frame: pd.DataFrame, start: pd.Timestamp, days: int, capsys,
                      extra: str = "") -> dict:
    """``fleet-health baseline fit --all --json`` over ``days`` from ``start`` of one pump
    ``P-001`` whose telemetry is ``frame`` (``extra`` ends its class); the asset's result."""
    import json

    from flows.cli import main
    from graybox.telemetry import write_telemetry

    root = tmp_path / "telemetry"
    write_telemetry(root, "P-001", frame)
    config = tmp_path / "fleet.toml"
    config.write_text(pump_config(root, tmp_path / "mlflow.db", extra))
    status = main(["--config", str(config), "baseline", "fit", "--all", "--start",
                   start.isoformat(), "--end", (start + pd.Timedelta(days=days)).isoformat(),
                   "--json"])
    out = capsys.readouterr()
    assert status == 0, out.err
    [asset] = json.loads(out.out)["assets"]
    return asset
