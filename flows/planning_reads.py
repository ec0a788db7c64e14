"""What a night's planning reads of the registry about a batch of assets, read together.

Planning an asset reads its watermark, the windows its newest candidates cover (the
look-back's late windows) and its baseline's window end; one asset at a time that is four
queries each (about 5 ms of the 6.4 ms an up-to-date asset took to plan at N = 1,000).
:meth:`PlanningReads.read` reads them for the whole batch in four queries
(:meth:`registry.Registry.watermarks`, :meth:`~registry.Registry.recorded_windows_of`,
:meth:`~registry.Registry.baseline_window_ends`), and :func:`flows.nightly.plan_asset` asks
it what it would ask the registry: the same three methods, the same answers. An asset or a
``last`` outside what was read is asked of the registry. Should the batch's reads fail, the
batch is planned asset by asset as before, so that each asset gets its own error; a passing
failure of the store (:func:`flows.results.is_transient`) is the batch's, which is retried.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Sequence

import pandas as pd

from graybox.stage_clock import StageClock, timed

from flows.config import FleetConfig
from flows.discovery import utc
from flows.errors import TransientError
from flows.results import is_transient
from flows.run_logger import run_logger

logger = logging.getLogger(__name__)


def versions_to_read(config: FleetConfig, watermark: pd.Timestamp, as_of: pd.Timestamp) -> int:
    """How many of an asset's newest versions hold every candidate recorded in its
    look-back (``[nightly] lookback`` before the watermark, up to ``as_of``): one a night,
    and room for baselines refitted in between."""
    window = config.nightly.window_delta
    earliest = watermark - config.nightly.lookback_delta
    return 2 * (int(-(-(utc(as_of) - earliest) // window)) + 1)


@dataclass(frozen=True)
class PlanningReads:
    """The registry's answers about a batch's assets (:meth:`read`), asked like the registry.

    Attributes
    ----------
    registry : registry.Registry
        Asked whatever was not read.
    marks : dict
        Per asset, its watermark (None: none yet).
    ends : dict
        Per asset, its baseline's window end (None: no baseline).
    recorded : dict
        Per asset with a watermark, the windows of its ``last`` newest candidates.
    last : int
        How many newest candidates ``recorded`` holds per asset.
    """

    registry: object
    marks: dict
    ends: dict
    recorded: dict
    last: int

    @classmethod
    def read(cls, config: FleetConfig, registry, asset_ids: Sequence[str], as_of,
             clock: StageClock | None = None) -> "PlanningReads | None":
        """The batch's reads, or None when they failed (the batch is then planned asset by
        asset, each with its own error) or there is no asset."""
        if not asset_ids:
            return None
        try:
            with timed(clock, "registry"):
                marks = registry.watermarks(asset_ids)
                # without a look-back a watermark is all an asset's planning reads
                marked = ([asset for asset, mark in marks.items() if mark is not None]
                          if config.nightly.lookback_delta > pd.Timedelta(0) else [])
                last = max((versions_to_read(config, marks[asset], as_of) for asset in marked),
                           default=0)
                recorded = registry.recorded_windows_of(marked, last) if marked else {}
                ends = registry.baseline_window_ends(marked) if marked else {}
        except Exception as error:  # noqa: BLE001 - each asset then reads (and fails) alone
            if is_transient(error):   # the store is away: the batch is retried
                raise TransientError(f"reading the registry for {len(asset_ids)} asset(s): "
                                     f"{type(error).__name__}: {error}") from error
            run_logger(logger).warning("reading the registry for %d assets together failed "
                                       "(%s: %s); each asset reads alone", len(asset_ids),
                                       type(error).__name__, error)
            return None
        return cls(registry, marks, ends, recorded, last)

    def watermark(self, asset_id: str) -> pd.Timestamp | None:
        if asset_id in self.marks:
            return self.marks[asset_id]
        return self.registry.watermark(asset_id)

    def recorded_windows(self, asset_id: str, last: int) -> list[tuple[str, str]]:
        if asset_id in self.recorded and last <= self.last:
            return self.recorded[asset_id][:last]
        return self.registry.recorded_windows(asset_id, last=last)

    def baseline_window_end(self, asset_id: str) -> pd.Timestamp | None:
        if asset_id in self.ends:
            return self.ends[asset_id]
        return self.registry.baseline_window_end(asset_id)
