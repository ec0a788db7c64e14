"""The level tier: its statistic, its record, its drift and calibration, and the bias step
it exists for (the white box 20 % off)."""
import dataclasses
import json
import pathlib

import numpy as np
import pandas as pd
import pytest

from graybox import Calibration, FitRequest, Signature, compute_drift, fit_baselines, fit_signatures
from graybox.drift import Drift
from graybox.analysis_rate import fastest_rate
from graybox.level_tier import (LevelTier, extrapolation, fit_level, horizon_samples,
                                k_step_prediction, level_data, level_horizon,
                                operating_features)
from graybox.models.base import WhiteBoxModel
from graybox.operating_conditions import operating_conditions
from graybox.record_json import from_dict, to_dict
from graybox.models.gas_turbine import GasTurbineShaft, LangevinShaft
from graybox.residual import one_step_residual
from graybox.rk4 import rk4_step
from graybox.signature import check_consistent
from graybox.simulation import Fault, FleetSpec, VehicleSpec, simulate_fleet, white_box_parameters
from graybox.calibration import TierThreshold
from graybox.tiers import TIER_KINDS, tier_kind
from graybox.alert import alerts_from_drift
from tests.graybox.conftest import make_channel, make_signature

DATA = pathlib.Path(__file__).parent / "data"
DT = 10.0


def _free_run(model, x0, u, dt=DT, substeps=2):
    """The model's own trajectory from x0 under inputs u (the sequential reference)."""
    x = np.empty((len(u), 1))
    x[0] = x0
    h = dt / substeps
    for t in range(1, len(u)):
        state = x[t - 1:t].copy()
        u0, u1 = u[t - 1:t], u[t:t + 1]
        for step in range(substeps):
            b = step / substeps
            state = rk4_step(model.derivatives, state, u0 + (u1 - u0) * b,
                             u0 + (u1 - u0) * (b + 0.5 / substeps),
                             u0 + (u1 - u0) * (b + 1.0 / substeps), h)
        x[t] = state[0]
    return x


def _langevin_frame(bias=0.0, n=3000, seed=0):
    model = LangevinShaft()
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    fuel = 1.0 + 0.2 * np.sin(2 * np.pi * t / 700) + 0.05 * rng.standard_normal(n).cumsum() / 30
    u = fuel.reshape(-1, 1)
    x = _free_run(model, model.default_parameters["omega_ref"], u)
    index = pd.date_range("2026-01-01", periods=n, freq="10s", tz="UTC")
    return model, pd.DataFrame({"omega": x[:, 0] + bias, "fuel_rate": fuel}, index=index)


def test_one_step_prediction_is_the_residuals_prediction():
    model, frame = _langevin_frame(n=400)
    x, u = frame[["omega"]].to_numpy(), frame[["fuel_rate"]].to_numpy()
    predicted = k_step_prediction(model, x, u, DT, 1)
    np.testing.assert_allclose(x[1:] - predicted, one_step_residual(model, x, u, DT), atol=1e-12)


def test_k_step_prediction_of_the_models_own_trajectory_is_exact():
    model, frame = _langevin_frame(n=400)
    x, u = frame[["omega"]].to_numpy(), frame[["fuel_rate"]].to_numpy()
    np.testing.assert_allclose(k_step_prediction(model, x, u, DT, 12), x[12:], atol=1e-9)


def test_the_level_of_a_biased_sensor_is_its_bias():
    # the white box's own trajectory plus a constant bias: the 12-step prediction starts from
    # the biased state and forgets it (gamma 0.06 1/s over 120 s), so the error is the bias
    model, frame = _langevin_frame(bias=0.5)
    k = horizon_samples(DT)
    assert k == 12
    errors, features, _ = level_data(model, [frame], DT, k)["omega"]
    level = fit_level(errors, features, k)
    assert level.level == pytest.approx(0.5 * (1 - np.exp(-0.06 * 120)), rel=0.02)
    assert level.n_obs == len(frame) - k and level.horizon == 12


