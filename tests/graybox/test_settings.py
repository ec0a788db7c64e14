"""Known answers of GrayBoxSettings: min_samples = "auto" and how a baseline resolves it."""
import pytest

from graybox import GrayBox, load_model
from graybox.exceptions import InsufficientDataError
from graybox.settings import GrayBoxSettings
from graybox.simulation import FleetSpec, VehicleSpec, simulate_fleet


@pytest.mark.parametrize("shortest, expected", [
    (86_400, 200), (1_000, 200), (250, 200),     # where a fixed 200 fitted, nothing changes
    (249, 199), (150, 100), (96, 48),            # a slow logger's day keeps 50 for the structure
    (90, 48), (10, 48)])                         # never fewer than 48
def test_auto_min_samples_resolves_from_the_shortest_window(shortest, expected):
    assert GrayBoxSettings().min_samples == "auto"
    assert GrayBoxSettings().for_windows(shortest).min_samples == expected


def test_a_count_is_kept_and_auto_counts_as_the_target_until_resolved():
    assert GrayBoxSettings(min_samples=500).for_windows(96).min_samples == 500
    assert GrayBoxSettings().min_sample_count == 200
    assert GrayBoxSettings().samples_per_window == 8 * 200
    assert GrayBoxSettings(min_samples=60).samples_per_window == 8 * 60


@pytest.mark.parametrize("value", [0, -3, 2.5, "many", True])
def test_a_bad_min_samples_is_refused(value):
    with pytest.raises(ValueError, match="min_samples must be an integer >= 1 or 'auto'"):
        GrayBoxSettings(min_samples=value)


def test_auto_round_trips_through_json():
    settings = GrayBoxSettings()
    assert GrayBoxSettings.from_dict(settings.to_dict()) == settings
    assert settings.to_dict()["min_samples"] == "auto"


def _days(sample_interval):
    data = simulate_fleet(FleetSpec((VehicleSpec("S", 5),), days=4,
                                    sample_interval=sample_interval))
    frame = data["S"].set_index("timestamp")
    return [day for _, day in frame.groupby(frame.index.floor("1D"))]


def test_a_15_minute_baseline_records_the_count_it_resolved_and_its_candidates_use_it():
    model = load_model("graybox.models:GasTurbineShaft", columns={"omega": "shaft_speed"})
    days = _days(900.0)
    assert {len(d) for d in days} == {96}
    baseline = GrayBox(model).fit(days[:3])
    assert baseline.signature_.settings.min_samples == 48
    candidate = GrayBox(model, baseline=baseline.signature_, settings=GrayBoxSettings()).fit(days[3])
    assert candidate.signature_.settings == baseline.signature_.settings
    # a count the user fixed is kept, and the error names the setting to lower
    with pytest.raises(InsufficientDataError, match="settings.min_samples"):
        GrayBox(model, settings=GrayBoxSettings(min_samples=200)).fit(days[:3])


@pytest.mark.parametrize("interval, expected", [(1.0, 460), (10.0, 46), (60.0, 10),
                                                (300.0, 10), (900.0, 10)])
def test_a_period_is_fitted_from_its_time_and_at_a_slow_rate_from_ten_samples(interval,
                                                                             expected):
    # ar_span + delay_span + derivative_span = 460 s; at 15 minutes that is one sample, and
    # stationarizing needs 8 residual samples after the one-step residual and a difference
    assert GrayBoxSettings().shortest_period == 460.0
    assert GrayBoxSettings().shortest_period_samples(interval) == expected
