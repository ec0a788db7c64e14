"""The diagnosis run on the gas-turbine detection grid.

Protocol (:mod:`benchmarks.detection.grid`'s fleet, reduced): per seed, ``vehicles`` vehicles,
each a healthy asset and one faulty asset per (fault kind, magnitude) on the vehicle's seed
(their telemetry identical up to the onset). Telemetry goes through the store layout
(``write_telemetry``) and ``graybox.read_window``, one window per UTC day. Per model error:

1. the white box (:func:`graybox.simulation.white_box_parameters`); when the model error is
   not 0, it is tuned to each vehicle on its baseline days as the product tunes it
   (``FitRequest.estimate`` = :data:`TUNED`: the baseline's fit estimates them and records
   ``Signature.tuning``, its candidates and ``diagnose`` use the tuned values; the shaft's
   ``J``, ``a``, ``b + c``, ``d`` scale together and ``b``, ``c`` enter only as a sum, so
   inertia, turbine gain and turbine slope stay fixed and ``compressor_linear`` takes up the
   error of ``b + c``);
2. the baseline on the baseline days (``gb.fit_baselines``, 1 % false alarms per
   asset-night), a candidate per night (``gb.fit_signatures``) on the night and the
   ``candidate_nights - 1`` before it, none before the baseline's end, as the nightly flow
   fits it (``[nightly] candidate_nights``, the product's default 2; a faulty asset's nights
   before the onset are its healthy twin's, identical telemetry), and its drift
   (``gb.compute_drift``): the night alarms when a tier exceeds its epsilon;
3. ``graybox.diagnose`` on every alarmed faulty night after the onset and on every healthy
   night (alarmed or not: the false-cause rate), timed, on the telemetry the candidate was
   fitted on (every night of its span), as :func:`flows.pipeline.diagnose_alarm` does.
   On the onset night the span's first night is healthy. With ``evidence = "since-alarm"``
   (an experiment, not the product: :mod:`benchmarks.diagnosis.episode`) an alarmed night is
   diagnosed on its alert episode's nights instead: from the span of the candidate that
   opened the alert (the first of the consecutive alarmed nights; a faulty asset's nights
   before the onset alarm as its healthy twin's) to the night, at most ``episode_nights``.
"""
from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, replace
from typing import Callable

import pandas as pd

import graybox as gb
from benchmarks.detection.grid import Grid, asset_id, simulate_seed, trailing_nights
from benchmarks.diagnosis.episode import EPISODE_NIGHTS, EVIDENCE, diagnosed_nights
from benchmarks.diagnosis.expected import CHANNEL, expected_hypothesis, implied_magnitude
from graybox.diagnosis import diagnose
from graybox.telemetry.writing import write_telemetry

#: the parameters tuned on the baseline days when the white box is off (an identifiable set)
TUNED = ("compressor_linear", "compressor_quadratic")
#: the grid's middle magnitudes, and the small and large ones (benchmarks.detection.grid)
SIZES = ("small", "middle", "large")
#: hypotheses kept per diagnosed night in the rows
KEEP = 5


#: the detection grid a diagnosis run reduces, by default: :class:`Grid`'s (candidates on the
#: product's ``[nightly] candidate_nights``) but for two model errors, one seed and two healthy
#: nights before the onset (``python -m benchmarks.diagnosis`` sets the magnitudes)
DETECTION = replace(Grid(), model_errors=(0.0, 0.2), seeds=(1,), pre_nights=2)


@dataclass(frozen=True)
class DiagnosisGrid:
    """What one diagnosis run covers.

    Attributes
    ----------
    detection : Grid
        The fleet, its faults and nights, the white-box errors, the baselines' false-alarm
        rate and the candidates' nights (the defaults: :data:`DETECTION`). Its magnitudes are
        the ones run per kind, a subset of the detection grid's; its ``estimate`` is not read
        (``tune`` is).
    sizes : dict of (kind, magnitude) -> str
        "small", "middle" or "large": the magnitude's place in the detection grid.
    tune : bool, default True
        Tune a white box that is off on the baseline days (False: the known weakness, kept
        for comparison).
    evidence : {"candidate", "since-alarm"}, default "candidate"
        What an alarmed night is diagnosed on: its candidate's nights (the product), or its
        alert episode's (:func:`benchmarks.diagnosis.episode.diagnosed_nights`; an
        experiment).
    episode_nights : int, default :data:`~benchmarks.diagnosis.episode.EPISODE_NIGHTS`
        The alert episode's cap, in nights (``since-alarm`` only).
    """

    detection: Grid
    sizes: dict
    tune: bool = True
    evidence: str = EVIDENCE[0]
    episode_nights: int = EPISODE_NIGHTS

    def to_dict(self) -> dict:
        """The settings as the ``--json`` record keeps them, in one flat mapping: the detection
        grid's (but ``estimate``, not read), ``sizes`` keyed ``kind=magnitude``, ``tune``,
        ``evidence`` and ``episode_nights``."""
        data = self.detection.to_dict()
        del data["estimate"]
        data.update(sizes={f"{k}={m:g}": s for (k, m), s in self.sizes.items()}, tune=self.tune,
                    evidence=self.evidence, episode_nights=self.episode_nights)
        return data


