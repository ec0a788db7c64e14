"""The zoo through other loggers: slower sampling, timestamp jitter, dropped rows, glitches.

``python -m benchmarks.zoo.logger thermal_room:every=5 hydraulic_level:jitter=0.2,drop=0.02``

A user's logger is rarely the simulator's: it samples more slowly (a building logs every 5 or
15 minutes), its timestamps wander around the nominal step, and rows go missing. Each spec is
a family and how its telemetry is logged: ``every=k`` keeps every k-th sample (the sample
interval times k), ``jitter=f`` moves each timestamp by up to ``f`` sample intervals (uniform,
to the millisecond), ``drop=p`` drops each row with probability ``p``, ``spike=p`` replaces each
reading of a channel with more than ten distinct values, with probability ``p``, by a glitch:
the reading plus or minus 3 to 8 times the channel's standard deviation over the asset's
simulated days (an interference spike, a garbled transmission); ``outage=p`` gives each
asset-day, with probability ``p``, one logger outage of 10 to 60 minutes at a random time (its
rows missing), and ``dropout=p`` likewise one channel's readings missing (NaN) for 10 to 60
minutes (a sensor's link), and ``resend=p`` gives each asset-day, with probability ``p``, one
reconnect of its gateway, which sends the last 10 to 60 minutes of rows again (the same
timestamps and readings, after the rows already sent). The family then runs
exactly as in ``python -m benchmarks.zoo`` (:func:`benchmarks.zoo.run.run_family`, the
product's defaults), on a smaller fleet by default. One markdown row per spec: failures (reads,
baselines, nights, with the first reason), healthy alarms, faults found, the analysis interval
and the cost.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from benchmarks.zoo.families import discover
from benchmarks.zoo.family import Family
from benchmarks.zoo.run import run_family


@dataclass(frozen=True)
class Logger:
    """How a family's telemetry is logged (see the module docstring)."""

    every: int = 1
    jitter: float = 0.0
    drop: float = 0.0
    spike: float = 0.0
    outage: float = 0.0
    dropout: float = 0.0
    resend: float = 0.0

    @classmethod
    def parse(cls, text: str) -> "Logger":
        """``"every=5,jitter=0.2"`` (empty: the simulator's own logging)."""
        fields = dict(item.split("=", 1) for item in text.split(",") if item)
        known = ("every", "jitter", "drop", "spike", "outage", "dropout", "resend")
        unknown = set(fields) - set(known)
        if unknown:
            raise ValueError(f"unknown logger settings {sorted(unknown)}: {', '.join(known)}")
        return cls(int(fields.get("every", 1)),
                   *(float(fields.get(name, 0.0)) for name in known[1:]))


class LoggedFamily:
    """A family whose telemetry passes through ``logger`` (everything else is the family's)."""

    def __init__(self, family: Family, logger: Logger, seed: int = 0):
        self.family, self.logger, self.seed = family, logger, seed

    def __getattr__(self, name):
        return getattr(self.family, name)

    @property
    def sample_interval(self) -> float:
        return self.family.sample_interval * self.logger.every

    def simulate(self, plans, start, days: int, first_day: int = 0) -> dict[str, pd.DataFrame]:
        frames = self.family.simulate(plans, start, days, first_day)
        return {asset: self._logged(frame, [self.seed, index, first_day])
                for index, (asset, frame) in enumerate(frames.items())}

    def _logged(self, frame: pd.DataFrame, seed: list[int]) -> pd.DataFrame:
        rng = np.random.default_rng(seed)
        frame = frame.iloc[::self.logger.every]
        if self.logger.drop:
            frame = frame[rng.random(len(frame)) >= self.logger.drop]
        if self.logger.spike:
            frame = frame.copy()
            for column in frame.columns:
                values = frame[column].to_numpy()
                if np.unique(values).size <= 10:
                    continue
                hit = rng.random(len(values)) < self.logger.spike
                size = rng.uniform(3.0, 8.0, hit.sum()) * rng.choice([-1.0, 1.0], hit.sum())
                values = values.copy()
                values[hit] += size * values.std()
                frame[column] = values
        if self.logger.outage or self.logger.dropout:
            frame = _outages(frame, rng, self.logger.outage, self.logger.dropout)
        if self.logger.jitter:
            shift = rng.uniform(-1, 1, len(frame)) * self.logger.jitter * self.sample_interval
            frame = frame.set_axis((frame.index + pd.to_timedelta(shift, unit="s")).round("ms")
                                   .rename(frame.index.name))
        if self.logger.resend:   # the rows as stamped, sent again
            frame = _resent(frame, rng, self.logger.resend)
        return frame


