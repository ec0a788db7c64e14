"""The plant zoo: its families simulate what they declare, and a reduced zoo run
(:func:`benchmarks.zoo.run.run_family`) fits every baseline with the defaults and stays within
the false-alarm bound. One file, so that each family's telemetry for both is simulated once
(tests/benchmarks/test_zoo_run.py has the other zoo runs)."""
import functools

import numpy as np
import pandas as pd
import pytest
from scipy import stats

import graybox as gb
from benchmarks.zoo import run
from benchmarks.zoo.families import discover
from benchmarks.zoo.family import AssetPlan
from benchmarks.zoo.run import plan_fleet, run_family

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
#: plants whose simulation (20-Hz drive control loops; a pack's evening before each day) and
#: hidden-state or stiff fits cost 1-2 minutes per family even reduced: their baselines and
#: nights run in ``python -m benchmarks.zoo`` (docs/benchmarks.md), not in the suite (the
#: coolant loop's hidden metal node at 10 s: 2 baselines of 5 days cost about 95 s of CPU;
#: the lift-cylinder servo at 10 Hz, 5-9 h of stiff 4-state fits a day: with it in the reduced
#: run this file took over 12 minutes instead of 3.3, stopped unfinished). Measured on the
#: reduced run's own fleet on 2026-11-29 (one process, quiet machine): the coolant loop 26 s
#: of CPU, the pack 17 s, the drive 43 s, against 1-16 s for the others; the pack's run then
#: alarmed on 2 of its 4 healthy nights (its temperature's AR tier), a finding of that day
#: The drum boiler (written blind, 2026-11-29: 1-s substeps of a 5-s log) costs about 15 s of
#: CPU a reduced run on top of its day's simulation for the checks below.
HEAVY = {"ev_battery", "traction_drive", "cooling_loop", "servo_hydraulic", "drum_boiler"}
#: families that miss the false-alarm bound with the protocol's 5-day baseline (a finding,
#: docs/benchmarks.md): the bus's ridership falls at weekends, and the reduced run's two
#: nights are a Saturday and a Sunday against a Monday-to-Friday baseline (one of its four
#: healthy nights alarms)
MISSES = {"bus_longitudinal"}
#: held-out families whose reduced run has a night the product reports as not operating,
#: not scored: the office air-handling unit never runs on Sundays (the night's read is
#: ``no_data``, the product's idle asset); the wind turbine (written blind, 10-min SCADA rows
#: kept by ``running`` on the production time) has a calm night that ran too little to fit
#: (``ShortWindowsError``, settled as not operating). Since 2026-11-28 a baseline leaves such
#: a day out (``Signature.left_out``) and every baseline fits.
IDLE_NIGHTS = {"air_handler", "wind_turbine"}
#: The district-heating substation (15 s, "A sixth blind family"), the heat pump (30 s, "A
#: seventh blind family") and the truck's tyre pressures (60 s, "A ninth blind family") are
#: in the reduced run since 2026-11-29 (about 7, 5 and 1.4 s of CPU): the tyres' reduced run
#: failed a read until a baseline learned how long a coarse reading holds
#: (``Signature.holds``: a 1-kPa tyre pressure held 10 samples on the highway was a
#: stuck_channel).
#: the reduced zoo run: its families and its fleet (5 baseline days, the zoo protocol's own:
#: day-to-day variation is estimated from them)
REDUCED = sorted(set(FAMILIES) - HEAVY - MISSES)
REDUCED_RUN = {"healthy_assets": 2, "baseline_days": 5, "nights": 2, "faulty_per_cell": 0,
               "seed": 3}
#: a reduced-zoo family's fleet telemetry, simulated with its _one_batch (taken once)
_fleets: dict[str, dict[str, pd.DataFrame]] = {}
#: families whose own physics checks run in this file, on the simulation of the checks above:
#: a day of the drum boiler's 1-s loop costs about 12 s of CPU (the suite's time), so its
#: ``Family.fault_days`` are simulated in the same batch (kept in ``_fault_days``)
PHYSICS_HERE = {"drum_boiler"}
_fault_days: dict[str, dict[str, pd.DataFrame]] = {}


