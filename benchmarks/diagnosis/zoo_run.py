"""The diagnosis run on a plant-zoo family (:mod:`benchmarks.zoo`), reduced.

The zoo's protocol (:func:`benchmarks.zoo.run.plan_fleet`): ``healthy_assets`` vehicles, each
with its own true parameters, healthy for ``baseline_days`` days and then ``nights`` scored
nights; per fault kind and magnitude (small, large), ``faulty_per_cell`` faulty assets on a
vehicle's seed with an onset inside the first night, scored on the first three nights (the
candidate as the nightly flow fits it, on the night and the ``candidate_nights - 1`` before
it). Telemetry through the store layout and ``graybox.read_window`` with the family's grid
policy. The family's coarse white box is tuned to each vehicle on its baseline days by the
baseline's fit (``FitRequest.estimate`` = :data:`benchmarks.diagnosis.expected_zoo.ZOO`'s
``tuned``, as the product tunes it), then ``graybox.diagnose`` runs on
every alarmed night after the onset and on every healthy night, on the telemetry its
candidate was fitted on (the night and the ones before it), as
:func:`flows.pipeline.diagnose_alarm` does.
"""
from __future__ import annotations

import tempfile
import time
from typing import Callable

import pandas as pd

import graybox as gb
from benchmarks.diagnosis.expected_zoo import ZOO
from benchmarks.diagnosis.grid_run import diagnosis_fields
from benchmarks.zoo.family import Family
from benchmarks.zoo.run import HORIZON, START, asset_nights, plan_fleet
from flows.config.settings import NightlySettings
from graybox.telemetry.writing import write_telemetry