def _outages(frame: pd.DataFrame, rng: np.random.Generator, outage: float, dropout: float
             ) -> pd.DataFrame:
    """``frame`` with, per day, one outage of 10-60 minutes (rows left out) with probability
    ``outage`` and one channel's readings missing (NaN) for 10-60 minutes with probability
    ``dropout``."""
    frame = frame.copy()
    keep = np.ones(len(frame), dtype=bool)
    seconds = (frame.index - frame.index[0]).total_seconds().to_numpy()
    for first in np.arange(0.0, seconds[-1] + 1.0, 86_400.0):
        for probability, rows in ((outage, True), (dropout, False)):
            if rng.random() >= probability:
                continue
            begin = first + rng.uniform(0.0, 86_400.0)
            inside = (seconds >= begin) & (seconds < begin + rng.uniform(600.0, 3600.0))
            if rows:
                keep &= ~inside
            else:
                column = frame.columns[rng.integers(len(frame.columns))]
                frame.loc[inside, column] = np.nan
    return frame[keep]


def _resent(frame: pd.DataFrame, rng: np.random.Generator, resend: float) -> pd.DataFrame:
    """``frame`` with, per day and with probability ``resend``, the rows of 10-60 minutes
    before a random time sent again right after them (a gateway's reconnect)."""
    seconds = (frame.index - frame.index[0]).total_seconds().to_numpy()
    parts, done = [], 0
    for first in np.arange(0.0, seconds[-1] + 1.0, 86_400.0):
        if rng.random() >= resend:
            continue
        at = first + rng.uniform(3600.0, 86_400.0)
        cut = int(np.searchsorted(seconds, at))
        begin = int(np.searchsorted(seconds, at - rng.uniform(600.0, 3600.0)))
        if begin >= cut or cut <= done:
            continue
        parts += [frame.iloc[done:cut], frame.iloc[begin:cut]]
        done = cut
    return pd.concat(parts + [frame.iloc[done:]]) if parts else frame


def _calm(result: dict) -> str:
    """`` (+N not operating)`` for a run's nights too short to fit (none: empty)."""
    calm = len(result.get("calm_nights", {}))
    return f" (+{calm} not operating)" if calm else ""


def row(spec: str, result: dict, seconds: float) -> str:
    """The markdown row of one run."""
    failures = {**result["failed_reads"], **result["failed_baselines"], **result["failed_nights"]}
    first = next(iter(failures.values()), "")
    fa = result["false_alarms"]
    tiers = "".join(f", {name} {count}" for name, count in result["healthy_tiers"].items())
    small, large = result["detected_small"], result["detected_large"]
    return (f"| {spec} | {result['analysis_intervals']} | {len(result['failed_reads'])} / "
            f"{len(result['failed_baselines'])} / {len(result['failed_nights'])}"
            f"{_calm(result)} | "
            f"{fa['alarms']}/{fa['asset_nights']}{tiers} | {small[0]}/{small[1]} | "
            f"{large[0]}/{large[1]} | "
            f"{result['s_per_baseline_day']:.2f} | {result['s_per_night']:.3f} | {seconds:.0f} | "
            f"{first[:160]} |")


HEADER = ("| family:logger | analysis interval (s) | failed reads / baselines / nights | "
          "healthy alarms (channel/tier) | small faults | large faults | s per asset-day of baseline | "
          "s per asset-night | wall s | first failure |\n|---|---|---|---|---|---|---|---|---|---|")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.zoo.logger",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("specs", nargs="+", help="family:logger, e.g. thermal_room:every=5")
    parser.add_argument("--healthy-assets", type=int, default=6)
    parser.add_argument("--baseline-days", type=int, default=5)
    parser.add_argument("--nights", type=int, default=5)
    parser.add_argument("--faulty-per-cell", type=int, default=1)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    families = discover()
    load = os.getloadavg()[0]
    print(HEADER, flush=True)
    for spec in args.specs:
        name, _, text = spec.partition(":")
        if name not in families:
            parser.error(f"unknown family {name!r}; known: {', '.join(families)}")
        family = LoggedFamily(families[name], Logger.parse(text))
        began = time.perf_counter()
        result = run_family(family, healthy_assets=args.healthy_assets,
                            baseline_days=args.baseline_days, nights=args.nights,
                            faulty_per_cell=args.faulty_per_cell, seed=args.seed,
                            progress=lambda line: print(line, file=sys.stderr, flush=True))
        print(row(spec, result, time.perf_counter() - began), flush=True)
    print(f"\n1-minute load {load:.1f} before, {os.getloadavg()[0]:.1f} after")
    return 0


if __name__ == "__main__":
    sys.exit(main())
