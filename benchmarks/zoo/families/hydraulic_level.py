"""Two tanks under closed-loop level control at 1 Hz, 24 h a day.

True plant: a pump (flow ``q`` following its command ``u`` with a 3-s lag and a head-dependent
pump curve) fills tank 1; tank 1 drains into tank 2 through a pipe (Torricelli:
``q12 = k12 sqrt(h1 - h2)``); tank 2 drains to the consumers through a demand valve of
opening ``v`` (``q_out = k_d v sqrt(h2)``). A PI controller sets ``u`` to hold tank 2 at 1 m;
the consumers' demand changes in steps through the day (a daily pattern that differs by day),
and the pipe's friction drifts slowly. Telemetry at 1 Hz: both levels (1 mm resolution),
the pump flow meter (L/s), the pump command and the demand valve opening.

The white box a user writes (:class:`TwoTankWhiteBox`): the same three states and two inputs,
but with flows linear in the levels (``q12 = g12 (h1 - h2)``, ``q_out = g_d v h2``) and a
linear pump ``q_max u``, linearised at a nominal point 10-20 % off this fleet's.
"""
from __future__ import annotations

import numpy as np

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 1.0
SUBSTEPS = 4
WARMUP = 1800


class TwoTankWhiteBox(WhiteBoxModel):
    """Levels ``h1``, ``h2`` (m) and pump flow ``q`` (L/s); inputs pump command ``u`` and demand
    valve opening ``v`` (0-1). Linear flow laws."""

    states = ("h1", "h2", "q")
    inputs = ("u", "v")
    controlled_inputs = ("u",)  # the level loop's pump command
    default_parameters = {"area1": 0.55, "area2": 0.45, "g12": 9.0, "g_demand": 4.0,
                          "q_max": 5.5, "pump_lag": 2.5}

    def derivatives(self, x, u):
        p = self.parameters
        h1, h2, q = x[..., 0], x[..., 1], x[..., 2]
        command, valve = u[..., 0], u[..., 1]
        q12 = p["g12"] * (h1 - h2)                        # L/s
        out = p["g_demand"] * valve * h2
        return np.stack([(q - q12) / (1000 * p["area1"]), (q12 - out) / (1000 * p["area2"]),
                         (p["q_max"] * command - q) / p["pump_lag"]], axis=-1)


class HydraulicLevel(Family):
    name = "hydraulic_level"
    title = "Two tanks, level control (1 Hz)"
    description = ("pump with lag and head-dependent curve, Torricelli pipe and demand valve, PI "
                   "level loop, stepwise daily demand; white box: linear flow laws, 10-20 % off")
    spec = "benchmarks.zoo.families.hydraulic_level:TwoTankWhiteBox"
    columns = {"h1": "level_1", "h2": "level_2", "q": "pump_flow", "u": "pump_command",
               "v": "demand_valve"}
    sample_interval = DT
    held_out = False
    channels = ("level_1", "level_2", "pump_flow", "pump_command", "demand_valve")
    faults = (
        FaultKind("leak", "a leak from tank 1 growing over 4 h to m of the mean flow", (0.04, 0.1)),
        FaultKind("clogging", "pipe conductance down by m (relative)", (0.1, 0.25)),
        FaultKind("meter_gain", "flow meter reads m high (relative)", (0.03, 0.08)),
        FaultKind("level_noise", "tank-2 level sensor noise x (1 + m)", (0.5, 2.0)),
    )

    def true_parameters(self, rng):
        return {"area1": spread(rng, 0.5, 0.03), "area2": spread(rng, 0.5, 0.03),
                "k12": spread(rng, 4.5, 0.05), "k_demand": spread(rng, 4.0, 0.05),
                "q_max": spread(rng, 6.0, 0.03), "head": spread(rng, 6.0, 0.05),
                "pump_lag": spread(rng, 3.0, 0.05)}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        n, t, hour, total = self.clock(WARMUP)
        # demand: a daily pattern (morning and evening peaks) scaled per day, held in steps
        pattern = 0.45 + 0.2 * np.exp(-((hour - 7.5) / 1.5) ** 2) + 0.25 * np.exp(-((hour - 19) / 2) ** 2)
        level = batch.uniform(0.8, 1.2)[:, None] * pattern[None, :]
        step = np.stack([np.repeat(rng.uniform(-0.12, 0.12, total // 300 + 1), 300)[:total]
                         for rng in batch.rngs])
        valve = np.clip(level + step, 0.15, 0.95)
        friction = 1 + 0.03 * smooth_noise(batch, total, 3600 / DT)   # pipe friction drifts
        leak = batch.active("leak", t) * np.clip((t[None, :] - batch.onset[:, None]) / 14400, 0, 1)
        k12 = p["k12"][:, None] * friction * (1 - batch.active("clogging", t))
        h1 = np.full(len(batch), 1.2)
        h2 = np.full(len(batch), 1.0)
        q = np.full(len(batch), 2.5)
        integral = np.full(len(batch), 0.45)
        shocks = batch.normal((total, 2), 1.0)
        out = {k: np.empty((len(batch), n)) for k in ("h1", "h2", "q", "u")}
        h = DT / SUBSTEPS
        for k in range(total):
            error = 1.0 - h2
            integral = np.clip(integral + 0.004 * error * DT, 0.0, 1.0)
            command = np.clip(0.8 * error + integral, 0.0, 1.0)
            for _ in range(SUBSTEPS):
                q12 = k12[:, k] * np.sign(h1 - h2) * np.sqrt(np.abs(h1 - h2))
                q_out = p["k_demand"] * valve[:, k] * np.sqrt(np.maximum(h2, 0.0))
                target = p["q_max"] * command * np.sqrt(np.clip(1 - h1 / p["head"], 0.0, 1.0))
                lost = leak[:, k] * 2.5 * np.sqrt(np.maximum(h1, 0.0) / 1.2)
                h1 = h1 + h * (q - q12 - lost) / (1000 * p["area1"])
                h2 = h2 + h * (q12 - q_out) / (1000 * p["area2"])
                q = q + h * (target - q) / p["pump_lag"]
            q = q + 0.01 * shocks[:, k, 0]                        # turbulence at the pump
            h2 = h2 + 2e-5 * shocks[:, k, 1]                      # sloshing
            if k >= WARMUP:
                out["h1"][:, k - WARMUP], out["h2"][:, k - WARMUP] = h1, h2
                out["q"][:, k - WARMUP], out["u"][:, k - WARMUP] = q, command
        day = slice(WARMUP, total)
        noise2 = 0.002 * (1 + batch.active("level_noise", t[day]))
        gain = 1 + batch.active("meter_gain", t[day])
        return {"level_1": quantise(out["h1"] + batch.normal((n,), 0.002), 0.001),
                "level_2": quantise(out["h2"] + batch.normal((n,), 1.0) * noise2, 0.001),
                "pump_flow": quantise(out["q"] * gain + batch.normal((n,), 0.02), 0.01),
                "pump_command": np.round(out["u"], 4),
                "demand_valve": np.round(valve[:, day], 3)}


FAMILY = HydraulicLevel()
