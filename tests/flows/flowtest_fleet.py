"""The small simulated fleet the flow tests share (constants and helpers)."""
from __future__ import annotations

import pandas as pd

START = pd.Timestamp("2026-01-01", tz="UTC")
DAYS = 6
BASELINE_DAYS = 3
ASSETS = ("T-001", "T-002", "T-003", "T-004", "T-005")
#: asset -> (fault kind, onset day, magnitude): sensor noise x4 from day 4, flutter from day 5.
#: (At 30-s samples the random moment integrated over a sample dominates the one-step
#: residual, so a doubled sensor noise is below what it can show; x4 is clear.)
FAULTY = {"T-002": ("noise", 3.0, 3.0), "T-004": ("nonlinear", 4.0, 0.5)}


def day(i: int) -> pd.Timestamp:
    """Midnight (UTC) starting day ``i`` of the fleet (0-based)."""
    return START + pd.Timedelta(days=i)


def assert_the_others_ran_every_night(by_asset: dict, registry, failed: str) -> None:
    """Every asset but ``failed`` is "ok" in a run's summary (``by_asset``: asset id -> its
    summary entry), with a window for every night after the baseline and its watermark at
    the last night's end."""
    for asset in set(ASSETS) - {failed}:
        assert by_asset[asset]["status"] == "ok", by_asset[asset]
        assert len(by_asset[asset]["windows"]) == DAYS - BASELINE_DAYS
        assert registry.watermark(asset) == day(DAYS)
