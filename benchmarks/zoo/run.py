"""One family's zoo run: simulate, write, read, baseline, score nights, count.

Protocol (the same for every family, with the product's defaults only): ``healthy_assets``
vehicles, each with its own true parameters and random streams, run healthy for
``baseline_days`` days (their baseline, calibrated for 1 % false alarms per asset-night) and
then ``nights`` nights, each scored as the nightly flow scores it: a candidate fitted on the
night and the ``candidate_nights - 1`` before it (never before the baseline's end), an alarm
when any channel and tier exceeds its epsilon. For every fault kind and magnitude,
``faulty_per_cell`` faulty assets share a vehicle's seed (so its baseline: their telemetry is
the vehicle's up to the onset, a counterfactual pair) and have the fault from an onset inside
the first night; they are scored on the first three nights. Telemetry goes through the store
layout and ``graybox.read_window`` with the family's grid policy, as the flows read it.
"""
from __future__ import annotations

import collections
import tempfile
import time
from typing import Callable, Mapping

import numpy as np
import pandas as pd

import graybox as gb
from graybox.calibration import DEFAULT_FALSE_ALARM_RATE
from graybox.exceptions import ShortWindowsError
from graybox.telemetry.writing import write_telemetry

from benchmarks.detection.grid import trailing_nights
from benchmarks.detection.metrics import rate
from benchmarks.zoo.family import AssetPlan, Family
from benchmarks.zoo.report import idle_read
from flows.config.settings import NightlySettings

START = pd.Timestamp("2026-01-05", tz="UTC")
#: nights after the onset in which a fault counts as detected
HORIZON = 3


def plan_fleet(family: Family, healthy_assets: int, faulty_per_cell: int, seed: int,
               baseline_days: int) -> tuple[list[AssetPlan], list[AssetPlan]]:
    """The healthy vehicles and the faulty assets (each on a vehicle's seed)."""
    prefix = family.name.upper().replace("_", "")[:6]
    vehicles = [AssetPlan(f"{prefix}-{i:03d}", seed * 1000 + i) for i in range(1, healthy_assets + 1)]
    rng = np.random.default_rng([seed, 17])
    faulty, slot = [], 0
    night0 = START + pd.Timedelta(days=baseline_days)
    for kind in family.faults:
        for size, magnitude in zip(("small", "large"), kind.magnitudes):
            for _ in range(faulty_per_cell):
                vehicle = vehicles[slot % len(vehicles)]
                slot += 1
                onset = night0 + pd.Timedelta(hours=float(rng.uniform(2.0, 20.0)))
                faulty.append(AssetPlan(f"{vehicle.asset_id}-{kind.name}-{size}", vehicle.seed,
                                        kind, magnitude, onset.round("s")))
    return vehicles, faulty


def vehicles_of(vehicles: list[AssetPlan], faulty: list[AssetPlan]) -> dict[str, str]:
    """Each asset's vehicle, whose baseline it is compared with: a healthy vehicle its own, a
    faulty asset the vehicle whose seed it shares."""
    out = {v.asset_id: v.asset_id for v in vehicles}
    out.update({f.asset_id: next(v.asset_id for v in vehicles if v.seed == f.seed)
                for f in faulty})
    return out


def asset_nights(vehicles: list[AssetPlan], faulty: list[AssetPlan], nights: int,
                 baselines: Mapping[str, object], windows: Mapping[tuple[str, int], object],
                 baseline_days: int, span: int):
    """The asset-nights a zoo run scores: every healthy vehicle's ``nights`` nights and every
    faulty asset's first :data:`HORIZON`, of the assets whose vehicle has a baseline.

    Yields
    ------
    plan : AssetPlan
    vehicle : str
        The asset's vehicle, whose baseline it is compared with (:func:`vehicles_of`).
    candidates : list of (int, list of int)
        Per night (0 is the first after the baseline) the days of its candidate that have a
        window: the night and the ``span - 1`` before it, never before the baseline's end
        (the night's own may be missing).
    """
    vehicle_of = vehicles_of(vehicles, faulty)
    for plan, count in [(v, nights) for v in vehicles] + [(f, HORIZON) for f in faulty]:
        vehicle = vehicle_of[plan.asset_id]
        if vehicle in baselines:
            yield plan, vehicle, [
                (night, [d for d in trailing_nights(baseline_days + night, span, baseline_days)
                         if (plan.asset_id, d) in windows])
                for night in range(count)]


