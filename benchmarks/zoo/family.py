"""A plant family of the zoo: a true plant simulated by its own code, a coarse white box written
as a user would write it, and the faults to inject.

A family simulates *asset-days*: every day of every asset is one element of a batch, started
from the plant's own state after a warm-up, with its own random streams drawn from
``(asset seed, day)``. So a faulty asset that shares its seed with a healthy one has the very
same telemetry up to the onset (a counterfactual pair: one baseline serves both), and a day's
telemetry does not depend on which other days are simulated with it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Mapping, NamedTuple, Sequence

import numpy as np
import pandas as pd
from scipy.signal import lfilter

SECONDS_PER_DAY = 86400.0


@dataclass(frozen=True)
class FaultKind:
    """One kind of fault of a family, at two magnitudes (small, large) in its own units."""

    name: str
    description: str
    magnitudes: tuple[float, float]


@dataclass(frozen=True)
class AssetPlan:
    """One simulated asset: its seed (its true parameters and random streams) and its fault.

    The fault acts from ``onset`` (UTC) on; ``fault=None`` is healthy throughout.
    """

    asset_id: str
    seed: int
    fault: FaultKind | None = None
    magnitude: float = 0.0
    onset: pd.Timestamp | None = None

    @property
    def size(self) -> str:
        """"small" or "large" (which of its kind's magnitudes), "" when healthy."""
        if self.fault is None:
            return ""
        return "small" if self.magnitude == self.fault.magnitudes[0] else "large"


@dataclass
class DayBatch:
    """The asset-days a family's :meth:`Family.simulate_days` simulates together.

    Attributes
    ----------
    true : dict of str -> ndarray (B,)
        Each element's true plant parameters (drawn per asset: the same on all its days).
    rngs : list of numpy.random.Generator
        Each element's own random stream, seeded by ``(asset seed, day)``.
    day : ndarray (B,)
        Day numbers (0 is the first simulated day).
    fault : ndarray of str (B,)
        Fault kind names ("" where healthy).
    magnitude : ndarray (B,)
    onset : ndarray (B,)
        Seconds after the day's midnight at which the fault starts acting (``inf``: never
        on this day; ``-inf``: from before midnight).
    """

    true: dict[str, np.ndarray]
    rngs: list[np.random.Generator]
    day: np.ndarray
    fault: np.ndarray
    magnitude: np.ndarray
    onset: np.ndarray

    def __len__(self) -> int:
        return len(self.day)

    def active(self, kind: str, t: float | np.ndarray) -> np.ndarray:
        """Fault magnitude of ``kind`` at day-second(s) ``t``: shape (B,) or (B, len(t)); 0
        where the element has another fault, none, or its onset is later."""
        t = np.asarray(t, dtype=float)
        on = self.onset if t.ndim == 0 else self.onset[:, None]
        size = self.magnitude if t.ndim == 0 else self.magnitude[:, None]
        mine = self.fault == kind if t.ndim == 0 else (self.fault == kind)[:, None]
        return np.where(mine & (t >= on), size, 0.0)

    def normal(self, shape: tuple[int, ...], scale: float | np.ndarray = 1.0) -> np.ndarray:
        """Normal draws of ``shape`` per element, each from its own stream: (B, *shape)."""
        return np.stack([rng.normal(0.0, 1.0, shape) for rng in self.rngs]) * scale

    def uniform(self, low: float, high: float, shape: tuple[int, ...] = ()) -> np.ndarray:
        """Uniform draws per element from its own stream: (B, *shape)."""
        return np.stack([rng.uniform(low, high, shape) for rng in self.rngs])


class DayClock(NamedTuple):
    """The grid a family simulates a day on (:meth:`Family.clock`), its warm-up first.

    Attributes
    ----------
    samples : int
        The day's samples (without the warm-up).
    t : ndarray (total,)
        Seconds after midnight of every sample (the warm-up's are negative).
    hour : ndarray (total,)
        Hour of day of every sample.
    total : int
        Samples of the warm-up and the day.
    """

    samples: int
    t: np.ndarray
    hour: np.ndarray
    total: int


class Family:
    """One plant family. Subclasses set the class attributes and implement
    :meth:`true_parameters` and :meth:`simulate_days`; the module exposes ``FAMILY``.

    Attributes
    ----------
    name, title, description : str
    spec : str
        The coarse white box, ``package.module:ClassName``.
    parameters : mapping
        fleet.toml parameter overrides of the white box (normally none).
    columns : mapping
        White-box variable -> telemetry column.
    sample_interval : float
        Seconds between telemetry samples.
    grid : mapping
        ``GridPolicy`` keyword arguments, as a fleet.toml class line gives them.
    held_out : bool
        True: not used to choose the method's defaults.
    faults : tuple of FaultKind
    channels : tuple of str
        Telemetry columns written, in order.
    """

    name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    description: ClassVar[str] = ""
    spec: ClassVar[str] = ""
    parameters: ClassVar[Mapping] = {}
    columns: ClassVar[Mapping[str, str]] = {}
    sample_interval: ClassVar[float] = 1.0
    grid: ClassVar[Mapping] = {}
    held_out: ClassVar[bool] = False
    faults: ClassVar[tuple[FaultKind, ...]] = ()
    channels: ClassVar[tuple[str, ...]] = ()
    #: asset-days simulated at once (bounds the memory of per-step noise)
    batch_size: ClassVar[int] = 128

    def true_parameters(self, rng: np.random.Generator) -> dict[str, float]:
        """One asset's true plant parameters."""
        raise NotImplementedError

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        """Telemetry of every asset-day of ``batch``: column -> array (B, samples per day)."""
        raise NotImplementedError

    # -- shared machinery ------------------------------------------------------------------
    @property
    def samples_per_day(self) -> int:
        return int(round(SECONDS_PER_DAY / self.sample_interval))

    def clock(self, warmup: int, substeps: int = 1) -> DayClock:
        """The grid a day is simulated on: ``warmup`` telemetry samples before the day and the
        day's, each divided into ``substeps`` (1: the telemetry's own grid)."""
        t, hour = day_clock(self.samples_per_day * substeps, warmup * substeps,
                            self.sample_interval / substeps)
        return DayClock(self.samples_per_day * substeps, t, hour, len(t))

    def fault(self, name: str) -> FaultKind:
        for kind in self.faults:
            if kind.name == name:
                return kind
        raise KeyError(f"{self.name} has no fault kind {name!r}")

    def simulate(self, plans: Sequence[AssetPlan], start: pd.Timestamp, days: int,
                 first_day: int = 0) -> dict[str, pd.DataFrame]:
        """Telemetry rows per asset for days ``first_day .. days - 1`` after ``start``.

        Returns
        -------
        dict of asset id -> DataFrame
            A UTC ``DatetimeIndex`` named ``"timestamp"`` and one column per channel.
        """
        return self.simulate_together([(plans, start, days, first_day)])[0]

    def fault_days(self, start: pd.Timestamp, days: int = 1,
                   seed: int = 11) -> dict[str, pd.DataFrame]:
        """``days`` days of one asset (``seed``) from the day after ``start``, in one batch
        (for checks of a family's physics).

        Returns
        -------
        dict of str -> DataFrame
            ``"healthy"``, and ``"<fault>/small"`` and ``"<fault>/large"``: the asset with each
            fault at each of its magnitudes from the first day's start.
        """
        return self.simulate(self.fault_day_plans(start, seed), start, days + 1, first_day=1)

    def fault_day_plans(self, start: pd.Timestamp, seed: int = 11) -> list[AssetPlan]:
        """The plans of :meth:`fault_days`: ``"healthy"``, and ``"<fault>/small"`` and
        ``"<fault>/large"`` from the day after ``start`` on (for a caller that simulates them
        together with other plans, :meth:`simulate_together`)."""
        onset = start + pd.Timedelta(days=1)
        return [AssetPlan("healthy", seed)] + [
            AssetPlan(f"{kind.name}/{size}", seed, kind, kind.magnitudes[i], onset)
            for kind in self.faults for i, size in enumerate(("small", "large"))]

    def simulate_together(self, requests: Sequence[tuple[Sequence[AssetPlan], pd.Timestamp,
                                                         int, int]]
                          ) -> list[dict[str, pd.DataFrame]]:
        """:meth:`simulate` of several ``(plans, start, days, first_day)`` requests, their
        asset-days in the same batches.

        A day's telemetry does not depend on which asset-days are simulated with it, while a
        plant's step loop costs about as much for one asset-day as for a batch of them (at
        1 Hz, seconds a day: numpy's cost per call, not per element): two uses of one family
        that need different telemetry simulate it once.

        Returns
        -------
        list of dict
            Per request, what :meth:`simulate` returns for it.
        """
        starts = [_utc(start) for _, start, _, _ in requests]
        elements = [(r, plan, day) for r, (plans, _, days, first_day) in enumerate(requests)
                    for plan in plans for day in range(first_day, days)]
        pieces: list[dict[str, list[dict[str, np.ndarray]]]] = [
            {p.asset_id: [] for p in plans} for plans, _, _, _ in requests]
        for first in range(0, len(elements), self.batch_size):
            chunk = elements[first: first + self.batch_size]
            telemetry = self.simulate_days(self._batch(
                [(plan, day, starts[r]) for r, plan, day in chunk]))
            for i, (r, plan, _) in enumerate(chunk):
                pieces[r][plan.asset_id].append({c: telemetry[c][i] for c in self.channels})
        n = self.samples_per_day
        out = []
        for (plans, _, days, first_day), start, got in zip(requests, starts, pieces):
            frames = {}
            for plan in plans:
                index = pd.date_range(start + pd.Timedelta(days=first_day),
                                      periods=n * (days - first_day),
                                      freq=pd.Timedelta(seconds=self.sample_interval),
                                      name="timestamp")
                frames[plan.asset_id] = pd.DataFrame(
                    {c: np.concatenate([p[c] for p in got[plan.asset_id]])
                     for c in self.channels}, index=index)
            out.append(frames)
        return out

    def _batch(self, chunk) -> DayBatch:
        """The :class:`DayBatch` of ``(plan, day, start)`` elements."""
        names = sorted(self.true_parameters(np.random.default_rng(0)))
        true = {name: [] for name in names}
        onsets = []
        for plan, day, start in chunk:
            drawn = self.true_parameters(np.random.default_rng([plan.seed, 7919]))
            for name in names:
                true[name].append(drawn[name])
            if plan.fault is None or plan.onset is None:
                onsets.append(np.inf)
            else:
                midnight = start + pd.Timedelta(days=day)
                onsets.append((pd.Timestamp(plan.onset) - midnight).total_seconds())
        return DayBatch(
            true={k: np.asarray(v, dtype=float) for k, v in true.items()},
            rngs=[np.random.default_rng([plan.seed, day]) for plan, day, _ in chunk],
            day=np.array([day for _, day, _ in chunk]),
            fault=np.array([plan.fault.name if plan.fault else "" for plan, _, _ in chunk]),
            magnitude=np.array([plan.magnitude for plan, _, _ in chunk], dtype=float),
            onset=np.asarray(onsets, dtype=float))


def _utc(start) -> pd.Timestamp:
    start = pd.Timestamp(start)
    return start.tz_localize("UTC") if start.tzinfo is None else start.tz_convert("UTC")


def day_clock(samples_per_day: int, warmup: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Seconds after midnight and hour of day of ``warmup`` samples before the day and the
    day's ``samples_per_day`` (the warm-up's times are negative): arrays of that total length."""
    t = (np.arange(warmup + samples_per_day) - warmup) * dt
    return t, (t / 3600.0) % 24.0


def spread(rng: np.random.Generator, nominal: float, relative: float) -> float:
    """``nominal`` with a relative normal spread (one asset's unit-to-unit variation)."""
    return float(nominal * (1.0 + relative * rng.standard_normal()))


def smooth_noise(batch: DayBatch, samples: int, correlation_samples: float,
                 scale: float | np.ndarray = 1.0) -> np.ndarray:
    """Per element a stationary first-order (Ornstein-Uhlenbeck) sequence of unit variance
    times ``scale`` with correlation time ``correlation_samples``: (B, samples)."""
    a = float(np.exp(-1.0 / max(correlation_samples, 1e-9)))
    shocks = batch.normal((samples,)) * np.sqrt(1 - a * a)
    out = lfilter([1.0], [1.0, -a], shocks, axis=1)
    out += batch.normal(())[:, None] * (a ** np.arange(1, samples + 1))[None, :]
    return out * (scale if np.ndim(scale) == 0 else np.asarray(scale)[:, None])


def quantise(values: np.ndarray, step: float) -> np.ndarray:
    """A sensor's resolution."""
    return np.round(values / step) * step