def white_box(model_error: float):
    """The gas-turbine shaft ``model_error`` off, reading ``omega`` from ``shaft_speed``."""
    from graybox.models.gas_turbine import GasTurbineShaft
    from graybox.simulation import white_box_parameters

    return GasTurbineShaft(white_box_parameters(model_error), columns={CHANNEL: "shaft_speed"})


def fit_vehicle_baselines(detection: Grid, vehicles, windows: dict, model_error: float,
                          tune: bool = True) -> tuple[dict, dict]:
    """Each vehicle's white box and baseline, as the product fits them.

    Parameters
    ----------
    detection : Grid
        The baseline days and the false-alarm rate the baselines are calibrated to.
    vehicles : list of VehicleData
        One seed's fleet (:func:`benchmarks.detection.grid.simulate_seed`).
    windows : dict
        ``(asset, day) -> TelemetryWindow`` (:func:`read_windows`); each baseline is fitted on its
        healthy asset's baseline days.
    model_error : float
        The white box's error (:func:`white_box`); when it is not 0 and ``tune``, the
        baseline's fit first estimates :data:`TUNED` (``FitRequest.estimate``, recorded as
        ``Signature.tuning``, which its candidates and ``diagnose`` use).
    tune : bool, default True
        False: a white box that is off is not tuned (the known weakness).

    Returns
    -------
    models : dict of int -> WhiteBoxModel
        Each vehicle's white box (its number ``VehicleData.vehicle`` as the key).
    baselines : dict of int -> (Signature, Calibration) or GrayBoxError
        :func:`graybox.fit_baselines`' result per vehicle.
    """
    estimate = TUNED if model_error and tune else ()
    models = {v.vehicle: white_box(model_error) for v in vehicles}
    requests = [gb.FitRequest(models[v.vehicle],
                              [windows[asset_id(v.seed, v.vehicle), d]
                               for d in range(detection.baseline_days)],
                              asset_id=asset_id(v.seed, v.vehicle), seed=v.vehicle,
                              estimate=estimate)
                for v in vehicles]
    results = gb.fit_baselines(requests, false_alarm_rate=detection.false_alarm_rate)
    return models, dict(zip([v.vehicle for v in vehicles], results))


def _read_days(root: str, asset: str, frames: list[pd.DataFrame], first_day: int, model,
               into: dict) -> None:
    """Write an asset's day frames in the store layout and read each back as its window."""
    write_telemetry(root, asset, pd.concat(frames))
    for offset, frame in enumerate(frames):
        begin = frame.index[0].floor("D")
        into[asset, first_day + offset] = gb.read_window(
            root, asset, model.required_columns, begin, begin + pd.Timedelta(days=1),
            inputs=model.input_columns)


def read_windows(grid: Grid, vehicles, model) -> dict:
    """``(asset, day) -> TelemetryWindow``: every day of the healthy assets, the days from the
    onset on of the faulty ones."""
    windows = {}
    with tempfile.TemporaryDirectory(prefix="diagnosis-bench-") as root:
        for v in vehicles:
            _read_days(root, asset_id(v.seed, v.vehicle), v.healthy, 0, model, windows)
            for (kind, magnitude), frames in v.faulty.items():
                _read_days(root, asset_id(v.seed, v.vehicle, kind, magnitude), frames,
                           grid.onset_day, model, windows)
    return windows


