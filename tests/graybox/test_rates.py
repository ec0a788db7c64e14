"""Known answers across telemetry rates: one simulated process, sampled at 1 s, 10 s and 60 s,
gives the same decisions with the default settings (see graybox.analysis_rate)."""
import pytest

from graybox import GrayBox, load_model
from graybox.simulation import Fault, FleetSpec, VehicleSpec, simulate_fleet

BASELINE_DAYS, DAYS, ONSET = 4, 6, 4


def nights(frame):
    frame = frame.set_index("timestamp")
    return [day for _, day in frame.groupby(frame.index.floor("1D"))]


def decisions(sample_interval):
    """Per asset (healthy, friction +50 % from day 4): whether each night after the onset
    alarmed, and the baseline's analysis interval."""
    vehicles = (VehicleSpec("H", 11), VehicleSpec("F", 11, faults=(
        Fault("friction", onset_day=ONSET, magnitude=0.5),)))
    data = simulate_fleet(FleetSpec(vehicles, days=DAYS, sample_interval=sample_interval))
    model = load_model("graybox.models:GasTurbineShaft", columns={"omega": "shaft_speed"})
    out = {}
    for asset, frame in data.items():
        days = nights(frame)
        baseline = GrayBox(model).fit(days[:BASELINE_DAYS])
        out[asset] = [baseline.drift(night).alarmed for night in days[ONSET:]]
        out["interval"] = baseline.signature_.analysis_step
    return out


@pytest.fixture(scope="module")
def at_10s():
    return decisions(10.0)


@pytest.mark.slow
def test_one_second_and_ten_seconds_decide_alike(at_10s):
    at_1s = decisions(1.0)
    # 1 Hz is decimated to the analysis interval chosen from the shaft's time constant
    # (1 / gamma ~ 16 s: half of it, a whole number of seconds); 10 s is analysed as it is
    assert at_1s["interval"] == 7.0 and at_10s["interval"] == 10.0
    assert at_10s["H"] == [False, False] and at_1s["H"] == [False, False]
    assert at_10s["F"] == [True, True] and at_1s["F"] == [True, True]


def test_sixty_second_telemetry_baselines_with_the_defaults_and_detects_friction():
    at_60s = decisions(60.0)
    assert at_60s["interval"] == 60.0
    assert at_60s["H"] == [False, False]
    assert at_60s["F"] == [True, True]
