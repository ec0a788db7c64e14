"""Zoo runs (:func:`benchmarks.zoo.run.run_family`) with the defaults: a 60-s thermal fleet
detects a fault. The 15-min SCADA pump station, whose every day once failed to read (its
idle pump, its steady power and its historian's held rows read as stuck sensors), is in the
reduced zoo run of every family in tests/benchmarks/test_zoo.py, beside the family checks it
shares its simulations with. """
import pytest

from benchmarks.zoo.families import discover
from benchmarks.zoo.run import run_family
FAMILIES = discover()


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