def test_the_horizon_is_twelve_steps_of_the_interval_the_dynamics_ask_for():
    # 500 s asks for 250-s steps, 4 analysis intervals of 60 s: 12 x 250 s is 50 steps,
    # rounded up to the rung 64 (2^n or 1.5 * 2^n)
    assert level_horizon(500.0, 60.0, [1440], 200) == 64
    # a slower plant: the caps decide, the last rung within half a 200-sample piece ...
    assert level_horizon(3000.0, 60.0, [1440], 200) == 96
    # ... or within half the median operating segment, or the cost cap
    assert level_horizon(1500.0, 60.0, [30, 90, 1440], 200) == 32
    assert level_horizon(200.0, 1.0, [86400], 10800) == 256
    # caps that leave the horizon shorter than one fastest time constant: the fixed horizon
    # (a 12-h tank at 15 min, capped at 24 steps = 6 h; a 2-h room capped at 96 minutes)
    assert level_horizon(12 * 3600.0, 900.0, [96], 48) == horizon_samples(900.0) == 1
    assert level_horizon(7200.0, 60.0, [1440], 200) == 2
    assert level_horizon(5400.0, 60.0, [1440], 200) == 96
    # nor does a mode that never decays
    assert level_horizon(500.0, 60.0, [1440], 200, integrating=True) == 2
    # a plant analysed at (more than half) the interval it asks for keeps the fixed 120 s:
    # the gas turbine's shaft (1 / 0.06 s) at 8 s and 10 s, a 200-s plant at 60 s; as does
    # a model without dynamics
    assert level_horizon(1 / 0.06, 10.0, [8640], 1080) == horizon_samples(10.0) == 12
    assert level_horizon(1 / 0.06, 8.0, [10800], 1350) == horizon_samples(8.0) == 12
    assert level_horizon(200.0, 60.0, [1440], 200) == horizon_samples(60.0) == 2
    assert level_horizon(0.0, 10.0, [8640], 1080) == 12


def test_a_slow_plants_level_carries_its_bias():
    # a shaft that settles in 1000 s, logged every 60 s: the fixed 120-s horizon (2 steps)
    # keeps 1 - exp(-0.12) = 11 % of a sensor bias; 96 steps (the piece's cap) keep it all
    model = LangevinShaft({"gamma": 1e-3, "fuel_gain": 0.05})
    rng = np.random.default_rng(3)
    n, dt = 1440, 60.0
    fuel = 1.0 + 0.2 * np.sin(2 * np.pi * np.arange(n) / 400) + 0.02 * rng.standard_normal(n)
    x = _free_run(model, 1000.0, fuel.reshape(-1, 1), dt=dt)
    index = pd.date_range("2026-01-01", periods=n, freq="60s", tz="UTC")
    frame = pd.DataFrame({"omega": x[:, 0] + 0.5, "fuel_rate": fuel}, index=index)
    assert fastest_rate(model, [frame]) == pytest.approx(1e-3, rel=1e-6)
    k = level_horizon(1 / fastest_rate(model, [frame]), dt, [n], 200)
    assert k == 96
    for steps, kept in ((horizon_samples(dt), 1 - np.exp(-0.12)), (k, 1 - np.exp(-k * 0.06))):
        errors, features, _ = level_data(model, [frame], dt, steps)["omega"]
        assert fit_level(errors, features, steps).level == pytest.approx(0.5 * kept, rel=0.02)


def test_fit_level_returns_the_intercept_at_the_baselines_operating_point():
    rng = np.random.default_rng(1)
    features = rng.normal([100.0, 1.0], [5.0, 0.2], size=(5000, 2))
    errors = 0.7 + 0.3 * (features[:, 0] - 100.0) - 2.0 * (features[:, 1] - 1.0)
    baseline = fit_level(errors + 1e-3 * rng.standard_normal(5000), features, 12)
    assert baseline.level == pytest.approx(0.7 + 0.3 * (baseline.center[0] - 100.0)
                                           - 2.0 * (baseline.center[1] - 1.0), abs=1e-4)
    assert baseline.slopes == pytest.approx((0.3, -2.0), abs=1e-4)
    assert baseline.residual_std == pytest.approx(1e-3, rel=0.05)
    # a candidate at another operating point, with the same relation plus a step of 0.25:
    # its level, read at the baseline's centre with the baseline's slopes, moves by the step
    shifted = features[:800] + [8.0, 0.1]
    candidate_errors = 0.95 + 0.3 * (shifted[:, 0] - 100.0) - 2.0 * (shifted[:, 1] - 1.0)
    candidate = fit_level(candidate_errors, shifted, 12, baseline)
    assert (candidate.center, candidate.slopes) == (baseline.center, baseline.slopes)
    assert candidate.level - baseline.level == pytest.approx(0.25, abs=1e-3)
    assert candidate.n_obs == 800


def _level(value, std=0.05):
    return LevelTier(value, (0.1, -0.2), (100.0, 1.0), std, 12, 8000)


def test_a_signature_with_the_level_tier_round_trips_json():
    signature = make_signature((dataclasses.replace(make_channel(), level=_level(0.4)),))
    again = Signature.from_json(signature.to_json())
    assert again == signature
    assert again.channel("omega").level == _level(0.4)
    names, values = signature.parameter_vector()
    assert names[-1] == "omega.level.level" and values[-1] == 0.4


