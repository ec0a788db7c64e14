"""Run the grid: per seed, simulate the fleet once; per model error, compute every night's
residual, the classic detectors' statistics and thresholds, and the gray box's zeta and
epsilon (one ``fit_baselines`` call for all the seed's baselines, one ``fit_signatures`` call
for all its nightly candidates). Seeds run in parallel worker processes.
"""
from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from benchmarks.detection.classic import DETECTORS, ClassicSettings, calibrate, night_statistics
from benchmarks.detection.grid import (Grid, VehicleData, asset_id, simulate_seed,
                                       trailing_nights)

TIERS = ("linear", "nonlinear", "noise", "level")
CHANNEL = "omega"


def white_box(model_error: float):
    from graybox.models.gas_turbine import GasTurbineShaft
    from graybox.simulation import white_box_parameters

    return GasTurbineShaft(white_box_parameters(model_error), columns={"omega": "shaft_speed"})


@dataclass
class _Night:
    vehicle: VehicleData
    kind: str
    magnitude: float
    night: int
    frame: pd.DataFrame
    candidate_frames: list[pd.DataFrame]   # the night and the N - 1 before it (gray box)


def _nights(grid: Grid, vehicle: VehicleData) -> list[_Night]:
    def trailing(days: dict, night: int) -> list[pd.DataFrame]:
        return [days[d] for d in trailing_nights(night, grid.candidate_nights, grid.baseline_days)]

    healthy = dict(enumerate(vehicle.healthy))
    out = [_Night(vehicle, "healthy", 0.0, d, healthy[d], trailing(healthy, d))
           for d in range(grid.baseline_days, grid.days)]
    for (kind, magnitude), frames in vehicle.faulty.items():
        days = {**healthy, **{grid.onset_day + j: f for j, f in enumerate(frames)}}
        out += [_Night(vehicle, kind, magnitude, d, days[d], trailing(days, d))
                for d in range(grid.onset_day, grid.days)]
    return out


def _classic_rows(grid: Grid, vehicles: list[VehicleData], model, settings: ClassicSettings,
                  residual_cache: dict) -> dict:
    """Classic statistics and thresholds per (vehicle, kind, magnitude, night)."""
    from graybox.residual import residual_frame

    def residual(frame):
        key = id(frame)
        if key not in residual_cache:
            residual_cache[key] = residual_frame(model, frame, "one_step",
                                                 grid.sample_interval)["omega"].to_numpy()
        return residual_cache[key]

    out = {}
    for v in vehicles:
        base = [residual(f) for f in v.healthy[:grid.baseline_days]]
        cal = calibrate(base, grid.sample_interval, settings, grid.false_alarm_rate,
                        seed=v.seed * 1000 + v.vehicle)
        for n in _nights(grid, v):
            stats = night_statistics(residual(n.frame), cal, grid.sample_interval, settings)
            row = {}
            for name in DETECTORS:
                row[f"{name}_stat"] = stats[name]
                row[f"{name}_thr"] = cal.thresholds[name]
            out[(v.vehicle, n.kind, n.magnitude, n.night)] = row
    return out


def _graybox_rows(grid: Grid, vehicles: list[VehicleData], model, settings) -> tuple[dict, dict]:
    """Gray-box zeta/epsilon per tier per (vehicle, kind, magnitude, night), and diagnostics."""
    from graybox import FitRequest, GrayBoxError, compute_drift, fit_baselines, fit_signatures

    t0 = time.perf_counter()
    requests = [FitRequest(model, v.healthy[:grid.baseline_days],
                           asset_id=asset_id(v.seed, v.vehicle), seed=v.vehicle,
                           estimate=grid.estimate) for v in vehicles]
    baselines = fit_baselines(requests, settings, grid.false_alarm_rate)
    t1 = time.perf_counter()
    jobs, candidate_requests = [], []
    info = {"baseline_failures": 0, "candidate_failures": 0, "structures": []}
    for v, result in zip(vehicles, baselines):
        if isinstance(result, GrayBoxError):
            info["baseline_failures"] += 1
            info["structures"].append({"vehicle": v.vehicle, "error": str(result)})
            continue
        signature, calibration = result
        structure = signature.channel(CHANNEL).structure
        info["structures"].append({
            "vehicle": v.vehicle, "analysis_interval": signature.analysis_step,
            "diff_order": structure.diff_order,
            "seasonal_order": structure.seasonal_order, "period": structure.period,
            "ar_order": structure.ar_order, "tau": structure.tau,
            "embedding_dim": structure.embedding_dim,
            "nonlinear_needed": structure.nonlinear_needed,
            **{f"epsilon_{t}": calibration.epsilon(CHANNEL, t) for t in TIERS},
            **{f"dof_{t}": calibration.threshold(CHANNEL, t).dof for t in TIERS}})
        for n in _nights(grid, v):
            jobs.append((v, n, signature, calibration))
            candidate_requests.append(FitRequest(model, n.candidate_frames, baseline=signature,
                                                 asset_id=asset_id(v.seed, v.vehicle, n.kind,
                                                                   n.magnitude)))
    candidates = fit_signatures(candidate_requests, settings)
    t2 = time.perf_counter()
    out = {}
    for (v, n, signature, calibration), candidate in zip(jobs, candidates):
        row = {}
        if isinstance(candidate, GrayBoxError):
            info["candidate_failures"] += 1
            row["gb_error"] = str(candidate)[:200]
        else:
            drift = compute_drift(candidate, signature, calibration)
            best = max(drift.entries, key=lambda e: e.ratio)
            for tier in TIERS:
                entry = drift.get(CHANNEL, tier)
                row[f"gb_{tier}_zeta"] = entry.zeta
                row[f"gb_{tier}_eps"] = entry.epsilon
            row["gb_top"] = f"{best.tier}:{best.top_changes[0].name}" if best.top_changes else best.tier
        out[(v.vehicle, n.kind, n.magnitude, n.night)] = row
    info["baseline_seconds"] = t1 - t0
    info["candidate_seconds"] = t2 - t1
    info["candidates"] = len(candidate_requests)
    return out, info


