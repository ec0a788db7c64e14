"""The scenario grid and the simulated fleet of one seed.

Protocol (the same for every asset and detector): days ``0 .. K-1`` are the healthy baseline,
then every UTC day is one nightly window. A seed's fleet has ``vehicles`` vehicles; each
appears as one *healthy* asset and as one *faulty* asset per (fault kind, magnitude), all with
the same vehicle seed. The simulator draws every random stream of a vehicle from its seed
independently of its faults, so the faulty assets' telemetry is identical to the healthy
asset's up to the onset (a counterfactual pair; checked here on every run). Hence one baseline
per vehicle serves all its assets, the healthy asset's nights ``K .. days-1`` measure false
alarms, and the faulty assets are evaluated on their nights from the onset on.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
import pandas as pd

from flows.config.settings import NightlySettings
from graybox.simulation import SECONDS_PER_DAY, Fault, FleetSpec, VehicleSpec, simulate_fleet

#: fault kinds of the issue, with the labels used in the report
KINDS = {"friction": "(a) gamma drift (friction)", "nonlinear": "(b) nonlinear onset (flutter)",
         "noise": "(c) sensor-noise change", "bias": "(d) bias step"}
UNITS = {"friction": "relative change of the damping rate", "nonlinear": "flutter kappa",
         "noise": "sensor-noise std x (1 + m)", "bias": "rad/s"}

#: three magnitudes per kind, small to moderate, chosen from a scan (see docs/benchmarks.md):
#: they bracket where the gray box goes from partial to full detection, and all but the largest
#: flutter lie where the 3-sigma redline detects <= 20 %
DEFAULT_MAGNITUDES = {
    "friction": (0.1, 0.2, 0.35),
    "nonlinear": (0.05, 0.1, 0.2),
    "noise": (0.05, 0.1, 0.3),
    "bias": (0.1, 0.5, 2.0),
}

#: the candidates' nights of a run recorded before :class:`Grid` had ``candidate_nights``:
#: the night alone
UNRECORDED_CANDIDATE_NIGHTS = 1


@dataclass(frozen=True)
class Grid:
    """Everything that defines a benchmark run.

    Attributes
    ----------
    magnitudes : dict of kind -> tuple of float
    model_errors : tuple of float
        Relative error of the white box (``graybox.simulation.white_box_parameters``).
    seeds : tuple of int
        Master seeds; vehicle ``i`` of seed ``s`` has the vehicle seed ``1000 s + i``.
    vehicles : int
        Vehicles per seed (each: one healthy and one faulty asset per kind and magnitude).
    baseline_days : int
        K healthy days the baselines and thresholds are fitted on.
    pre_nights : int
        Healthy nights between the baseline and the onset.
    post_nights : int
        Nights evaluated from the onset on ("within 3 nights" = onset, onset+1, onset+2).
    sample_interval : float
        Seconds between telemetry samples.
    false_alarm_rate : float
        Target false alarms per asset-night, for every detector.
    candidate_nights : int
        The gray box's candidate of a night is fitted on it and the ``N - 1`` nights before it,
        never before the end of the baseline, as ``[nightly] candidate_nights = N`` does in the
        product (the classic detectors always see one night). Default the product's.
    estimate : tuple of str
        White-box parameters each gray-box baseline tunes to its vehicle first, as a class's
        ``estimate = [...]`` does in the product (default none).
    """

    magnitudes: dict = field(default_factory=lambda: dict(DEFAULT_MAGNITUDES))
    model_errors: tuple = (0.0, 0.1, 0.2)
    seeds: tuple = (1, 2, 3, 4, 5, 6)
    vehicles: int = 8
    baseline_days: int = 4
    pre_nights: int = 6
    post_nights: int = 3
    sample_interval: float = 10.0
    false_alarm_rate: float = 0.01
    candidate_nights: int = NightlySettings().candidate_nights
    estimate: tuple = ()

    @property
    def onset_day(self) -> int:
        return self.baseline_days + self.pre_nights

    @property
    def days(self) -> int:
        return self.onset_day + self.post_nights

    @property
    def samples_per_day(self) -> int:
        value = SECONDS_PER_DAY / self.sample_interval
        if abs(value - round(value)) > 1e-9:
            raise ValueError("sample_interval must divide a day")
        return int(round(value))

    def scenarios(self) -> list[tuple[str, float]]:
        return [(kind, float(m)) for kind in self.magnitudes for m in self.magnitudes[kind]]

    def to_dict(self) -> dict:
        data = asdict(self)
        data["magnitudes"] = {k: list(v) for k, v in self.magnitudes.items()}
        data["model_errors"] = list(self.model_errors)
        data["seeds"] = list(self.seeds)
        return data


def vehicle_seed(seed: int, vehicle: int) -> int:
    return 1000 * int(seed) + int(vehicle)


def asset_id(seed: int, vehicle: int, kind: str = "healthy", magnitude: float | None = None) -> str:
    base = f"S{seed}-V{vehicle}"
    return base + "-healthy" if kind == "healthy" else f"{base}-{kind}-{magnitude:g}"


@dataclass
class VehicleData:
    """One vehicle's day frames: all days of the healthy asset, the post-onset days of each
    faulty asset (keyed by (kind, magnitude))."""

    seed: int
    vehicle: int
    healthy: list[pd.DataFrame]
    faulty: dict[tuple[str, float], list[pd.DataFrame]]


def _split_days(frame: pd.DataFrame, samples_per_day: int, first: int, last: int) -> list[pd.DataFrame]:
    frame = frame.set_index("timestamp")
    return [frame.iloc[d * samples_per_day:(d + 1) * samples_per_day] for d in range(first, last)]


def simulate_seed(grid: Grid, seed: int) -> list[VehicleData]:
    """Simulate one seed's fleet (one vectorized simulator call) and cut it into days."""
    vehicles = []
    for i in range(grid.vehicles):
        s = vehicle_seed(seed, i)
        vehicles.append(VehicleSpec(asset_id(seed, i), seed=s))
        for kind, magnitude in grid.scenarios():
            vehicles.append(VehicleSpec(asset_id(seed, i, kind, magnitude), seed=s,
                                        faults=(Fault(kind, float(grid.onset_day), magnitude),)))
    spec = FleetSpec(tuple(vehicles), days=grid.days, sample_interval=grid.sample_interval)
    frames = simulate_fleet(spec)
    spd = grid.samples_per_day
    out = []
    for i in range(grid.vehicles):
        healthy_frame = frames.pop(asset_id(seed, i))
        healthy = _split_days(healthy_frame, spd, 0, grid.days)
        faulty = {}
        onset_row = grid.onset_day * spd
        for kind, magnitude in grid.scenarios():
            frame = frames.pop(asset_id(seed, i, kind, magnitude))
            # the counterfactual pair: identical telemetry before the onset
            same = np.array_equal(frame["shaft_speed"].to_numpy()[:onset_row],
                                  healthy_frame["shaft_speed"].to_numpy()[:onset_row])
            if not same:
                raise AssertionError(f"{asset_id(seed, i, kind, magnitude)} differs from its healthy "
                                     "twin before the onset; the shared-baseline design is invalid")
            faulty[(kind, magnitude)] = _split_days(frame, spd, grid.onset_day, grid.days)
        out.append(VehicleData(seed, i, healthy, faulty))
    return out


def trailing_nights(night: int, nights: int, first: int) -> range:
    """The nights a candidate of ``night`` is fitted on with ``[nightly] candidate_nights =
    nights``: it and the ``nights - 1`` before it, none before ``first`` (the baseline's end).

    >>> list(trailing_nights(5, 2, 4)), list(trailing_nights(4, 2, 4))
    ([4, 5], [4])
    """
    return range(max(first, night - nights + 1), night + 1)


def fault_summary(grid: Grid) -> str:
    kinds = ", ".join(f"{k} {list(v)}" for k, v in grid.magnitudes.items())
    return (f"{len(grid.seeds)} seeds x {grid.vehicles} vehicles; kinds/magnitudes: {kinds}; "
            f"model errors {list(grid.model_errors)}; {grid.days} days, onset day {grid.onset_day}; "
            f"gray-box candidates on {grid.candidate_nights} night(s)"
            + (f"; white box tuned on {', '.join(grid.estimate)}" if grid.estimate else ""))
