"""Dormancy: an asset that has not operated for longer than ``[alerts] not_operating_after``.

An asset whose new nights all ran too little to monitor is ``not operating`` that run (a
calm turbine, a parked vehicle: :func:`flows.pipeline.settle_calm`); that alone leaves the
run's exit status 0, and its watermark moves past those nights. Once it has lasted longer
than the limit the asset is ``dormant`` instead: not settled, so the run exits 1 every night
it is still not operating, until it operates again or someone decides it may rest (the
limit raised, or ``"off"``). ``stale`` wins over it: a stale asset is never ``not
operating`` (:func:`flows.pipeline.settle_calm`).

How long it has lasted is read from the registry, not counted by the runs: the asset last
operated at the latest window end of its recorded nightly candidates (a night is recorded
only when it ran enough to be compared), or of its baseline's window when that is later (an
asset that never operated since its baseline counts from the baseline's end). That is one
bounded query of its newest candidate versions (:meth:`registry.Registry.recorded_windows`,
not every version of the model), made only for an asset that is ``not operating``, before
its watermark moves: a look-up that fails fails the asset and keeps its watermark, so the
next run looks at the same nights again.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import pandas as pd

from graybox.alert import dormant_alert
from graybox.stage_clock import StageClock, timed

from flows.batching import guard_asset_error
from flows.config import FleetConfig
from flows.config.settings import FROM_ALERTS
from flows.discovery import utc
from flows.pipeline import PendingAsset
from flows.results import DORMANT, NOT_OPERATING

DAY = pd.Timedelta(days=1)


@dataclass(frozen=True)
class LastOperated:
    """When an asset last operated, as the registry knows it.

    Attributes
    ----------
    end : Timestamp
        End (UTC) of its last monitored night, or of its baseline's window.
    baseline_version : int or None
        The baseline whose window end it is, when no monitored night is later (None: a
        recorded candidate's).
    """

    end: pd.Timestamp
    baseline_version: int | None = None

    def describe(self) -> str:
        """``its last monitored night ended 2026-03-07 00:00 UTC``, or the baseline's."""
        when = f"{self.end:%Y-%m-%d %H:%M} UTC"
        if self.baseline_version is None:
            return f"its last monitored night ended {when}"
        return (f"no night monitored since its baseline v{self.baseline_version}, whose "
                f"window ended {when}")


def last_operated(registry, asset_id: str, baseline_version: int, baseline_end,
                  newest: int) -> LastOperated:
    """When the asset last operated: the latest window end among its ``newest`` newest
    recorded candidates, or its baseline's window end (``baseline_end``) when that is later
    or none was recorded.

    ``newest`` must reach past the late windows recorded after its latest night (a late
    window is recorded after the nights past it; :func:`newest_to_read`).
    """
    ends = [utc(end) for _, end in registry.recorded_windows(asset_id, last=newest) if end]
    latest = max(ends, default=None)
    if baseline_end is not None and (latest is None or utc(baseline_end) > latest):
        return LastOperated(utc(baseline_end), baseline_version)
    if latest is None:
        raise ValueError(f"asset {asset_id!r}: neither a recorded candidate nor a baseline "
                         f"window end tells when it last operated")
    return LastOperated(latest)


def newest_to_read(config: FleetConfig) -> int:
    """How many of an asset's newest candidate versions hold its latest night: the late
    windows recorded after it all lie within one ``[nightly] lookback`` before it (at most
    one a window), and twice that leaves room for nights re-analysed after an import."""
    return 2 * (int(config.nightly.lookback_delta // config.nightly.window_delta) + 1)


def is_dormant(last: LastOperated, as_of, limit: pd.Timedelta | None) -> bool:
    """Whether an asset that last operated at ``last`` has not operated for longer than
    ``limit`` before ``as_of`` (never when ``limit`` is None: the check is off)."""
    return limit is not None and utc(as_of) - last.end > limit


def dormancy_limit(config: FleetConfig, vehicle_class: str) -> tuple[str | None, str]:
    """How long an asset of ``vehicle_class`` may not operate (a duration, None: the check
    is off), and the key that says so: its class's ``not_operating_after``, or by default
    (:data:`flows.config.settings.FROM_ALERTS`) ``[alerts] not_operating_after``."""
    own = config.classes.get(vehicle_class)
    if own is not None and own.not_operating_after != FROM_ALERTS:
        return own.not_operating_after, f"[classes.{vehicle_class}] not_operating_after"
    return config.alerts.not_operating_after, "[alerts] not_operating_after"


def dormant_note(last: LastOperated, as_of, limit_text: str,
                 key: str = "[alerts] not_operating_after") -> str:
    """Why an asset is dormant: since when it has not operated, the limit (and the key
    that set it), what to check."""
    age = (utc(as_of) - last.end) / DAY
    return (f"dormant: not operating for {age:.1f} days ({last.describe()}), longer than "
            f"{key} = {limit_text}: is it out of service (then leave "
            f"it out of the fleet, or raise or turn off not_operating_after), or does its "
            f"class's grid drop the time it ran (`running` bounds too strict, or a "
            f"`min_duration` longer than it runs)?")


def settle_dormant(config: FleetConfig, registry, group: Sequence[PendingAsset], as_of,
                   clock: StageClock | None = None) -> None:
    """Each ``not operating`` asset of a nightly group that has not operated for longer
    than its limit (:func:`dormancy_limit`: its class's ``not_operating_after``, by default
    ``[alerts] not_operating_after``) before ``as_of`` becomes ``dormant``, its note saying
    why (:func:`dormant_note`) and its result holding a ``dormant`` alert
    (:func:`graybox.alert.dormant_alert`, one per last monitored night). Called before the
    group's watermarks move: an asset whose look-up fails is failed (its watermark kept); a
    passing failure of the store is raised (the batch is retried)."""
    for pending in group:
        result = pending.result
        if result.status != NOT_OPERATING or pending.reference is None:
            continue
        limit_text, key = dormancy_limit(config, pending.ref.vehicle_class)
        if limit_text is None:
            continue
        limit = pd.Timedelta(limit_text)
        reference = pending.reference
        try:
            with timed(clock, "registry"):
                last = last_operated(registry, pending.asset_id, reference.version,
                                     reference.info.window_end, newest_to_read(config))
        except Exception as error:  # noqa: BLE001 - one asset never stops the batch
            guard_asset_error(error, pending.ref, "looking up when it last operated")
            pending.fail(error)
            continue
        if is_dormant(last, as_of, limit):
            note = dormant_note(last, as_of, limit_text, key)
            result.status = DORMANT
            result.alerts.append(dormant_alert(
                asset_id=pending.asset_id, vehicle_class=pending.ref.vehicle_class,
                last_operated=last.end.isoformat(), age_days=(utc(as_of) - last.end) / DAY,
                limit_days=limit / DAY))
            result.note = note if not result.note else f"{result.note}; {note}"
