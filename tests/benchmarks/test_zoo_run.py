"""A reduced zoo run (:func:`benchmarks.zoo.run.run_family`) fits every baseline with the
defaults and stays within the false-alarm bound, and a 60-s thermal fleet detects a fault.
Apart from tests/benchmarks/test_zoo.py so that the two slow files run on different workers."""
import pytest
from scipy import stats

from benchmarks.zoo.families import discover
from benchmarks.zoo.run import run_family
FAMILIES = discover()
#: plants whose simulation (20-Hz drive control loops; a pack's evening before each day) and
#: hidden-state or stiff fits cost 1-2 minutes per family even reduced: their baselines and
#: nights run in ``python -m benchmarks.zoo`` (docs/benchmarks.md), not in the suite (the
#: coolant loop's hidden metal node at 10 s: 2 baselines of 5 days cost about 95 s of CPU)
HEAVY = {"ev_battery", "traction_drive", "cooling_loop"}
#: families that miss the false-alarm bound with the protocol's 5-day baseline (a finding,
#: docs/benchmarks.md): the bus's ridership falls at weekends, and the reduced run's two
#: nights are a Saturday and a Sunday against a Monday-to-Friday baseline
MISSES = {"bus_longitudinal"}
#: families whose telemetry the defaults cannot read at all (issue 18's blind families, a
#: finding): the 15-min SCADA export's pumps stand still for hours (pump_flow 0.0 for 10+
#: samples) and a fixed-speed pump's power holds one 0.5-kW value for hours, both read as
#: stuck sensors (its 96 samples a day are enough since min_samples = "auto")
UNREADABLE = {"pump_station"}


def _bound(trials: int, rate: float = 0.01, level: float = 0.05) -> int:
    """Smallest k with P(Binomial(trials, rate) > k) < level."""
    return next(k for k in range(trials + 1) if stats.binom.sf(k, trials, rate) < level)


@pytest.mark.slow
def test_a_reduced_zoo_fits_every_baseline_with_the_defaults_within_the_false_alarm_bound():
    assert HEAVY <= set(FAMILIES) and MISSES <= set(FAMILIES) and UNREADABLE <= set(FAMILIES)
    # 5 baseline days, the zoo protocol's own: day-to-day variation is estimated from them
    results = [run_family(family, healthy_assets=2, baseline_days=5, nights=2, faulty_per_cell=0,
                          seed=3) for family in FAMILIES.values()
               if family.name not in HEAVY | MISSES | UNREADABLE]
    for result in results:
        assert result["failed_reads"] == {} and result["failed_nights"] == {}, result["family"]
        assert result["failed_baselines"] == {}, result["family"]
        assert result["baselines_fitted"] == 2
        assert result["false_alarms"]["asset_nights"] == 4
    trials = sum(r["false_alarms"]["asset_nights"] for r in results)
    alarms = sum(r["false_alarms"]["alarms"] for r in results)
    assert alarms <= _bound(trials), {r["family"]: r["healthy_tiers"] for r in results}


@pytest.mark.slow
def test_a_slow_thermal_fleet_at_60_s_baselines_and_detects_a_fault_with_the_defaults():
    """Issue 18's starting point: 1-minute rooms once failed every baseline (27 samples a day
    at a 3120-s analysis interval). With the defaults they baseline at a rate that keeps a
    day's samples, and a failing insulation alarms on the wall's level tier."""
    family = FAMILIES["thermal_room"]
    result = run_family(family, healthy_assets=2, baseline_days=5, nights=3, faulty_per_cell=1,
                        seed=3)
    assert result["failed_baselines"] == {} and result["baselines_fitted"] == 2
    # 1,440 samples a day are fewer than the tiers' samples_per_window: no decimation at all
    assert result["analysis_intervals"] == [60.0]
    assert result["false_alarms"]["alarms"] == 0
    insulation = result["detection"]["insulation", "large"]
    assert insulation["detected"] == insulation["assets"] == 1
    assert insulation["alarmed_before_onset"] == 0


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="issue 18 finding: a 15-min SCADA export's idle pump "
                   "and steady power read as stuck sensors; remove when the defaults read it")
def test_a_fifteen_minute_scada_pump_station_baselines_with_the_defaults():
    result = run_family(FAMILIES["pump_station"], healthy_assets=2, baseline_days=5, nights=2,
                        faulty_per_cell=0, seed=3)
    assert result["failed_reads"] == {} and result["failed_baselines"] == {}
    assert result["baselines_fitted"] == 2