def test_an_older_signature_without_the_tier_loads_and_has_no_level_drift():
    text = (DATA / "signature_v1.json").read_text().strip()
    old = Signature.from_json(text)
    assert all(c.level is None for c in old.channels)
    assert "level" not in json.loads(text)["channels"][0]
    assert old.to_json() == text                       # written back as the old code did
    calibration = Calibration.from_json((DATA / "calibration_v1.json").read_text())
    assert "level" not in {t.tier for t in calibration.thresholds}   # older calibrations load
    drift = compute_drift(old, old)
    assert {e.tier for e in drift.entries} == {"linear", "nonlinear", "noise"}
    # a candidate with the tier against a baseline without it: the tier is not compared
    new = dataclasses.replace(old, channels=tuple(dataclasses.replace(c, level=_level(0.1))
                                                  for c in old.channels))
    assert "level" not in {e.tier for e in compute_drift(new, old).entries}


def test_inconsistent_level_record_is_refused():
    bad = LevelTier(0.1, (0.1,), (100.0, 1.0), 0.05, 12, 8000)
    with pytest.raises(Exception, match="level must have as many slopes"):
        check_consistent(make_signature((dataclasses.replace(make_channel(), level=bad),)))


def test_level_drift_is_the_squared_move_in_residual_standard_deviations():
    baseline = make_signature((dataclasses.replace(make_channel(), level=_level(0.40)),))
    candidate = make_signature((dataclasses.replace(make_channel(), level=_level(0.55)),))
    assert tier_kind("level").deltas(candidate.channels[0], baseline.channels[0]) == \
        pytest.approx([3.0])
    entry = compute_drift(candidate, baseline).get("omega", "level")
    assert entry.zeta == pytest.approx(9.0)
    assert (entry.top_changes[0].baseline, entry.top_changes[0].candidate) == (0.40, 0.55)



def test_a_baselines_reach_is_its_farthest_windows_correction():
    rng = np.random.default_rng(2)
    # three windows at different loads; the error depends on the load with slope 0.3
    loads = np.concatenate([rng.normal(mean, 2.0, 1000) for mean in (95.0, 100.0, 103.0)])
    groups = np.repeat([0, 1, 2], 1000)
    # features: the channel's prediction (unrelated to the error here), then the load input
    features = np.column_stack([rng.normal(50.0, 1.0, 3000), loads])
    errors = 0.5 + 0.3 * (loads - 100.0) + 1e-3 * rng.standard_normal(3000)
    baseline = fit_level(errors, features, 12, groups=groups)
    means = [loads[groups == g].mean() for g in range(3)]
    center = baseline.center[1]
    assert baseline.slopes[1] == pytest.approx(0.3, abs=1e-4)
    assert baseline.reach == pytest.approx(max(abs(baseline.slopes[1] * (m - center))
                                               for m in means), rel=1e-6)
    # a candidate whose load lies twice as far from the centre as the farthest window
    farthest = max(means, key=lambda m: abs(m - center))
    night = center + 2 * (farthest - center) + rng.normal(0.0, 2.0, 800)
    shifted = np.column_stack([rng.normal(50.0, 1.0, 800), night])
    candidate = fit_level(0.5 + 0.3 * (night - 100.0), shifted, 12, baseline)
    assert candidate.reach is None
    assert extrapolation(candidate, baseline) == pytest.approx(2.0, rel=0.05)
    inside = fit_level(errors[1000:1800], features[1000:1800], 12, baseline)
    assert extrapolation(inside, baseline) < 1.0
    # the prediction moving (a sensor bias enters it through its start) is not "outside"
    biased = features[1000:1800] + [5.0, 0.0]
    assert extrapolation(fit_level(errors[1000:1800], biased, 12, baseline), baseline) < 1.0
    # a record stored without the figures is never discounted
    assert extrapolation(inside, dataclasses.replace(baseline, reach=None)) == 0.0


class Room(WhiteBoxModel):
    """A room whose heater a thermostat sets against the outdoor temperature."""
    states = ("air",)
    inputs = ("heater", "outdoor")
    controlled_inputs = ("heater",)

    def derivatives(self, x, u):
        return u[:, :1] - x


def test_an_input_a_controller_sets_does_not_place_a_night_outside_the_range():
    assert operating_features(Room()) == (2,)
    assert operating_features(GasTurbineShaft()) == (1,)
    rng = np.random.default_rng(3)
    # three baseline days at outdoor means 5, 8 and 10 C; the heater works against the cold
    outdoor = np.concatenate([rng.normal(mean, 1.0, 1000) for mean in (5.0, 8.0, 10.0)])
    heater = 2.0 - 0.1 * outdoor + 0.05 * rng.standard_normal(3000)
    groups = np.repeat([0, 1, 2], 1000)
    features = np.column_stack([rng.normal(20.0, 0.1, 3000), heater, outdoor])
    errors = 0.2 * heater + 0.05 * outdoor + 1e-3 * rng.standard_normal(3000)
    baseline = fit_level(errors, features, 12, groups=groups, operating=(2,))
    assert baseline.operating == (2,)
    assert from_dict(LevelTier, json.loads(json.dumps(to_dict(baseline)))) == baseline
    # an open window on a mild night: the thermostat doubles the heat, the outdoor
    # temperature is inside the baseline's days
    night = np.column_stack([rng.normal(20.0, 0.1, 800), 2.0 * heater[1000:1800],
                             outdoor[1000:1800]])
    candidate = fit_level(errors[1000:1800] + 0.3, night, 12, baseline)
    assert candidate.operating is None
    assert extrapolation(candidate, baseline) < 1.0
    # counting the heater (every input, as a record stored before the field does), the
    # same night reads as outside the range, and its level change would be discounted
    every_input = fit_level(errors, features, 12, groups=groups)
    assert every_input.operating is None
    assert extrapolation(fit_level(errors[1000:1800] + 0.3, night, 12, every_input),
                         every_input) > 1.5
    # a cold night outside the baseline's days still is outside
    cold = np.column_stack([rng.normal(20.0, 0.1, 800), 2.0 - 0.1 * (outdoor[:800] - 10.0),
                            outdoor[:800] - 10.0])
    assert extrapolation(fit_level(errors[:800], cold, 12, baseline), baseline) > 1.5


