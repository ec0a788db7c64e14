"""Known-answer detection on the fleet simulator: healthy nights stay below epsilon, each
fault kind (a)-(c) at a moderate magnitude exceeds epsilon on the tier that should see it,
with the true white box and with its parameters 20 % off."""
import pytest

from graybox import FitRequest, compute_drift, fit_baselines, fit_signatures, load_model
from graybox.simulation import Fault, FleetSpec, VehicleSpec, simulate_fleet, white_box_parameters

ONSET = 4
FAULTS = {"healthy": None,
          "friction": Fault("friction", ONSET, 0.5),     # (a) gamma +50 %: the AR tier
          "nonlinear": Fault("nonlinear", ONSET, 0.25),  # (b) flutter: the network
          "noise": Fault("noise", ONSET, 1.0)}           # (c) sensor noise x2: the moments
EXPECTED_TIER = {"friction": "linear", "nonlinear": "nonlinear", "noise": "noise"}


def day_frames(frame):
    frame = frame.set_index("timestamp")
    return [day for _, day in frame.groupby(frame.index.floor("1D"))]


@pytest.fixture(scope="module", params=[0.0, 0.2], ids=["exact-model", "model-20pct-off"])
def drifts(request):
    vehicles = tuple(VehicleSpec(name, 40 + i, faults=() if fault is None else (fault,))
                     for i, (name, fault) in enumerate(FAULTS.items()))
    frames = simulate_fleet(FleetSpec(vehicles, days=ONSET + 2))
    model = load_model("graybox.models:GasTurbineShaft", white_box_parameters(request.param),
                       {"omega": "shaft_speed"})
    days = {v.asset_id: day_frames(frames[v.asset_id]) for v in vehicles}
    baselines = fit_baselines([FitRequest(model, days[v.asset_id][:ONSET], asset_id=v.asset_id)
                               for v in vehicles])
    nights = [(v.asset_id, night) for v in vehicles for night in (ONSET, ONSET + 1)]
    by_asset = dict(zip([v.asset_id for v in vehicles], baselines))
    candidates = fit_signatures([FitRequest(model, [days[a][n]], baseline=by_asset[a][0])
                                 for a, n in nights])
    return {(asset, night): compute_drift(candidate, *by_asset[asset])
            for (asset, night), candidate in zip(nights, candidates)}


def test_healthy_windows_stay_below_epsilon_on_every_tier(drifts):
    for night in (ONSET, ONSET + 1):
        drift = drifts[("healthy", night)]
        assert not drift.alarmed, [(e.tier, e.zeta, e.epsilon) for e in drift.entries]
        assert all(e.epsilon is not None and e.epsilon > 0 for e in drift.entries)


@pytest.mark.parametrize("kind", ["friction", "nonlinear", "noise"])
def test_each_fault_exceeds_epsilon_on_its_tier(drifts, kind):
    for night in (ONSET, ONSET + 1):
        entry = drifts[(kind, night)].get("omega", EXPECTED_TIER[kind])
        assert entry.exceeded, (kind, night, entry.zeta, entry.epsilon)
        assert entry.top_changes, "an alarm names the parameters that moved most"