@functools.cache
def _one_batch(name: str) -> dict[str, pd.DataFrame]:
    """Day 1 of two healthy vehicles, on the first one's seed one copy per fault kind (large,
    from noon), and last the first vehicle again under another id: one simulation, as the
    drive's 20-Hz loop costs seconds a day. A family of the reduced zoo run simulates that
    run's fleet in the same batch (kept in ``_fleets``): a 1-Hz plant's step loop costs about
    6 s of CPU a call, for one asset-day as for twenty."""
    family = FAMILIES[name]
    plans = [AssetPlan("A-1", 11), AssetPlan("A-2", 12)] + [
        AssetPlan(kind.name, 11, kind, kind.magnitudes[1], ONSET) for kind in family.faults] + [
        AssetPlan("A-1 again", 11)]
    requests = [(plans, START, 2, 1)]
    if name in REDUCED:
        vehicles, _ = plan_fleet(family, REDUCED_RUN["healthy_assets"], 0, REDUCED_RUN["seed"],
                                 REDUCED_RUN["baseline_days"])
        requests.append((vehicles, run.START,
                         REDUCED_RUN["baseline_days"] + REDUCED_RUN["nights"], 0))
    if name in PHYSICS_HERE:
        requests.append((family.fault_day_plans(START), START, 2, 1))
    frames = family.simulate_together(requests)
    if name in REDUCED:
        _fleets[name] = frames[1]
    if name in PHYSICS_HERE:
        _fault_days[name] = frames[-1]
    return frames[0]


def assert_same_telemetry(left: pd.DataFrame, right: pd.DataFrame, **kwargs) -> None:
    """:func:`pandas.testing.assert_frame_equal` of two frames on a ``timestamp`` index, the
    index compared as a column (dtype with its tz, name and every value, exactly): pandas
    compares a datetime index as Timestamp objects one by one, a quarter of a second of CPU
    per 1-Hz day, the same column as int64 nanoseconds."""
    pd.testing.assert_frame_equal(left.reset_index(), right.reset_index(), **kwargs)


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
        # the index's own difference (numpy's diff of a tz-aware index boxes every
        # timestamp: a quarter of a second per 1-Hz day)
        steps = frame.index[1:] - frame.index[:-1]
        assert (steps == pd.Timedelta(seconds=family.sample_interval)).all()
        assert np.isfinite(frame.to_numpy()).all()
    # a day does not depend on which other assets are simulated with it, nor on its place in
    # the batch (each family's simulate_days draws from each asset-day's own generator)
    assert_same_telemetry(frames["A-1"], again)
    assert not frames["A-1"].equals(frames["A-2"])


def test_a_day_simulated_alone_equals_the_same_day_in_a_batch():
    # the shared machinery (Family.simulate, its batches and generators) once, on the
    # cheapest family: a separate simulation of one asset gives the batch's day
    family = FAMILIES["thermal_room"]
    alone = family.simulate([AssetPlan("A-1", 11)], START, 2, first_day=1)["A-1"]
    assert_same_telemetry(_one_batch("thermal_room")["A-1"], alone)


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_every_fault_changes_the_plant_from_its_onset_only(name):
    frames = dict(_one_batch(name))
    healthy = frames.pop("A-1")
    frames.pop("A-2")
    frames.pop("A-1 again")
    assert len(frames) == len(FAMILIES[name].faults)
    before, after = healthy.index < ONSET, healthy.index >= ONSET + pd.Timedelta(hours=1)
    for fault, faulty in frames.items():
        assert_same_telemetry(healthy[before], faulty[before], obj=fault)
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
    assert result["cpu_per_baseline_day"] > 0 and result["cpu_per_night"] > 0
    assert set(result["baseline_cpu_stages"]) == set(result["baseline_stages"])


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