def test_days_driven_alike_place_no_night_outside_the_level_range():
    rng = np.random.default_rng(4)
    groups = np.repeat([0, 1, 2, 3], 960)

    def baselines(day_means):
        """The level baseline of four days, with the days' test and counting the outdoor
        temperature whatever the days show (as before the test)."""
        # a daily cycle every day shares, each day's mean at day_means
        hour = np.tile(np.linspace(0.0, 24.0, 960, endpoint=False), 4)
        outdoor = (np.repeat(day_means, 960) + 3.0 * np.sin(2 * np.pi * hour / 24)
                   + rng.normal(0.0, 1.0, 3840))
        heater = 2.0 - 0.1 * outdoor + 0.05 * rng.standard_normal(3840)
        conditions = operating_conditions(
            Room(), [np.column_stack([heater, outdoor])[groups == g] for g in range(4)],
            list(range(4)))
        features = np.column_stack([rng.normal(20.0, 0.1, 3840), heater, outdoor])
        errors = 0.05 * outdoor + 1e-3 * rng.standard_normal(3840)
        operating = operating_features(Room(), conditions)
        return (operating, fit_level(errors, features, 12, groups=groups, operating=operating),
                fit_level(errors, features, 12, groups=groups, operating=(2,)))

    def outside(night, baseline):
        return extrapolation(fit_level(0.05 * night[:, 2], night, 12, baseline), baseline)

    # four days at the same outdoor mean: their means differ by chance alone
    operating, alike, counted = baselines([8.0, 8.0, 8.0, 8.0])
    assert operating == () and alike.reach == 0.0
    assert from_dict(LevelTier, json.loads(json.dumps(to_dict(alike)))) == alike
    # a night a little beyond such days (0.2 C against their scatter of a few hundredths) is
    # not outside anything; counting the outdoor temperature, it read as far outside
    night = np.column_stack([rng.normal(20.0, 0.1, 960), np.full(960, 1.0),
                             rng.normal(8.2, 1.0, 960)])
    assert outside(night, alike) == 0.0
    assert outside(night, counted) > 2.0
    # days at 5, 8, 10 and 12 C differ beyond chance: a night at 14 C lies outside them,
    # one at 8.2 C inside
    operating, varied, _ = baselines([5.0, 8.0, 10.0, 12.0])
    assert operating == (2,) and varied.reach > 0
    assert outside(night + [0.0, 0.0, 5.8], varied) > 1.0
    assert outside(night, varied) < 1.0


def test_a_level_change_outside_the_baselines_range_is_discounted_by_the_distance_squared():
    reference = dataclasses.replace(_level(0.40), operating_point=(100.0, 1.0), reach=0.5)
    # the input's correction at 6.0: |-0.2 * 5| = 1.0, twice the reach (the prediction, the
    # first feature, does not count)
    night = dataclasses.replace(_level(0.55), operating_point=(130.0, 6.0))
    baseline = make_signature((dataclasses.replace(make_channel(), level=reference),))
    candidate = make_signature((dataclasses.replace(make_channel(), level=night),))
    kind = tier_kind("level")
    assert kind.deltas(candidate.channels[0], baseline.channels[0]) == pytest.approx([3.0])
    # twice the reach: the change divided by 2 squared (a slope's error grows with the
    # distance, the model error's curvature with its square)
    assert kind.discount(candidate.channels[0], baseline.channels[0]) == pytest.approx(4.0)
    assert kind.drift_deltas(candidate.channels[0], baseline.channels[0]) == \
        pytest.approx([0.75])
    # the asset's input conditions do not replace the level's own extrapolation
    assert kind.drift_deltas(candidate.channels[0], baseline.channels[0], 6.0) == \
        pytest.approx([0.75])
    entry = compute_drift(candidate, baseline).get("omega", "level")
    assert entry.zeta == pytest.approx(0.5625)
    assert entry.outside == pytest.approx(2.0)
    # the hint's parameter contribution is discounted alike
    assert entry.top_changes[0].contribution == pytest.approx(0.5625)
    assert Drift.from_dict(compute_drift(candidate, baseline).to_dict()).get(
        "omega", "level") == entry
    # inside the range: undiscounted and not flagged
    inside = dataclasses.replace(night, operating_point=(130.0, 1.5))
    candidate = make_signature((dataclasses.replace(make_channel(), level=inside),))
    entry = compute_drift(candidate, baseline).get("omega", "level")
    assert entry.zeta == pytest.approx(9.0) and entry.outside is None
    assert Signature.from_json(baseline.to_json()) == baseline
    # a candidate of two nights, one inside (1.5) and one at 6.0: as far outside as the
    # farthest, where their mean (3.75, a correction of 0.55) would read as inside
    pair = dataclasses.replace(inside, window_points=((130.0, 1.5), (130.0, 6.0)))
    candidate = make_signature((dataclasses.replace(make_channel(), level=pair),))
    entry = compute_drift(candidate, baseline).get("omega", "level")
    assert entry.zeta == pytest.approx(0.5625) and entry.outside == pytest.approx(2.0)
    assert Signature.from_json(candidate.to_json()) == candidate


