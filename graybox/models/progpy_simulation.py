"""Telemetry of a fleet simulated by a ProgPy model itself (its simulation, its noise).

Assets that share an input profile run in one vectorised ProgPy simulation (one state column
per asset); per-asset state changes (a wear rate switched on at some time) make the faults,
and per-asset profiles with stops (:func:`stopped_load`) make intermittent operation. The
result is one frame per asset in the telemetry store's shape: a
``timestamp`` column, the ProgPy outputs (with ProgPy's measurement noise) and the inputs,
named by the white box's column map.
"""
from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from graybox.models.progpy import ProgPyModel

#: asset -> [(seconds after start, {ProgPy state: new value}), ...]
StateChanges = Mapping[str, Sequence[tuple[float, Mapping[str, float]]]]
#: ``load(t) -> {input: value}``, seconds since the start
Load = Callable[[float], Mapping[str, float]]


def simulate_progpy_fleet(model: ProgPyModel, assets: Sequence[str], start: pd.Timestamp,
                          duration: float, load: Load | Mapping[str, Load], *,
                          sample_interval: float = 1.0, step: float = 0.25,
                          process_noise=0.0, measurement_noise=0.0,
                          initial: Mapping[str, float] | None = None,
                          changes: StateChanges | None = None, seed: int = 0
                          ) -> dict[str, pd.DataFrame]:
    """Simulate ``assets`` with the white box's ProgPy model and return their telemetry.

    Parameters
    ----------
    model : ProgPyModel
        The white box; its ProgPy parameter overrides and column map are used.
    assets : sequence of str
    start : Timestamp
        UTC time of the first sample.
    duration : float
        Seconds simulated (a whole multiple of ``sample_interval``).
    load : callable or mapping of str to callable
        ``load(t) -> {input: value}``, seconds since ``start`` (ProgPy's future loading), for
        every asset or per asset. Assets given the same callable run in one vectorised
        simulation; each other callable costs a simulation of its own (ProgPy's pump cannot
        take per-asset inputs in one).
    sample_interval : float, default 1.0
        Seconds between saved samples (ProgPy's ``save_freq``).
    step : float, default 0.25
        ProgPy's integration step ``dt`` (a divisor of ``sample_interval``).
    process_noise, measurement_noise : float or mapping, default 0.0
        ProgPy's noise arguments (per state and per output when mappings).
    initial : mapping of str to float, optional
        ProgPy state values replacing those of ``initialize`` (e.g. warm temperatures, to
        start near the operating point), for every asset.
    changes : mapping, optional
        Per asset, state values set at given seconds after ``start`` (e.g. a wear rate).
    seed : int, default 0
        Seeds ProgPy's noise (the first group of assets sharing a load with ``seed`` itself,
        each further group with a seed derived from it); numpy's global generator is restored
        afterwards.

    Returns
    -------
    dict of str to DataFrame
        Per asset, ``timestamp`` and one column per ProgPy output and input.
    """
    samples = round(duration / sample_interval)
    if samples < 1 or abs(samples * sample_interval - duration) > 1e-9 * duration:
        raise ValueError(f"duration {duration} s is not a whole multiple of {sample_interval} s")
    changes = changes or {}
    unknown = sorted(set(changes) - set(assets))
    if unknown:
        raise ValueError(f"state changes name assets that are not simulated: {unknown}")
    if callable(load):
        loads = {asset: load for asset in assets}
    else:
        missing = [asset for asset in assets if asset not in load]
        if missing:
            raise ValueError(f"no load for the simulated assets {missing}")
        loads = {asset: load[asset] for asset in assets}
    groups: dict[int, list[str]] = {}
    for asset in assets:
        groups.setdefault(id(loads[asset]), []).append(asset)
    frames = {}
    for k, members in enumerate(groups.values()):
        group_seed = seed if k == 0 else _derived_seed(seed, k)
        frames.update(_simulate_group(
            model, members, start, duration, loads[members[0]], sample_interval=sample_interval,
            step=step, process_noise=process_noise, measurement_noise=measurement_noise,
            initial=initial, changes={a: changes[a] for a in members if a in changes},
            seed=group_seed))
    return {asset: frames[asset] for asset in assets}


def _simulate_group(model: ProgPyModel, assets: Sequence[str], start: pd.Timestamp,
                    duration: float, load: Load, *, sample_interval: float, step: float,
                    process_noise, measurement_noise, initial: Mapping[str, float] | None,
                    changes: StateChanges, seed: int) -> dict[str, pd.DataFrame]:
    """One vectorised ProgPy simulation of ``assets`` under one input profile."""
    plant = model.make_progpy(process_noise=process_noise, measurement_noise=measurement_noise)
    cuts = sorted({float(t) for steps in changes.values() for t, _ in steps if 0 < t < duration})
    bounds = [0.0, *cuts, float(duration)]

    saved = np.random.get_state()
    np.random.seed(seed)   # ProgPy draws its noise from numpy's global generator
    try:
        first = plant.initialize(plant.InputContainer(dict(load(0.0))))
        for name, value in (initial or {}).items():
            if name not in plant.states:
                raise ValueError(f"initial names {name!r}, not a ProgPy state "
                                 f"({', '.join(plant.states)})")
            first[name] = float(value)
        state = plant.StateContainer(np.repeat(np.asarray(first.matrix, dtype=float),
                                               len(assets), axis=1))
        times, outputs, inputs = [], [], []
        for begin, end in zip(bounds[:-1], bounds[1:]):
            _apply_changes(state, assets, changes, begin)
            # simulate_to is simulate_to_threshold with no event stopping it (ProgPy 1.9's
            # simulate_to says so through a deprecated argument, which warns)
            result = plant.simulate_to_threshold(
                lambda t, x=None: plant.InputContainer(dict(load(t))),
                horizon=end - begin, event_strategy=lambda thresholds: False,
                dt=step, save_freq=sample_interval, t0=begin, x=state)
            skip = 1 if times else 0   # a segment starts where the last one ended
            # (ProgPy's SimResult does not slice: convert to lists first)
            times.extend(list(result.times)[skip:])
            outputs.extend(np.asarray(z.matrix, dtype=float) for z in list(result.outputs)[skip:])
            inputs.extend(np.asarray(u.matrix, dtype=float) for u in list(result.inputs)[skip:])
            state = result.states[-1]
    finally:
        np.random.set_state(saved)

    offsets = np.round(np.asarray(times) / sample_interval) * sample_interval
    stamps = pd.Timestamp(start) + pd.to_timedelta(offsets, unit="s")
    output_names = [_column(model, name) for name in plant.outputs]
    input_names = [model.columns.get(name, name) for name in plant.inputs]
    frames = {}
    for index, asset in enumerate(assets):
        columns = {"timestamp": stamps}
        for k, name in enumerate(output_names):
            columns[name] = [z[k, index] for z in outputs]
        for k, name in enumerate(input_names):
            columns[name] = [u[k, 0] for u in inputs]
        frames[asset] = pd.DataFrame(columns)
    return frames


