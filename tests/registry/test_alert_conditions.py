"""An alert of a night driven beyond the baseline's input conditions says which input left."""
from __future__ import annotations

import json

from graybox.calibration import Calibration, TierThreshold
from graybox.drift import compute_drift
from graybox.operating_conditions import OperatingConditions
from graybox.alert import Alert, alerts_from_drift
from tests.graybox.conftest import make_channel, make_signature


def _conditions(means):
    pieces = tuple(tuple((m + 0.1 * (-1) ** p,) for p in range(8)) for m in means)
    return OperatingConditions(("load",), tuple((m,) for m in means), tuple((1.0,) for _ in means),
                               pieces, tuple(((1.0,),) * 8 for _ in means))


def _alerts(load: float) -> list[Alert]:
    baseline = make_signature((make_channel(a=(0.5,)),), conditions=_conditions([5.0, 8.0, 10.0]))
    candidate = make_signature((make_channel(a=(0.9,)),), conditions=_conditions([load]))
    thresholds = tuple(TierThreshold("omega", tier, 0.01, 0.002, 2.0, (0.001, 0.002, 0.003))
                       for tier in ("linear", "nonlinear", "noise"))
    drift = compute_drift(candidate, baseline, Calibration(thresholds, 0.01, 0.01 / 3, 1000, 12))
    return alerts_from_drift(drift, asset_id="T-1", vehicle_class="turbine",
                             window_start="2026-01-01T00:00:00+00:00",
                             window_end="2026-01-02T00:00:00+00:00", version=3,
                             baseline_version=1, run_id="r")


def test_the_alert_names_the_input_that_left_the_baselines_range():
    # twice the reach: the linear change 0.4 is halved, zeta 0.04 still above epsilon 0.01
    alert = next(a for a in _alerts(13.0) if a.tier == "linear")
    assert alert.conditions == "load mean 13 (baseline days 5 to 10)"
    assert alert.hint() == ("a1 0.5→0.9; outside the baseline's conditions: load mean 13 "
                            "(baseline days 5 to 10)")
    assert Alert.from_dict(json.loads(json.dumps(alert.to_dict()))) == alert
    # inside the range nothing is said, and an alert stored before the field reads as None
    inside = next(a for a in _alerts(8.0) if a.tier == "linear")
    assert inside.conditions is None and inside.hint() == "a1 0.5→0.9"
    old = {k: v for k, v in inside.to_dict().items() if k != "conditions"}
    assert Alert.from_dict(old) == inside