def test_a_candidate_keeps_the_operating_point_of_each_of_its_windows():
    rng = np.random.default_rng(5)
    features = np.column_stack([rng.normal(0.0, 1.0, 300), np.repeat([1.0, 2.0, 3.0], 100)])
    errors = 0.5 * features[:, 1] + rng.normal(0.0, 0.1, 300)
    baseline = fit_level(errors, features, 4, groups=np.repeat([0, 1, 2], 100))
    assert baseline.window_points is None and baseline.reach == pytest.approx(0.5, rel=0.05)
    night = np.column_stack([rng.normal(0.0, 1.0, 200), np.repeat([2.0, 6.0], 100)])
    candidate = fit_level(0.5 * night[:, 1], night, 4, baseline, groups=np.repeat([7, 8], 100))
    np.testing.assert_allclose([p[1] for p in candidate.window_points], [2.0, 6.0])
    assert candidate.operating_point[1] == pytest.approx(4.0)
    # the night at 6.0 lies 4 from the centre, a correction of 2.0: four times the reach of
    # the baseline's days (their mean, 4.0, would say twice)
    assert extrapolation(candidate, baseline) == pytest.approx(4.0, rel=0.05)

def _turbine_days(model_error, faults, days, vehicles=1):
    specs = []
    for i in range(vehicles):
        specs += [VehicleSpec(f"H{i}", seed=4100 + i),
                  VehicleSpec(f"B{i}", seed=4100 + i, faults=faults)]
    frames = simulate_fleet(FleetSpec(tuple(specs), days=days, sample_interval=DT))
    per_day = int(86400 / DT)
    split = {name: [f.set_index("timestamp").iloc[d * per_day:(d + 1) * per_day]
                    for d in range(days)] for name, f in frames.items()}
    model = GasTurbineShaft(white_box_parameters(model_error), columns={"omega": "shaft_speed"})
    return model, split


@pytest.mark.slow
def test_the_level_tier_catches_a_bias_step_with_the_white_box_20_percent_off():
    baseline_days, onset, days = 4, 7, 9
    model, split = _turbine_days(0.2, (Fault("bias", float(onset), 0.5),), days)
    [(signature, calibration)] = fit_baselines(
        [FitRequest(model, split["H0"][:baseline_days], asset_id="H0")])
    assert calibration.threshold("omega", "level").epsilon > 0
    nights = ([("healthy", d, split["H0"][d]) for d in range(baseline_days, days)]
              + [("bias", d, split["B0"][d]) for d in range(onset, days)])
    candidates = fit_signatures([FitRequest(model, [frame], baseline=signature)
                                 for _, _, frame in nights])
    for (kind, day, _), candidate in zip(nights, candidates):
        drift = compute_drift(candidate, signature, calibration)
        level = drift.get("omega", "level")
        if kind == "healthy":
            assert not level.exceeded, f"healthy night {day}: level ratio {level.ratio:.2f}"
        else:
            assert level.exceeded, f"bias night {day}: level ratio {level.ratio:.2f}"
            move = level.top_changes[0].candidate - level.top_changes[0].baseline
            assert move == pytest.approx(0.5, abs=0.1)
            [alert] = [a for a in alerts_from_drift(
                drift, asset_id="B0", vehicle_class="turbine", window_start="s",
                window_end="e", version=None, baseline_version=1, run_id=None)
                if a.tier == "level"]
            assert alert.hint().startswith("level moved from ")