def _derived_seed(seed: int, group: int) -> int:
    """A seed of its own for the ``group``-th group of assets (not another run's ``seed``)."""
    return int(np.random.SeedSequence([seed, group]).generate_state(1)[0])


def _column(model: ProgPyModel, output: str) -> str:
    """An output named like a state goes to that state's column; others keep their name."""
    return model.columns.get(output, output)


def _apply_changes(state, assets, changes: StateChanges, at: float) -> None:
    """Set the state values of the changes due at ``at`` (those before 0 count at 0)."""
    names = list(state.keys())
    for index, asset in enumerate(assets):
        for when, values in changes.get(asset, ()):
            if max(float(when), 0.0) != at:
                continue
            for name, value in values.items():
                if name not in names:
                    raise ValueError(f"asset {asset}: {name!r} is not a ProgPy state "
                                     f"({', '.join(names)})")
                state.matrix[names.index(name), index] = float(value)


def pump_cycle_load(t: float, period: float = 1800.0, voltage: float = 471.2389,
                    step: float = 40.0, ramp: float = 100.0) -> dict[str, float]:
    """Inputs of ProgPy's ``CentrifugalPump`` over a duty cycle, after ProgPy's own example.

    Low voltage for the first half of each ``period`` less ``ramp``, a linear ramp up by
    ``step`` volts over ``ramp`` seconds, high voltage, and a ramp back down at the end; the
    synchronous speed is 0.8 times the voltage, the pressures and ambient temperature hold.
    ProgPy's example uses a 3600 s cycle and a 100 V step.

    Parameters
    ----------
    t : float
        Seconds since the start.

    Returns
    -------
    dict
        ``Tamb`` (K), ``V`` (V), ``pdisch`` and ``psuc`` (Pa), ``wsync`` (rad/s).
    """
    phase = t % period
    half = period / 2
    if phase < half - ramp:
        level = 0.0
    elif phase < half:
        level = (phase - (half - ramp)) / ramp
    elif phase < period - ramp:
        level = 1.0
    else:
        level = 1.0 - (phase - (period - ramp)) / ramp
    v = voltage + step * level
    return {"Tamb": 290.0, "V": v, "pdisch": 928654.0, "psuc": 239179.0, "wsync": 0.8 * v}


def pump_stops(duration: float, seed: int | Sequence[int],
               run: tuple[float, float] = (1200.0, 2700.0),
               stop: tuple[float, float] = (300.0, 900.0)) -> list[tuple[float, float]]:
    """A plant's stops of one pump: operating periods and stops of random lengths alternate.

    Parameters
    ----------
    duration : float
        Seconds covered; the pump runs from 0.
    seed : int or sequence of int
        Seeds the lengths (one pump's schedule), as :func:`numpy.random.default_rng` takes it.
    run, stop : (float, float)
        Shortest and longest operating period and stop, in seconds (uniform, whole seconds).

    Returns
    -------
    list of (float, float)
        The stops as ``[begin, end)`` seconds, in time order, each inside ``[0, duration)``.
    """
    rng = np.random.default_rng(seed)
    stops, t = [], 0.0
    while True:
        t += float(np.round(rng.uniform(*run)))
        if t >= duration:
            return stops
        end = t + float(np.round(rng.uniform(*stop)))
        stops.append((t, min(end, float(duration))))
        t = end


def stopped_load(load: Load, stops: Sequence[tuple[float, float]]) -> Load:
    """``load`` with the pump's motor off (``V = 0``) during ``stops``.

    The other inputs keep their values (the synchronous speed stays non-zero, so ProgPy's
    slip stays finite): without torque the pump spins down by its own dynamics, and at the
    end of a stop it restarts from whatever speed it reached, a direct-on-line start.

    Parameters
    ----------
    load : callable
        The inputs while running, ``load(t) -> {input: value}``.
    stops : sequence of (float, float)
        ``[begin, end)`` seconds in which the motor is off.

    Returns
    -------
    callable
        ``load(t)`` with ``V`` 0 inside a stop.
    """
    begins = np.array([b for b, _ in stops], dtype=float)
    ends = np.array([e for _, e in stops], dtype=float)

    def inputs(t: float) -> dict[str, float]:
        values = dict(load(t))
        k = int(np.searchsorted(begins, t, side="right")) - 1
        if k >= 0 and t < ends[k]:
            values["V"] = 0.0
        return values

    return inputs