def run_family(family: Family, healthy_assets: int = 30, baseline_days: int = 5,
               nights: int = 10, faulty_per_cell: int = 3, seed: int = 1,
               false_alarm_rate: float = DEFAULT_FALSE_ALARM_RATE, candidate_nights: int | None = None,
               progress: Callable[[str], None] | None = None,
               frames: Mapping[str, pd.DataFrame] | None = None) -> dict:
    """Run one family; returns the figures and per-asset-night rows.

    Parameters
    ----------
    family : Family
    healthy_assets, baseline_days, nights : int
        Healthy vehicles, their baseline days and their scored nights.
    faulty_per_cell : int
        Faulty assets per fault kind and magnitude (scored on their first three nights).
    seed : int
    false_alarm_rate : float
        The baselines' calibration target per asset-night (the product's default).
    candidate_nights : int, optional
        Nights per candidate; default the product's ``[nightly] candidate_nights``.
    progress : callable, optional
        Called with a line per stage.
    frames : mapping, optional
        The telemetry of every asset :func:`plan_fleet` plans (the faulty ones only with
        ``nights >= 3``), days as simulated here from :data:`START`, simulated beforehand
        (with other telemetry of the family: :meth:`Family.simulate_together`); default
        simulated here.

    Returns
    -------
    dict
    """
    say = progress or (lambda line: None)
    span = candidate_nights or NightlySettings().candidate_nights
    model = gb.load_model(family.spec, dict(family.parameters), dict(family.columns))
    policy = gb.GridPolicy(**dict(family.grid))
    vehicles, faulty = plan_fleet(family, healthy_assets, faulty_per_cell, seed, baseline_days)
    clock = {}
    began = time.perf_counter()
    if not (faulty and nights >= HORIZON):
        faulty = []
    if frames is None:
        frames = family.simulate(vehicles, START, baseline_days + nights)
        if faulty:
            frames.update(family.simulate(faulty, START, baseline_days + HORIZON,
                                          first_day=baseline_days))
    else:
        missing = sorted({p.asset_id for p in vehicles + faulty} - set(frames))
        if missing:
            raise ValueError(f"frames: no telemetry of {missing}")
        frames = {p.asset_id: frames[p.asset_id] for p in vehicles + faulty}
    clock["simulation"] = time.perf_counter() - began
    say(f"{family.name}: simulated {len(vehicles)} vehicles x {baseline_days + nights} days and "
        f"{len(faulty)} faulty assets in {clock['simulation']:.0f} s")

    began = time.perf_counter()
    store = tempfile.TemporaryDirectory(prefix=f"zoo-{family.name}-")
    root = store.name
    for asset, frame in frames.items():
        write_telemetry(root, asset, frame)
    del frames
    # a new baseline reads its days as the baseline flow does (a channel may hold a value up
    # to 6 h; the holds are recorded), its nights as the nightly flow does (with the holds its
    # baseline saw: GridPolicy.with_holds)
    windows, failed_reads = read_days(root, model, policy, [
        (v.asset_id, day) for v in vehicles for day in range(baseline_days)], holds=True)
    clock["write_read"] = time.perf_counter() - began

    began, cpu = time.perf_counter(), time.process_time()
    days_read = baseline_days_read([v.asset_id for v in vehicles], baseline_days, windows,
                                   failed_reads)
    # fewer days than a baseline needs (none at all too) fail in fit_baselines, as they do
    # in the baseline flow
    ready = [v for v in vehicles if v.asset_id in days_read]
    requests = [gb.FitRequest(model, [windows[v.asset_id, d] for d in days_read[v.asset_id]],
                              asset_id=v.asset_id, seed=i) for i, v in enumerate(ready)]
    fitted = gb.fit_baselines(requests, false_alarm_rate=false_alarm_rate)
    baselines, failed_baselines = {}, {}
    for vehicle, result in zip(ready, fitted):
        if isinstance(result, gb.GrayBoxError):
            failed_baselines[vehicle.asset_id] = str(result)
        else:
            baselines[vehicle.asset_id] = result
    clock["baselines"] = time.perf_counter() - began
    clock["baselines_cpu"] = time.process_time() - cpu
    say(f"{family.name}: {len(baselines)} of {len(vehicles)} baselines in "
        f"{clock['baselines']:.0f} s" + (f"; failed: {failed_baselines}" if failed_baselines else ""))

    began = time.perf_counter()
    vehicle_of = vehicles_of(vehicles, faulty)
    for plan, count in [(v, nights) for v in vehicles] + [(f, HORIZON) for f in faulty]:
        base = baselines.get(vehicle_of[plan.asset_id])
        read, failed = read_days(root, model, policy.with_holds(
            base[0].holds if base else None), [(plan.asset_id, baseline_days + night)
                                               for night in range(count)])
        windows.update(read)
        failed_reads.update(failed)
    store.cleanup()
    clock["write_read"] += time.perf_counter() - began

    jobs = []
    for plan, base, candidates in asset_nights(vehicles, faulty, nights, baselines, windows,
                                               baseline_days, span):
        for night, days in candidates:
            if (plan.asset_id, baseline_days + night) not in windows:
                continue
            jobs.append((plan, night, base,
                         gb.FitRequest(model, [windows[plan.asset_id, d] for d in days],
                                       baseline=baselines[base][0], asset_id=plan.asset_id)))
    began, cpu = time.perf_counter(), time.process_time()
    scored = gb.fit_signatures([request for *_, request in jobs])
    clock["nights"] = time.perf_counter() - began
    clock["nights_cpu"] = time.process_time() - cpu

    rows, failed_nights, calm_nights = [], {}, {}
    for (plan, night, base, _), candidate in zip(jobs, scored):
        if isinstance(candidate, gb.GrayBoxError):
            settled = calm_nights if night_not_operating(candidate) else failed_nights
            settled[f"{plan.asset_id} night {night}"] = str(candidate)
            continue
        signature, calibration = baselines[base]
        drift = gb.compute_drift(candidate, signature, calibration)
        exceeded = [e for e in drift.entries if e.exceeded]
        night_start = START + pd.Timedelta(days=baseline_days + night)
        rows.append({
            "asset": plan.asset_id, "night": night,
            "fault": plan.fault.name if plan.fault else "",
            "size": plan.size,
            "after_onset": plan.onset is not None and plan.onset < night_start + pd.Timedelta(days=1),
            "alarm": bool(exceeded),
            "exceeded": ";".join(f"{e.channel}/{e.tier}" for e in exceeded),
            "max_ratio": drift.largest.ratio if drift.largest else 0.0,
            "moved": {f"{e.channel}/{e.tier}": [c.name for c in e.top_changes[:2]]
                      for e in exceeded},
            "ratios": {f"{e.channel}/{e.tier}": e.ratio for e in drift.entries},
            "outside": {f"{e.channel}/{e.tier}": e.outside for e in drift.entries
                        if e.outside is not None}})
    return summarise(family, rows, {
        "family": family.name, "title": family.title, "held_out": family.held_out,
        "healthy_assets": len(vehicles), "baseline_days": baseline_days, "nights": nights,
        "faulty_per_cell": faulty_per_cell, "candidate_nights": span, "seed": seed,
        "failed_reads": failed_reads, "failed_baselines": failed_baselines,
        "failed_nights": failed_nights, "calm_nights": calm_nights, "clock": clock,
        "baselines_fitted": len(baselines),
        "baseline_asset_days": len(ready) * baseline_days, "scored_nights": len(jobs),
        "nonlinear_needed": sorted({f"{c.channel}" for s, _ in baselines.values()
                                    for c in s.channels if c.structure.nonlinear_needed}),
        "needed_share": (sum(c.structure.nonlinear_needed for s, _ in baselines.values()
                             for c in s.channels) /
                         max(1, sum(len(s.channels) for s, _ in baselines.values()))),
        "analysis_intervals": sorted({s.analysis_step for s, _ in baselines.values()}),
    })