def test_a_level_alerts_hint_says_where_the_level_moved():
    baseline = make_signature((dataclasses.replace(make_channel(), level=_level(129.02)),))
    candidate = make_signature((dataclasses.replace(make_channel(), level=_level(129.49)),))
    drift = compute_drift(candidate, baseline)
    entry = drift.get("omega", "level")
    flagged = type(drift)((dataclasses.replace(entry, epsilon=1.0),), drift.n_samples)
    [alert] = alerts_from_drift(flagged, asset_id="T-001", vehicle_class="turbine",
                                window_start="s", window_end="e", version=2,
                                baseline_version=1, run_id=None)
    assert (alert.channel, alert.tier) == ("omega", "level")
    assert alert.hint() == "level moved from 129.02 to 129.49 (+0.47)"


def test_a_level_change_within_one_step_of_a_quantized_reading_never_alarms():
    # a winding temperature logged to 0.01 degree, its level's regression spread 0.05: two
    # nights' levels may differ by a whole step with nothing changed (each rounds by up to
    # half a step), so the epsilon is at least (0.01 / 0.05)^2 = 0.04, however narrow the
    # calibrated one
    reference = dataclasses.replace(_level(0.40), resolution=0.01)
    baseline = make_signature((dataclasses.replace(make_channel(), level=reference),))
    samples = baseline.channels[0].n_samples
    calibration = Calibration(tuple(
        TierThreshold("omega", kind.name, 0.01 if kind.name == "level" else 1.0, 0.005, 1.0,
                      (0.005,) * 3) for kind in TIER_KINDS), 0.01, 0.001, samples, 3)
    kind = tier_kind("level")
    for change, alarmed in ((0.009, False), (0.012, True)):
        candidate = make_signature((dataclasses.replace(make_channel(),
                                                        level=_level(0.40 + change)),))
        assert kind.epsilon_floor(candidate.channels[0], baseline.channels[0]) == \
            pytest.approx(0.04)
        entry = compute_drift(candidate, baseline, calibration).get("omega", "level")
        assert entry.zeta == pytest.approx((change / 0.05) ** 2)
        assert entry.epsilon == pytest.approx(0.04) and entry.exceeded is alarmed
    # twice outside the range: the step is discounted as the change is
    far = dataclasses.replace(reference, operating_point=(100.0, 1.0), reach=0.5)
    night = dataclasses.replace(_level(0.412), operating_point=(130.0, 6.0))
    assert kind.epsilon_floor(make_signature((dataclasses.replace(make_channel(), level=night),
                                              )).channels[0],
                              make_signature((dataclasses.replace(make_channel(), level=far),
                                              )).channels[0]) == pytest.approx(0.04 / 16)
    # an unquantized reading (0) and a record stored before the field (None) have no floor
    for step in (0.0, None):
        plain = make_signature((dataclasses.replace(
            make_channel(), level=dataclasses.replace(reference, resolution=step)),))
        assert kind.epsilon_floor(baseline.channels[0], plain.channels[0]) == 0.0
    assert Signature.from_json(baseline.to_json()) == baseline
    assert "resolution" not in make_signature((dataclasses.replace(
        make_channel(), level=_level(0.4)),)).to_json()


class _MeteredTank(WhiteBoxModel):
    """A tank's level ``h`` (m, measured) between a metered inflow and a metered outflow
    (m^3/h): ``area h' = inflow - outflow``."""

    states = ("h",)
    outputs = ("h",)
    inputs = ("inflow", "outflow")
    default_parameters = {"area": 360.0}

    def derivatives(self, x, u):
        return (u[..., :1] - u[..., 1:2]) / (3600.0 * self.parameters["area"])

    def output(self, x, u):
        return x[..., :1]


def test_an_outflow_meter_reading_low_moves_the_level_by_the_tanks_mass_balance():
    # a tank of 400 m^2 logged every 15 minutes, its white box's area 360 m^2 (10 % off):
    # the baseline's slopes take out the area's error, which moves with the flows; an outflow
    # meter reading 8 % low then moves a candidate's one-step level by 8 % of the mean
    # outflow over one sample on the *true* area (the slopes keep the baseline's relation,
    # nothing refits the meter's gain away): -0.08 * 150 * 0.25 / 400 = -0.75 cm
    from graybox.state_estimation import WindowStates

    dt, n = 900.0, 96
    truth = _MeteredTank({"area": 400.0})
    model = _MeteredTank()

    def window(gain, seed):
        rng = np.random.default_rng(seed)
        hours = np.arange(n) * dt / 3600.0
        outflow = 150.0 * (1 + 0.5 * np.sin(2 * np.pi * (hours - 7) / 24)) \
            * (1 + 0.05 * rng.standard_normal(n))
        inflow = np.where(np.sin(2 * np.pi * hours / 6 + seed) > 0, 300.0, 0.0)
        level = _free_run(truth, 3.0, np.column_stack([inflow, outflow]), dt=dt)
        u = np.column_stack([inflow, outflow * gain])
        return WindowStates(level, u, level, {})

    healthy = [window(1.0, day) for day in range(5)]
    errors, features, _ = level_data(model, healthy, dt, 1, drift={})["h"]
    baseline = fit_level(errors, features, 1)
    for gain in (1.0, 0.92):
        night = [window(gain, 11)]
        errors, features, _ = level_data(model, night, dt, 1, drift={})["h"]
        moved = fit_level(errors, features, 1, baseline).level - baseline.level
        mean_outflow = night[0].u[1:, 1].mean() / gain
        expected = -(1 - gain) * mean_outflow * dt / 3600.0 / 400.0
        assert moved == pytest.approx(expected, abs=0.0002)  # 360 m^2 would give -0.83 cm
    assert expected == pytest.approx(-0.0075, rel=0.1)