def diagnosis_fields(signature, windows, model, expected: tuple[str, str] | None,
                     implied: Callable[[object], float]) -> dict:
    """Diagnose one night's candidate; the fields of its row.

    Parameters
    ----------
    signature : Signature
        The baseline.
    windows : sequence of TelemetryWindow
        The telemetry the night's candidate was fitted on (its ``FitRequest.windows``: the
        night and the ones before it in its span), what the nightly flow diagnoses.
    model : WhiteBoxModel
        The baseline's white box.
    expected : (kind, target) or None
        The hypothesis the night's fault should rank first.
    implied : callable
        The fault's magnitude implied by the expected hypothesis (a :class:`Hypothesis`).
    """
    began, began_cpu = time.perf_counter(), time.process_time()
    diagnosis = diagnose(signature, list(windows), model)
    seconds, cpu_seconds = time.perf_counter() - began, time.process_time() - began_cpu
    ranked = diagnosis.hypotheses
    names = [(h.kind, h.target) for h in ranked]
    rank = names.index(expected) + 1 if expected in names else None
    first = ranked[0]
    out = {"diagnosed": True, "seconds": seconds, "cpu_seconds": cpu_seconds,
           "explained": diagnosis.explained,
           "first": first.hypothesis, "first_kind": first.kind, "first_target": first.target,
           "first_estimate": first.estimate, "first_baseline": first.baseline,
           "first_score": first.score,
           "gap": first.score - ranked[1].score if len(ranked) > 1 else math.inf,
           "expected_rank": rank, "top": [
               {"hypothesis": h.hypothesis, "estimate": h.estimate,
                "interval": list(h.interval), "score": h.score} for h in ranked[:KEEP]]}
    if rank is not None:
        hit = ranked[rank - 1]
        out.update(expected_estimate=hit.estimate, expected_interval=list(hit.interval),
                   expected_score=hit.score, implied_magnitude=implied(hit))
    return out


def _holder(windows: dict, asset: str, vehicle, day: int) -> str:
    """Whose telemetry is ``asset``'s on ``day``: its own, or before the onset its healthy
    twin's (identical up to the onset)."""
    return asset if (asset, day) in windows else asset_id(vehicle.seed, vehicle.vehicle)


def _alarmed_nights(jobs: list, drifts: list, onset_day: int) -> dict[str, set[int]]:
    """``asset -> nights whose candidate alarmed``; a faulty asset's nights before the onset
    are its healthy twin's (the same telemetry, baseline and candidate)."""
    own: dict[str, set[int]] = {}
    for (v, kind, magnitude, night, _), drift in zip(jobs, drifts):
        nights = own.setdefault(asset_id(v.seed, v.vehicle, kind, magnitude), set())
        if drift is not None and any(e.exceeded for e in drift.entries):
            nights.add(night)
    alarmed = {}
    for (v, kind, magnitude, _, _) in jobs:
        asset = asset_id(v.seed, v.vehicle, kind, magnitude)
        twin = own.get(asset_id(v.seed, v.vehicle), set()) if kind != "healthy" else set()
        alarmed[asset] = own[asset] | {n for n in twin if n < onset_day}
    return alarmed