def baseline_days_read(assets: list[str], baseline_days: int, windows: Mapping,
                       failed_reads: Mapping[str, str]) -> dict[str, list[int]]:
    """Per asset whose baseline days read, the days its baseline is fitted on.

    A day the machine did not run (:func:`benchmarks.zoo.report.idle_read`) is left out, as
    the baseline flow leaves it out (too few days left fail the fit, there and in
    :func:`graybox.fit_baselines`); any other failed read leaves the asset out (no
    baseline; the read is counted as a failure).
    """
    out = {}
    for asset in assets:
        missing = [d for d in range(baseline_days) if (asset, d) not in windows]
        if all(idle_read(failed_reads[f"{asset} day {d}"]) for d in missing):
            out[asset] = [d for d in range(baseline_days) if d not in missing]
    return out


def read_days(root, model, policy: gb.GridPolicy, days: list[tuple[str, int]],
              holds: bool = False) -> tuple[dict, dict]:
    """Read asset-days ``(asset, day)`` of the store at ``root`` as the flows read a window.

    Returns
    -------
    windows : dict of (asset, day) to TelemetryWindow
    failed_reads : dict of "asset day N" to the read's error
    """
    windows, failed_reads = {}, {}
    for asset, day in days:
        begin = START + pd.Timedelta(days=day)
        try:
            windows[asset, day] = gb.read_window(
                root, asset, model.required_columns, begin, begin + pd.Timedelta(days=1),
                policy=policy, inputs=model.input_columns, holds=holds)
        except gb.GrayBoxError as error:
            failed_reads[f"{asset} day {day}"] = str(error)
    return windows, failed_reads