def test_a_parked_bus_reads_as_a_part_at_rest_and_with_its_grid_line_as_operating_periods(
        tmp_path):
    """A finding of the held-out bus family: its wheel-speed sensors read exactly 0 at a
    standstill and a city bus parks for 5-7 hours a night. Without a fleet.toml ``grid``
    line every day's read once failed as a stuck ``speed`` channel. The speed at exactly 0
    while the motor's temperature cools is a part at rest, not a frozen sensor: the day reads
    whole, the parked hours as data. With the family's line (``running`` on the speed, as a
    user would write it) the same day reads as operating periods between the stops; a speed
    sensor frozen at its last reading while the bus drives is still stuck."""
    from graybox.telemetry.writing import write_telemetry

    family = FAMILIES["bus_longitudinal"]
    frame = _one_batch("bus_longitudinal")["A-1"]
    write_telemetry(tmp_path, "A-1", frame)
    model = gb.load_model(family.spec, dict(family.parameters), dict(family.columns))
    begin = START + pd.Timedelta(days=1)
    span = (begin, begin + pd.Timedelta(days=1))
    whole = gb.read_window(tmp_path, "A-1", model.required_columns, *span,
                           policy=gb.GridPolicy(), inputs=model.input_columns)
    assert whole.n_periods == 1 and len(whole.frame) == 86400
    window = gb.read_window(tmp_path, "A-1", model.required_columns, *span,
                            policy=gb.GridPolicy(**dict(family.grid)),
                            inputs=model.input_columns)
    # the day's service (about 17 hours) in many periods between stops
    assert len(window.frame) > 6 * 3600 and len(window.periods()) > 10
    frozen = frame.copy()
    driving = frozen.index[(frozen["speed"] > 5.0).to_numpy()]
    at = frozen.index.get_loc(driving[len(driving) // 2])
    frozen.iloc[at:at + 900, frozen.columns.get_loc("speed")] = frozen["speed"].iloc[at]
    write_telemetry(tmp_path / "frozen", "A-1", frozen)
    with pytest.raises(gb.GrayBoxError, match=r"'speed' stuck at .*stuck_channel"):
        gb.read_window(tmp_path / "frozen", "A-1", model.required_columns,
                       frozen.index[at] - pd.Timedelta(hours=2),
                       frozen.index[at] + pd.Timedelta(hours=2),
                       policy=gb.GridPolicy(), inputs=model.input_columns)


def _bound(trials: int, rate: float = 0.01, level: float = 0.05) -> int:
    """Smallest k with P(Binomial(trials, rate) > k) < level."""
    return next(k for k in range(trials + 1) if stats.binom.sf(k, trials, rate) < level)


@pytest.mark.slow
def test_a_reduced_zoo_fits_every_baseline_with_the_defaults_within_the_false_alarm_bound():
    assert HEAVY | MISSES | IDLE_NIGHTS <= set(FAMILIES)
    assert IDLE_NIGHTS <= set(REDUCED)
    results = []
    for name in REDUCED:
        _one_batch(name)
        # the fleet simulated with the family's checks above (None when already taken: then
        # run_family simulates it, the same telemetry)
        results.append(run_family(FAMILIES[name], **REDUCED_RUN, frames=_fleets.pop(name, None)))
    for result in results:
        assert result["failed_baselines"] == {}, result["family"]
        assert result["baselines_fitted"] == 2
        assert result["failed_nights"] == {}, result["family"]
        if result["family"] not in IDLE_NIGHTS:
            assert result["failed_reads"] == {}, result["family"]
            assert result["false_alarms"]["asset_nights"] == 4
    # a night the product reports as not operating is neither scored nor a failure: the
    # unit's Sunday (each asset's read says the machine did not run), the turbine's calm night
    by_family = {r["family"]: r for r in results}
    unit = by_family["air_handler"]
    assert sorted(unit["failed_reads"]) == ["AIRHAN-001 day 6", "AIRHAN-002 day 6"]
    assert all("[no_data]" in error for error in unit["failed_reads"].values())
    assert unit["false_alarms"]["asset_nights"] == 2
    turbine = by_family["wind_turbine"]
    assert turbine["failed_reads"] == {} and len(turbine["calm_nights"]) == 1
    assert turbine["false_alarms"]["asset_nights"] == 3
    trials = sum(r["false_alarms"]["asset_nights"] for r in results)
    alarms = sum(r["false_alarms"]["alarms"] for r in results)
    assert alarms <= _bound(trials), {r["family"]: r["healthy_tiers"] for r in results}


def _boiler_day() -> dict[str, pd.DataFrame]:
    """Day 1 of one boiler (seed 11) healthy and with each fault at each magnitude from its
    start (``Family.fault_days``), simulated with the boiler's checks above."""
    _one_batch("drum_boiler")
    return _fault_days["drum_boiler"]


def test_the_drum_boilers_loops_hold_the_level_and_the_pressure_and_a_load_step_swells():
    """The drum boiler (written blind) simulates the physics its docstring sizes the faults
    by: its loops hold, a load step swells then shrinks the level."""
    frame = _boiler_day()["healthy"]
    level, pressure = frame["drum_level"], frame["drum_pressure"]
    assert abs(level.median()) < 3.0 and 5.0 < level.std() < 25.0
    assert level.abs().quantile(0.99) < 60.0
    assert (pressure - pressure.median()).abs().quantile(0.99) < 0.5
    # steps up of the steam drawn (over 2.5 t/h within a minute): the level first rises
    # (flashing in the risers: swell), then falls below where it was (shrink)
    steam = frame["steam_flow"].rolling(12).mean().to_numpy()
    rise = np.flatnonzero(steam[12:] - steam[:-12] > 2.5) + 12
    starts = [i for k, i in enumerate(rise) if (k == 0 or i - rise[k - 1] > 60)
              and 24 < i < len(frame) - 100]
    assert len(starts) > 10
    smooth = level.rolling(6, center=True).mean().to_numpy()
    response = np.mean([smooth[i - 12: i + 60] - smooth[i - 12] for i in starts], axis=0)
    assert response[:30].max() > 10.0                   # swell within 2.5 minutes
    assert response[36:].min() < -5.0                    # then shrink, 4-6 minutes after


def test_the_drum_boilers_large_faults_change_what_they_should_physically():
    frames = _boiler_day()
    healthy = frames["healthy"]

    def change(fault, column):
        return frames[fault][column].mean() - healthy[column].mean()

    # the same process demand (a counterfactual pair): the steam drawn barely moves
    for fault in frames:
        assert abs(change(fault, "steam_flow")) < 0.02, fault
    # water lost from the circuit: fed on top of the steam (t/h)
    assert abs(change("tube_leak/large", "feedwater_flow") - 0.3 * 3.6) < 0.1
    assert abs(change("safety_valve_passing/large", "feedwater_flow") - 0.25 * 3.6) < 0.1
    fuel = healthy["fuel_flow"].mean()
    assert 0.02 < change("safety_valve_passing/large", "fuel_flow") / fuel < 0.04
    # fouling: more gas, a hotter stack and feedwater, the same water
    assert 0.015 < change("fireside_fouling/large", "fuel_flow") / fuel < 0.04
    assert 25.0 < change("fireside_fouling/large", "flue_gas_temp") < 50.0
    assert 0 < change("fireside_fouling/small", "flue_gas_temp") < change(
        "fireside_fouling/large", "flue_gas_temp")
    assert abs(change("fireside_fouling/large", "feedwater_flow")) < 0.05
    # a meter reading 4 % high: the same water, 4 % more of it on the meter
    ratio = frames["feedwater_meter/large"]["feedwater_flow"].sum() / healthy[
        "feedwater_flow"].sum()
    assert abs(ratio - 1.04) < 0.005
    assert abs(change("feedwater_meter/large", "fuel_flow")) / fuel < 0.002


def test_a_baseline_leaves_out_the_days_its_machine_did_not_run_as_the_baseline_flow_does():
    from benchmarks.zoo.run import baseline_days_read

    idle = "asset 'B': the machine did not run in [...] (grid running) [no_data]"
    short = "asset 'C': the window covers 50min (5 samples at 600 s), ... [too_few_samples]"
    broken = "asset 'D': row 12 of .../part.parquet: timestamp not increasing [bad_row]"
    windows = {(a, d): object() for a in "ABCD" for d in range(5)}
    del windows["B", 2], windows["C", 3], windows["C", 4], windows["D", 1]
    windows["F", 4] = object()   # E never ran; F ran on one day only
    failed = {"B day 2": idle, "C day 3": short, "C day 4": short, "D day 1": broken,
              **{f"E day {d}": idle for d in range(5)},
              **{f"F day {d}": idle for d in range(4)}}
    # B and C keep their other days; D's broken day is a failure, not an idle day; E and F
    # keep what they have (none, one day), which run_family fails as fewer than three
    assert baseline_days_read(list("ABCDEF"), 5, windows, failed) == {
        "A": [0, 1, 2, 3, 4], "B": [0, 1, 3, 4], "C": [0, 1, 2], "E": [], "F": [4]}