def run_seed(grid: DiagnosisGrid, seed: int, say: Callable[[str], None]) -> tuple[list[dict], dict]:
    """Every scored asset-night of one seed, for every model error, and the clock."""
    detection = grid.detection
    clock = {"diagnose_seconds": 0.0, "diagnosed": 0}
    began = time.perf_counter()
    vehicles = simulate_seed(detection, seed)
    windows = read_windows(detection, vehicles, white_box(0.0))
    clock["simulate_write_read_seconds"] = time.perf_counter() - began
    say(f"seed {seed}: simulated, wrote and read {len(windows)} asset-days in "
        f"{clock['simulate_write_read_seconds']:.0f} s")
    rows = []
    for error in detection.model_errors:
        # a white box that is off is tuned as the product tunes it: the baseline's fit
        # estimates TUNED on its days (FitRequest.estimate) and its candidates use the values
        began = time.perf_counter()
        models, baselines = fit_vehicle_baselines(detection, vehicles, windows, error, grid.tune)
        tuning = {vehicle: result[0].tuning for vehicle, result in baselines.items()
                  if not isinstance(result, gb.GrayBoxError) and result[0].tuning is not None}
        clock[f"baseline_seconds_{error:g}"] = time.perf_counter() - began
        jobs = []
        for v in vehicles:
            if isinstance(baselines[v.vehicle], gb.GrayBoxError):
                say(f"seed {seed} vehicle {v.vehicle}: baseline failed: {baselines[v.vehicle]}")
                continue
            signature = baselines[v.vehicle][0]
            assets = [("healthy", 0.0, range(detection.baseline_days, detection.days))] + [
                (kind, magnitude, range(detection.onset_day, detection.days))
                for kind, magnitude in detection.scenarios()]
            for kind, magnitude, nights in assets:
                asset = asset_id(v.seed, v.vehicle, kind, magnitude)
                for night in nights:
                    # the candidate's span, as the nightly flow reads it; before the onset a
                    # faulty asset's telemetry is its healthy twin's
                    days = trailing_nights(night, detection.candidate_nights,
                                           detection.baseline_days)
                    parts = [windows[_holder(windows, asset, v, d), d] for d in days]
                    jobs.append((v, kind, magnitude, night,
                                 gb.FitRequest(models[v.vehicle], parts, baseline=signature,
                                               asset_id=asset)))
        began = time.perf_counter()
        candidates = gb.fit_signatures([job[-1] for job in jobs])
        clock[f"candidate_seconds_{error:g}"] = time.perf_counter() - began
        say(f"seed {seed}, model error {error:g}: {len(baselines)} baselines ({len(tuning)} "
            f"white boxes tuned) in {clock[f'baseline_seconds_{error:g}']:.0f} s, "
            f"{len(jobs)} nights in "
            f"{clock[f'candidate_seconds_{error:g}']:.0f} s; diagnosing")
        began = time.perf_counter()
        drifts = [None if isinstance(candidate, gb.GrayBoxError)
                  else gb.compute_drift(candidate, *baselines[job[0].vehicle])
                  for job, candidate in zip(jobs, candidates)]
        alarmed = _alarmed_nights(jobs, drifts, detection.onset_day)
        for (v, kind, magnitude, night, request), candidate, drift in zip(jobs, candidates,
                                                                           drifts):
            signature, calibration = baselines[v.vehicle]
            expected = expected_hypothesis(kind) if kind != "healthy" else None
            row = {"seed": seed, "model_error": error, "vehicle": v.vehicle, "fault": kind,
                   "magnitude": magnitude, "size": grid.sizes.get((kind, magnitude), ""),
                   "night": night, "diagnosed": False,
                   "expected": None if expected is None else " ".join(expected)}
            if v.vehicle in tuning:
                row["tuned"] = dict(zip(tuning[v.vehicle].names, tuning[v.vehicle].values))
            if drift is None:
                row.update(alarm=None, candidate_error=str(candidate)[:200])
                rows.append(row)
                continue
            exceeded = [e for e in drift.entries if e.exceeded]
            row.update(alarm=bool(exceeded),
                       exceeded=";".join(f"{e.channel}/{e.tier}" for e in exceeded))
            if exceeded or kind == "healthy":
                parts = request.windows
                if grid.evidence != "candidate":
                    asset = asset_id(v.seed, v.vehicle, kind, magnitude)
                    days = diagnosed_nights(night, alarmed[asset], detection.candidate_nights,
                                            detection.baseline_days, grid.evidence,
                                            grid.episode_nights)
                    parts = [windows[_holder(windows, asset, v, d), d] for d in days]
                    row["diagnosed_nights"] = [days.start, days.stop - 1]
                try:
                    row.update(diagnosis_fields(
                        signature, parts, models[v.vehicle], expected,
                        lambda h: implied_magnitude(kind, h.estimate, h.baseline)))
                    clock["diagnose_seconds"] += row["seconds"]
                    clock["diagnosed"] += 1
                except gb.GrayBoxError as error_:
                    row.update(diagnosis_error=str(error_)[:200])
            rows.append(row)
        say(f"seed {seed}, model error {error:g}: diagnosed "
            f"{sum(r['diagnosed'] for r in rows if r['model_error'] == error)} nights in "
            f"{time.perf_counter() - began:.0f} s")
    return rows, clock


def run_grid(grid: DiagnosisGrid, progress: Callable[[str], None] | None = None) -> dict:
    """Every seed of ``grid``, one after the other, in this process.

    Returns
    -------
    dict
        ``grid`` (its settings), ``tuned`` (:data:`TUNED`), ``rows`` (one per scored
        asset-night and model error) and ``clock``.
    """
    say = progress or (lambda line: None)
    rows, clocks = [], []
    for seed in grid.detection.seeds:
        seed_rows, clock = run_seed(grid, seed, say)
        rows += seed_rows
        clocks.append(clock)
    clock = {key: sum(c.get(key, 0.0) for c in clocks) for c in clocks for key in c}
    return {"grid": grid.to_dict(), "tuned": list(TUNED) if grid.tune else [], "rows": rows,
            "clock": clock}
