"""The plant zoo: its families simulate what they declare (the reduced zoo run is in
tests/benchmarks/test_zoo_run.py)."""
import functools

import numpy as np
import pandas as pd
import pytest

import graybox as gb
from benchmarks.zoo.families import discover
from benchmarks.zoo.family import AssetPlan
from benchmarks.zoo.run import plan_fleet

FAMILIES = discover()
START = pd.Timestamp("2026-03-01", tz="UTC")


def test_the_zoo_has_the_families_the_benchmark_promises():
    assert len(FAMILIES) >= 6
    rates = {f.sample_interval for f in FAMILIES.values()}
    assert 60.0 in rates and 1.0 in rates
    assert any(f.grid.get("intermittent") for f in FAMILIES.values())
    held_out = [f for f in FAMILIES.values() if f.held_out]
    assert 0 < len(held_out) < len(FAMILIES)
    for family in FAMILIES.values():
        assert 3 <= len(family.faults) <= 6
        assert all(0 < small < large for small, large in (k.magnitudes for k in family.faults))
        # the white box loads with the family's column map only, and reads declared channels
        model = gb.load_model(family.spec, dict(family.parameters), dict(family.columns))
        assert set(model.required_columns) <= set(family.channels)
        assert not family.spec.startswith("graybox.")


ONSET = START + pd.Timedelta(days=1, hours=12)


@functools.cache
def _one_batch(name: str) -> dict[str, pd.DataFrame]:
    """Day 1 of two healthy vehicles, on the first one's seed one copy per fault kind (large,
    from noon), and last the first vehicle again under another id: one simulation, as the
    drive's 20-Hz loop costs seconds a day."""
    family = FAMILIES[name]
    plans = [AssetPlan("A-1", 11), AssetPlan("A-2", 12)] + [
        AssetPlan(kind.name, 11, kind, kind.magnitudes[1], ONSET) for kind in family.faults] + [
        AssetPlan("A-1 again", 11)]
    return family.simulate(plans, START, 2, first_day=1)


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_a_family_simulates_its_channels_deterministically(name):
    family = FAMILIES[name]
    frames = dict(_one_batch(name))
    again = frames.pop("A-1 again")
    day = family.samples_per_day
    for frame in frames.values():
        assert list(frame.columns) == list(family.channels)
        assert len(frame) == day and frame.index.name == "timestamp"
        assert str(frame.index.tz) == "UTC" and frame.index[0] == START + pd.Timedelta(days=1)
        assert (np.diff(frame.index) == pd.Timedelta(seconds=family.sample_interval)).all()
        assert np.isfinite(frame.to_numpy()).all()
    # a day does not depend on which other assets are simulated with it, nor on its place in
    # the batch (each family's simulate_days draws from each asset-day's own generator)
    pd.testing.assert_frame_equal(frames["A-1"], again)
    assert not frames["A-1"].equals(frames["A-2"])


def test_a_day_simulated_alone_equals_the_same_day_in_a_batch():
    # the shared machinery (Family.simulate, its batches and generators) once, on the
    # cheapest family: a separate simulation of one asset gives the batch's day
    family = FAMILIES["thermal_room"]
    alone = family.simulate([AssetPlan("A-1", 11)], START, 2, first_day=1)["A-1"]
    pd.testing.assert_frame_equal(_one_batch("thermal_room")["A-1"], alone)


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_every_fault_changes_the_plant_from_its_onset_only(name):
    frames = dict(_one_batch(name))
    healthy = frames.pop("A-1")
    frames.pop("A-2")
    frames.pop("A-1 again")
    assert len(frames) == len(FAMILIES[name].faults)
    before, after = healthy.index < ONSET, healthy.index >= ONSET + pd.Timedelta(hours=1)
    for fault, faulty in frames.items():
        pd.testing.assert_frame_equal(healthy[before], faulty[before], obj=fault)
        assert not np.allclose(healthy[after].to_numpy(), faulty[after].to_numpy()), fault