def run_family(family: Family, healthy_assets: int = 3, baseline_days: int = 4,
               nights: int = 3, faulty_per_cell: int = 2, seed: int = 1,
               false_alarm_rate: float = 0.01,
               progress: Callable[[str], None] | None = None) -> dict:
    """Diagnose one family's alarmed nights; returns the rows and the clock.

    Parameters
    ----------
    family : Family
        One of :data:`benchmarks.diagnosis.expected_zoo.ZOO`'s families.
    healthy_assets, baseline_days, nights, faulty_per_cell, seed : int
        As :func:`benchmarks.zoo.run.run_family`.
    false_alarm_rate : float
    progress : callable, optional

    Returns
    -------
    dict
        ``family``, ``tuned``, ``rows`` (the grid run's schema; ``model_error`` is
        ``"coarse"``) and ``clock``.
    """
    say = progress or (lambda line: None)
    expectation = ZOO[family.name]
    span = NightlySettings().candidate_nights
    coarse = gb.load_model(family.spec, dict(family.parameters), dict(family.columns))
    policy = gb.GridPolicy(**dict(family.grid))
    vehicles, faulty = plan_fleet(family, healthy_assets, faulty_per_cell, seed, baseline_days)
    clock = {}
    began = time.perf_counter()
    frames = family.simulate(vehicles, START, baseline_days + nights)
    frames.update(family.simulate(faulty, START, baseline_days + HORIZON, first_day=baseline_days))
    clock["simulate_seconds"] = time.perf_counter() - began
    say(f"{family.name}: simulated {len(vehicles)} vehicles and {len(faulty)} faulty assets in "
        f"{clock['simulate_seconds']:.0f} s")
    windows = {}
    healthy_ids = {v.asset_id for v in vehicles}
    with tempfile.TemporaryDirectory(prefix=f"diagnosis-{family.name}-") as root:
        for asset, frame in frames.items():
            write_telemetry(root, asset, frame)
            first = 0 if asset in healthy_ids else baseline_days
            last = baseline_days + (nights if asset in healthy_ids else HORIZON)
            for day in range(first, last):
                begin = START + pd.Timedelta(days=day)
                windows[asset, day] = gb.read_window(
                    root, asset, coarse.required_columns, begin, begin + pd.Timedelta(days=1),
                    policy=policy, inputs=coarse.input_columns)
    del frames

    # the coarse white box tuned as the product tunes it: each baseline's fit estimates the
    # family's parameters on its days (FitRequest.estimate), its candidates use the values
    began = time.perf_counter()
    fitted = gb.fit_baselines([gb.FitRequest(coarse,
                                             [windows[v.asset_id, d] for d in range(baseline_days)],
                                             asset_id=v.asset_id, seed=i,
                                             estimate=tuple(expectation.tuned))
                               for i, v in enumerate(vehicles)], false_alarm_rate=false_alarm_rate)
    baselines = {v.asset_id: result for v, result in zip(vehicles, fitted)
                 if not isinstance(result, gb.GrayBoxError)}
    tuning = {asset: (dict(zip(result[0].tuning.names, result[0].tuning.values))
                      if result[0].tuning is not None else {})   # untuned: the white box as given
              for asset, result in baselines.items()}
    clock["baseline_seconds"] = time.perf_counter() - began
    say(f"{family.name}: {len(baselines)} of {len(vehicles)} baselines (tuned on "
        f"{expectation.tuned}) in {clock['baseline_seconds']:.0f} s")

    jobs = []
    for plan, base, candidates in asset_nights(vehicles, faulty, nights, baselines, windows,
                                               baseline_days, span):
        for night, days in candidates:
            jobs.append((plan, night, base,
                         gb.FitRequest(coarse, [windows[plan.asset_id, d] for d in days],
                                       baseline=baselines[base][0], asset_id=plan.asset_id)))
    began = time.perf_counter()
    candidates = gb.fit_signatures([job[-1] for job in jobs])
    clock["candidate_seconds"] = time.perf_counter() - began
    say(f"{family.name}: {len(jobs)} nights in {clock['candidate_seconds']:.0f} s; diagnosing")

    began = time.perf_counter()
    rows = []
    for (plan, night, base, request), candidate in zip(jobs, candidates):
        signature, calibration = baselines[base]
        fault = plan.fault.name if plan.fault else "healthy"
        expected = expectation.hypothesis(fault) if plan.fault else None
        night_end = START + pd.Timedelta(days=baseline_days + night + 1)
        row = {"family": family.name, "seed": seed, "model_error": "coarse", "vehicle": base,
               "asset": plan.asset_id, "fault": fault, "magnitude": plan.magnitude,
               "size": plan.size, "night": night, "diagnosed": False,
               "after_onset": plan.onset is not None and plan.onset < night_end,
               "expected": None if expected is None else " ".join(expected),
               "tuned": tuning[base]}
        if isinstance(candidate, gb.GrayBoxError):
            row.update(alarm=None, candidate_error=str(candidate)[:200])
            rows.append(row)
            continue
        exceeded = [e for e in gb.compute_drift(candidate, signature, calibration).entries
                    if e.exceeded]
        row.update(alarm=bool(exceeded),
                   exceeded=";".join(f"{e.channel}/{e.tier}" for e in exceeded))
        if (exceeded and row["after_onset"]) or fault == "healthy":
            implied = expectation.magnitude(fault)
            try:
                row.update(diagnosis_fields(signature, request.windows, coarse, expected,
                                            lambda h: implied(h.estimate, h.baseline)))
            except gb.GrayBoxError as error:
                row.update(diagnosis_error=str(error)[:200])
        rows.append(row)
    clock["diagnose_seconds"] = time.perf_counter() - began
    say(f"{family.name}: diagnosed {sum(r['diagnosed'] for r in rows)} nights in "
        f"{clock['diagnose_seconds']:.0f} s")
    return {"family": family.name, "tuned": list(expectation.tuned), "rows": rows,
            "clock": clock, "healthy_assets": healthy_assets, "baseline_days": baseline_days,
            "nights": nights, "faulty_per_cell": faulty_per_cell, "seed": seed,
            "candidate_nights": span, "diagnosis_nights": span,
            "sample_interval": family.sample_interval}