def write_and_read(family: Family, model, policy: gb.GridPolicy,
                   frames: Mapping[str, pd.DataFrame], vehicles: set[str], baseline_days: int,
                   nights: int) -> tuple[dict, dict]:
    """Write every asset's telemetry in the store layout and read its days back with one
    ``policy``: a vehicle's baseline days and ``nights``, a faulty asset's :data:`HORIZON`
    nights (the diagnosis harnesses' reading; :func:`run_family` reads a baseline's days and
    its nights as the flows do, with the holds the baseline saw).

    Returns
    -------
    windows : dict of (asset, day) to TelemetryWindow
    failed_reads : dict of "asset day N" to the read's error
    """
    with tempfile.TemporaryDirectory(prefix=f"zoo-{family.name}-") as root:
        days = []
        for asset, frame in frames.items():
            write_telemetry(root, asset, frame)
            first = baseline_days if asset not in vehicles else 0
            last = baseline_days + (HORIZON if first else nights)
            days += [(asset, day) for day in range(first, last)]
        return read_days(root, model, policy, days)


def night_not_operating(error: gb.GrayBoxError) -> bool:
    """Whether a scored night's failed fit is one the product settles as ``not operating``
    rather than as a failure: its window ran too little to fit (:class:`ShortWindowsError`;
    ``flows.pipeline`` leaves such a window out with a note, and the asset is not
    monitored that night). Such a night is neither scored nor counted as a failure."""
    return isinstance(error, ShortWindowsError)


def summarise(family: Family, rows: list[dict], result: dict) -> dict:
    """False alarms, detection per fault kind and magnitude, tiers that alarmed, cost."""
    healthy = [r for r in rows if not r["fault"]]
    result["false_alarms"] = rate(sum(r["alarm"] for r in healthy), len(healthy))
    result["healthy_tiers"] = dict(collections.Counter(
        t for r in healthy for t in r["exceeded"].split(";") if t))
    detection = {}
    for kind in family.faults:
        for size in ("small", "large"):
            assets = sorted({r["asset"] for r in rows if r["fault"] == kind.name and r["size"] == size})
            hits, early, tiers = 0, 0, collections.Counter()
            for asset in assets:
                mine = [r for r in rows if r["asset"] == asset]
                after = [r for r in mine if r["after_onset"]]
                early += any(r["alarm"] for r in mine if not r["after_onset"])
                if any(r["alarm"] for r in after):
                    hits += 1
                    tiers.update(t for t in next(r for r in after if r["alarm"])["exceeded"].split(";"))
            detection[kind.name, size] = {"detected": hits, "assets": len(assets),
                                         "alarmed_before_onset": early, "tiers": dict(tiers)}
    result["detection"] = detection
    for size in ("small", "large"):
        cells = [d for (k, s), d in detection.items() if s == size]
        result[f"detected_{size}"] = (sum(d["detected"] for d in cells),
                                      sum(d["assets"] for d in cells))
    clock = result["clock"]
    result["s_per_baseline_day"] = clock["baselines"] / max(1, result["baseline_asset_days"])
    result["s_per_night"] = clock["nights"] / max(1, result["scored_nights"])
    result["rows"] = rows
    return result