class _Pack(WhiteBoxModel):
    """A charge ``q`` counted from the current (an integrator, hidden), an RC voltage ``v``
    (hidden, relaxing) and a measured temperature; the terminal voltage reads both."""

    states = ("q", "v", "temp")
    outputs = ("voltage", "temp")
    inputs = ("current",)
    default_parameters = {"capacity": 100.0, "slope": 2.0, "r": 0.5, "tau": 20.0, "r0": 0.1}

    def derivatives(self, x, u):
        p = self.parameters
        current = u[..., 0]
        return np.stack([-current / p["capacity"],
                         p["r"] * current / p["tau"] - x[..., 1] / p["tau"],
                         0.01 * current ** 2 - 0.05 * x[..., 2]], axis=-1)

    def output(self, x, u):
        p = self.parameters
        voltage = 10.0 + p["slope"] * x[..., 0] - x[..., 1] - p["r0"] * u[..., 0]
        return np.stack([voltage, x[..., 2]], axis=-1)


class _HeatedByCharge(_Pack):
    """The same pack whose temperature's dynamics read the charge."""

    def derivatives(self, x, u):
        rates = super().derivatives(x, u)
        rates[..., 2] += 0.001 * x[..., 0]
        return rates


def _pack_window(model, current, dt=1.0, q0=0.5):
    """A segment's states as the hidden-state run gives them: the model's own run (RK4, the
    current linear inside a sample), with the temperature as read."""
    from graybox.integration import Integration, advance
    from graybox.state_estimation import WindowStates
    u = current[:, None]
    states = np.empty((len(current), 3))
    states[0] = (q0, 0.0, 25.0)
    for t in range(1, len(current)):
        states[t] = advance(model.derivatives, states[t - 1:t], u[t - 1:t], u[t:t + 1], dt,
                            Integration("rk4", 2))[0]
    states[:, 2] = 25.0 + 0.1 * np.sin(np.arange(len(current)) / 50.0)
    return WindowStates(model.output(states, u), u, states, {"q": q0, "v": 0.0})


def test_a_hidden_integrator_drifts_into_the_outputs_that_read_it():
    from graybox.level_tier import drifting_states
    current = np.random.default_rng(0).normal(1.0, 2.0, 500)
    pack = _Pack()
    window = _pack_window(pack, current)
    # q's rate ignores q (it never forgets its start); v relaxes; temp is measured and its
    # dynamics read neither
    assert drifting_states(pack, [window]) == {"voltage": (0,), "temp": ()}
    heated = _HeatedByCharge()
    assert drifting_states(heated, [_pack_window(heated, current)]) == {"voltage": (0,),
                                                                        "temp": (0,)}
    shaft = LangevinShaft()            # no hidden states: nothing drifts, features unchanged
    x = np.linspace(10.0, 12.0, 50)[:, None]
    from graybox.state_estimation import WindowStates
    assert drifting_states(shaft, [WindowStates(x, np.ones((50, 1)), x, {})]) == {"omega": ()}


def test_a_drifting_states_change_since_the_segment_start_is_a_level_feature():
    from graybox.level_tier import pool_level_data, segment_level_data
    pack = _Pack()
    current = np.random.default_rng(1).normal(1.0, 2.0, 400)
    window = _pack_window(pack, current, q0=0.8)
    k = 5
    part = segment_level_data(pack, window, 1.0, k, stride=3)
    data = pool_level_data(pack, [window], [part], k, stride=3)
    errors, features, _ = data["voltage"]
    assert features.shape == (len(errors), 3)   # prediction, current, q's change
    np.testing.assert_allclose(features[:, 2], window.states[k::3, 0] - 0.8, atol=1e-12)
    assert data["temp"][1].shape == (len(errors), 2)


