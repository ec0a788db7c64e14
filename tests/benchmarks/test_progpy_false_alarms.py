"""Issue 10 item 5, must show: the realized false-alarm rate on a healthy ProgPy-simulated
fleet is within its target (the reduced version; the full count is the benchmark's,
docs/benchmarks.md).

The same :func:`benchmarks.detection.progpy_false_alarms.run` as the benchmark, on 4 pumps
(2 continuous, 2 intermittent sharing one stop schedule, to simulate it once), 3 baseline
windows of 1 h and 3 nightly windows each: 12 asset-nights, five channels, real ProgPy
simulation and real fits, candidates as the product fits them by default (each window with
the one before it, ``[nightly] candidate_nights = 2``).

The rule: with n asset-nights and a true rate of 1 %, the alarms are Binomial(n, 0.01); the
test allows the smallest k with P(Binomial(n, 0.01) > k) < 5 % (k = 1 for n = 12), so a
fleet calibrated to its target fails it less than 1 time in 20, while a rate far above the
target (say 15 %, 2 or more alarms with probability 55 %) fails it more often than not.
"""
from __future__ import annotations

import pytest
from scipy import stats

pytest.importorskip("progpy")

from benchmarks.detection.progpy_false_alarms import run  # noqa: E402

TARGET = 0.01
ASSETS, INTERMITTENT, BASELINE_WINDOWS, NIGHTS = 4, 2, 3, 3


def allowed_alarms(trials: int, rate: float, level: float = 0.05) -> int:
    """The smallest k with P(Binomial(trials, rate) > k) < level."""
    k = 0
    while stats.binom.sf(k, trials, rate) >= level:
        k += 1
    return k


def test_allowed_alarms_follows_the_binomial_tail():
    assert allowed_alarms(12, 0.01) == 1        # P(X > 0) = 11.4 %, P(X > 1) = 0.62 %
    assert allowed_alarms(216, 0.01) == 5       # P(X > 4) = 6.7 %, P(X > 5) = 2.2 %
    assert allowed_alarms(5, 0.001) == 0


@pytest.mark.slow
def test_healthy_progpy_fleet_with_intermittent_pumps_stays_within_its_false_alarm_target():
    result = run(ASSETS, BASELINE_WINDOWS, NIGHTS, window_hours=1.0, seed=1,
                 intermittent=INTERMITTENT, stop_schedules=1, false_alarm_rate=TARGET)

    # nothing failed and every asset-night was scored (none silently skipped)
    assert result["failed_reads"] == {}
    assert result["failed_baselines"] == {}
    assert result["failed_candidates"] == {}
    rows = result["rows"]
    assert sorted((r["asset"], r["night"]) for r in rows) == sorted(
        (f"P-{a:03d}", k) for a in range(1, ASSETS + 1) for k in range(NIGHTS))
    assert result["model"].states == ("w", "Q", "Tt", "Tr", "To")
    # the intermittent pumps really stop: their nights hold several operating periods,
    # the continuous pumps' one
    periods = {r["group"]: set() for r in rows}
    for r in rows:
        periods[r["group"]].add(r["periods"])
    assert periods["continuous"] == {1}
    assert max(periods["intermittent"]) >= 2
    assert result["continuous"]["asset_nights"] == result["intermittent"]["asset_nights"] == 6

    assert result["candidate_windows"] == 2     # the product's default span

    n = result["overall"]["asset_nights"]
    assert n == ASSETS * NIGHTS
    assert result["overall"]["alarms"] <= allowed_alarms(n, TARGET), result["by_tier"]