def test_faulty_assets_share_their_vehicles_seed_and_start_on_the_first_scored_night():
    family = FAMILIES["thermal_room"]
    vehicles, faulty = plan_fleet(family, 3, 1, seed=2, baseline_days=4)
    assert len(faulty) == 2 * len(family.faults)
    night = pd.Timestamp("2026-01-05", tz="UTC") + pd.Timedelta(days=4)
    seeds = {v.seed for v in vehicles}
    for plan in faulty:
        assert plan.seed in seeds
        assert night <= plan.onset < night + pd.Timedelta(days=1)


def test_the_cost_benchmark_measures_a_small_family_run():
    from benchmarks.zoo.cost import measure
    result = measure(FAMILIES["thermal_room"], assets=1, baseline_days=3, nights=1)
    assert result["s_per_baseline_day"] > 0 and result["s_per_night"] > 0
    assert result["analysis_interval"] == 60.0 and result["states"] == 2
    assert "residual" in result["baseline_stages"] and "residual" in result["night_stages"]


def test_envelope_places_each_healthy_night_against_the_baseline_range():
    from benchmarks.zoo import run
    from benchmarks.zoo.envelope import outside_distances

    family = discover()["thermal_room"]
    vehicles, _ = plan_fleet(family, 1, 0, 1, 3)
    asset = vehicles[0].asset_id
    result = {"baseline_days": 3, "nights": 2, "candidate_nights": 1, "healthy_assets": 1,
              "seed": 1, "rows": [
                  {"asset": asset, "night": 0, "fault": "", "alarm": False, "exceeded": ""},
                  {"asset": asset, "night": 1, "fault": "", "alarm": True,
                   "exceeded": "air/level"}]}
    frame = outside_distances(family, result, "outdoor_temp")
    assert list(frame["night"]) == [0, 1] and list(frame["alarm"]) == [False, True]
    # night n is day 3 + n; its distance is its daily mean outside the range of days 0-2
    telemetry = family.simulate(vehicles, run.START, 5)[asset]["outdoor_temp"]
    means = [telemetry[run.START + pd.Timedelta(days=d):
                       run.START + pd.Timedelta(days=d + 1) - pd.Timedelta(seconds=1)].mean()
             for d in range(5)]
    expected = [max(0.0, means[d] - max(means[:3]), min(means[:3]) - means[d]) for d in (3, 4)]
    np.testing.assert_allclose(frame["outside"], expected, rtol=1e-12)


def test_a_parked_bus_reads_with_its_grid_line_and_without_it_is_told_which_setting_helps(
        tmp_path):
    """A finding of the held-out bus family: its wheel-speed sensors read exactly 0 at a
    standstill and a city bus parks for 5-7 hours a night, so without a fleet.toml ``grid``
    line (``stuck_after`` 10 min on every sensor) every day's read fails as a stuck ``speed``
    channel. The error names the setting that helps; with it (the family's line, as a user
    would write it) the same day reads as operating periods."""
    from graybox.telemetry.writing import write_telemetry

    family = FAMILIES["bus_longitudinal"]
    frame = _one_batch("bus_longitudinal")["A-1"]
    write_telemetry(tmp_path, "A-1", frame)
    model = gb.load_model(family.spec, dict(family.parameters), dict(family.columns))
    begin = START + pd.Timedelta(days=1)
    span = (begin, begin + pd.Timedelta(days=1))
    with pytest.raises(gb.GrayBoxError,
                       match=r"'speed' stuck at 0\.0.*intermittent = true.*stuck_channel"):
        gb.read_window(tmp_path, "A-1", model.required_columns, *span,
                       policy=gb.GridPolicy(), inputs=model.input_columns)
    window = gb.read_window(tmp_path, "A-1", model.required_columns, *span,
                            policy=gb.GridPolicy(**dict(family.grid)),
                            inputs=model.input_columns)
    # the day's service (about 17 hours) in many periods between stops
    assert len(window.frame) > 6 * 3600 and len(window.periods()) > 10