def run_seed(grid: Grid, seed: int, classic: ClassicSettings = ClassicSettings(),
             graybox_settings=None, with_graybox: bool = True) -> tuple[pd.DataFrame, dict]:
    """All rows (one per asset-night and model error) and timings of one seed."""
    from graybox import GrayBoxSettings

    settings = graybox_settings or GrayBoxSettings()
    timings = {"seed": seed, "pid": os.getpid()}
    cpu = time.process_time()
    t = time.perf_counter()
    vehicles = simulate_seed(grid, seed)
    timings["simulate_seconds"] = time.perf_counter() - t
    rows, diagnostics = [], []
    for error in grid.model_errors:
        model = white_box(error)
        t = time.perf_counter()
        classic_rows = _classic_rows(grid, vehicles, model, classic, {})
        timings[f"classic_seconds_{error:g}"] = time.perf_counter() - t
        gray_rows, info = ({}, {}) if not with_graybox else _graybox_rows(grid, vehicles, model, settings)
        for key in ("baseline_seconds", "candidate_seconds", "candidates", "baseline_failures",
                    "candidate_failures"):
            if key in info:
                timings[f"gb_{key}_{error:g}"] = info[key]
        for s in info.get("structures", []):
            diagnostics.append({"seed": seed, "model_error": error, **s})
        for key, values in classic_rows.items():
            vehicle, kind, magnitude, night = key
            rows.append({"seed": seed, "model_error": error, "vehicle": vehicle,
                         "asset_id": asset_id(seed, vehicle, kind, magnitude), "kind": kind,
                         "magnitude": magnitude,
                         "onset": np.nan if kind == "healthy" else grid.onset_day,
                         "night": night, "faulty": kind != "healthy",
                         **values, **gray_rows.get(key, {})})
    timings["total_seconds"] = sum(v for k, v in timings.items()
                                   if "_seconds" in k and not k.startswith("total"))
    timings["cpu_time"] = time.process_time() - cpu
    return pd.DataFrame(rows), {"timings": timings, "structures": diagnostics}


def _init_worker(threads: int) -> None:
    os.environ["OMP_NUM_THREADS"] = str(threads)
    os.environ["MKL_NUM_THREADS"] = str(threads)
    import torch

    torch.set_num_threads(threads)


def _task(args):
    grid, seed, classic, with_graybox = args
    return run_seed(grid, seed, classic, None, with_graybox)


def run_grid(grid: Grid, workers: int = 2, threads: int = 1,
             classic: ClassicSettings = ClassicSettings(), with_graybox: bool = True,
             progress=sys.stderr) -> tuple[pd.DataFrame, dict]:
    """Every seed of the grid; ``workers`` processes with ``threads`` torch threads each."""
    tasks = [(grid, seed, classic, with_graybox) for seed in grid.seeds]
    frames, timings, structures = [], [], []
    start = time.perf_counter()

    def collect(result):
        frame, info = result
        frames.append(frame)
        timings.append(info["timings"])
        structures.extend(info["structures"])
        if progress is not None:
            t = info["timings"]
            print(f"[detection] seed {t['seed']} done: {t['total_seconds']:.0f} s of work, "
                  f"{time.perf_counter() - start:.0f} s elapsed", file=progress, flush=True)

    if workers <= 1 or len(tasks) == 1:
        _init_worker(threads)
        for task in tasks:
            collect(_task(task))
    else:
        import multiprocessing

        context = multiprocessing.get_context("spawn")
        with context.Pool(min(workers, len(tasks)), initializer=_init_worker,
                          initargs=(threads,)) as pool:
            for result in pool.imap_unordered(_task, tasks):
                collect(result)
    table = pd.concat(frames, ignore_index=True).sort_values(
        ["model_error", "seed", "vehicle", "kind", "magnitude", "night"], ignore_index=True)
    return table, {"timings": timings, "structures": structures,
                   "wall_seconds": time.perf_counter() - start}