def test_a_capacity_error_is_taken_out_of_the_level_on_a_night_that_charges():
    """Known answer: the white box's capacity is 10 % short, so the voltage's k-step error is
    ``-slope (1 - C/C_true)`` times the charge counted since the segment's start. Baseline
    segments that discharge from a full pack fit that slope; a night that charges from a
    low one keeps the level, and lies outside the baseline's range."""
    from graybox.level_tier import pool_level_data, segment_level_data
    pack, true = _Pack(), _Pack({"capacity": 110.0})
    rng = np.random.default_rng(2)
    k = 5

    def segment(mean, q0=0.9):
        current = rng.normal(mean, 1.0, 600)
        run = _pack_window(pack, current, q0=q0)           # the white box's hidden-state run
        truth = _pack_window(true, current, q0=q0)
        noisy = truth.y + rng.normal(0.0, 0.001, truth.y.shape)
        return type(run)(noisy, run.u, run.states, run.initial_hidden)

    def data(windows):
        parts = [segment_level_data(pack, w, 1.0, k) for w in windows]
        errors, features, groups = pool_level_data(pack, windows, parts, k)["voltage"]
        return errors, features, groups

    errors, features, groups = data([segment(m) for m in (2.0, 3.0, 4.0, 2.5)])
    baseline = fit_level(errors, features, k, groups=groups, operating=(1, 2))
    slope = -2.0 * (1 - 100.0 / 110.0)
    assert baseline.slopes[2] == pytest.approx(slope, rel=0.02)
    assert baseline.residual_std < 0.01
    night = data([segment(-3.0, q0=0.2)])       # from a low charge, charging: q moves up
    candidate = fit_level(night[0], night[1], k, baseline=baseline)
    assert abs(candidate.level - baseline.level) < 3 * baseline.residual_std
    # the night moves q beyond every baseline segment's: it lies outside their range
    assert extrapolation(fit_level(night[0], night[1], k, baseline=baseline,
                                   groups=night[2]), baseline) > 1


def test_a_baseline_records_its_drifting_states_and_its_candidates_use_them():
    """The baseline's record names the drifting states (round-tripping JSON); a candidate
    takes them from it, a record stored before them (``drifting`` None) gets none."""
    from graybox.level_tier import pool_level_data, segment_level_data
    pack = _Pack()
    window = _pack_window(pack, np.random.default_rng(3).normal(1.0, 2.0, 300))
    parts = [segment_level_data(pack, window, 1.0, 5)]
    found = pool_level_data(pack, [window], parts, 5)
    errors, features, groups = found["voltage"]
    record = fit_level(errors, features, 5, groups=groups, operating=(1, 2),
                       drifting=("q",))
    assert record.drifting == ("q",)
    assert from_dict(LevelTier, json.loads(json.dumps(to_dict(record)))) == record
    assert "drifting" not in to_dict(fit_level(errors, features[:, :2], 5))
    given = pool_level_data(pack, [window], parts, 5, drift={"voltage": record.drifting})
    np.testing.assert_array_equal(given["voltage"][1], features)
    older = pool_level_data(pack, [window], parts, 5, drift={"voltage": (), "temp": ()})
    assert older["voltage"][1].shape == (len(errors), 2)


def test_a_night_that_takes_a_drifting_state_beyond_the_baselines_days_is_outside():
    """A drifting state's change is a path: a night that dips twice as deep as any baseline
    day and comes back has an ordinary mean change, and is outside by its farthest
    excursion (the extent), measured from the baseline's centre."""
    rng = np.random.default_rng(4)
    n = 200

    def window(path):
        return np.column_stack([rng.normal(0.0, 1.0, len(path)), rng.normal(0.0, 1.0, len(path)),
                                path])

    days = [np.linspace(0.0, -depth, n) for depth in (0.3, 0.5, 0.4)]
    features = np.concatenate([window(path) for path in days])
    errors = 2.0 * features[:, 2] + rng.normal(0.0, 0.01, len(features))
    groups = np.repeat(np.arange(3), n)
    baseline = fit_level(errors, features, 5, groups=groups, operating=(2,), drifting=("q",))
    c = baseline.center[2]
    assert baseline.extent_reach == pytest.approx(
        abs(baseline.slopes[2]) * max(abs(0.0 - c), abs(-0.5 - c)))
    night = np.full(n, -0.15)                  # an ordinary day but for one deep dip
    night[90:110] = -np.concatenate([np.linspace(0.15, 1.0, 10), np.linspace(1.0, 0.15, 10)])
    assert abs(night.mean() - c) < max(abs(d.mean() - c) for d in days)   # its mean is inside
    f = window(night)
    candidate = fit_level(2.0 * f[:, 2], f, 5, baseline=baseline, groups=np.zeros(n))
    assert candidate.window_extents[0][2] == pytest.approx(-1.0)
    assert extrapolation(candidate, baseline) == pytest.approx(
        abs(-1.0 - c) / max(abs(0.0 - c), abs(-0.5 - c)), rel=1e-6)
    # without drifting states no extent is kept, and the mean alone places the night inside
    plain = fit_level(errors, features, 5, groups=groups, operating=(2,))
    assert plain.extent_reach is None
    inside = fit_level(2.0 * f[:, 2], f, 5, baseline=plain, groups=np.zeros(n))
    assert inside.window_extents is None and extrapolation(inside, plain) < 1
