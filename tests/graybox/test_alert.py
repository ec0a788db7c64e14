"""Known answers of alert making, where it lives: thresholds by severity ratios, one alert
per exceeded entry, largest ratio first, and the stale-telemetry alert."""
from __future__ import annotations

import math

import pytest

from graybox.alert import REANALYSIS, STALE, Alert, alerts_from_drift, stale_alert
from graybox.severity import SeverityScale
from graybox.drift import Drift, ParameterChange, TierDrift

WINDOW = dict(asset_id="T-07", vehicle_class="turbine", window_start="2026-03-01T00:00:00+00:00",
              window_end="2026-03-02T00:00:00+00:00", version=9, baseline_version=4, run_id="r9")


def drift() -> Drift:
    """Ratios 0.5 (no alarm), 1.5, 3.0, 6.0, and one entry without a threshold."""
    change = ParameterChange("a1", 0.8, 0.5, 0.09)
    return Drift((TierDrift("omega", "linear", 0.05, 0.1, (change,)),
                  TierDrift("omega", "nonlinear", 0.15, 0.1, ()),
                  TierDrift("omega", "noise", 0.3, 0.1, ()),
                  TierDrift("temp", "linear", 0.6, 0.1, (change,)),
                  TierDrift("temp", "noise", 9.0, None, ())), 1440,
                 conditions="load 12.5 beyond 3.1 to 9.8")


def test_the_default_thresholds_are_two_and_five():
    assert (SeverityScale().major_ratio, SeverityScale().critical_ratio) == (2.0, 5.0)


@pytest.mark.parametrize("ratio, major, critical, expected", [
    (1.5, 2.0, 5.0, "minor"), (2.0, 2.0, 5.0, "major"), (4.999, 2.0, 5.0, "major"),
    (5.0, 2.0, 5.0, "critical"), (1.5, 1.2, 1.4, "critical"), (3.0, 4.0, 8.0, "minor"),
    (None, 2.0, 5.0, "minor")])
def test_severity_grades_a_ratio_by_the_thresholds_given(ratio, major, critical, expected):
    assert SeverityScale(major, critical).grade(ratio) == expected


def test_one_alert_per_exceeded_entry_largest_ratio_first():
    alerts = alerts_from_drift(drift(), **WINDOW)
    assert [(a.channel, a.tier, a.ratio, a.severity) for a in alerts] == [
        ("temp", "linear", pytest.approx(6.0), "critical"),
        ("omega", "noise", pytest.approx(3.0), "major"),
        ("omega", "nonlinear", pytest.approx(1.5), "minor")]
    first = alerts[0]
    assert (first.asset_id, first.version, first.baseline_version, first.run_id, first.source,
            first.kind) == ("T-07", 9, 4, "r9", "nightly", "drift")
    assert first.top_changes == ({"name": "a1", "baseline": 0.8, "candidate": 0.5,
                                  "contribution": 0.09},)
    assert first.conditions == "load 12.5 beyond 3.1 to 9.8"
    assert first.hint() == "a1 0.8→0.5; outside the baseline's conditions: load 12.5 beyond " \
                           "3.1 to 9.8"


def test_the_thresholds_given_grade_the_alerts():
    graded = alerts_from_drift(drift(), scale=SeverityScale(1.4, 2.5), **WINDOW)
    assert [a.severity for a in graded] == ["critical", "critical", "major"]


def test_a_drift_without_alarms_makes_no_alert_and_a_bad_source_is_refused():
    quiet = Drift((TierDrift("omega", "linear", 0.05, 0.1, ()),), 1440)
    assert alerts_from_drift(quiet, **WINDOW) == []
    assert alerts_from_drift(drift(), source=REANALYSIS, **WINDOW)[0].source == REANALYSIS
    with pytest.raises(ValueError, match="alert source"):
        alerts_from_drift(drift(), source="weekly", **WINDOW)


def test_an_alert_round_trips_through_its_dict():
    diagnosis = ({"hypothesis": "parameter inertia", "kind": "parameter", "target": "inertia",
                  "baseline": 50.0, "estimate": 33.4, "interval": [33.1, 33.7], "score": 4.0},)
    [alert, *_] = alerts_from_drift(drift(), diagnosis=diagnosis, **WINDOW)
    data = alert.to_dict()
    assert isinstance(data["top_changes"], list) and isinstance(data["diagnosis"], list)
    assert Alert.from_dict({**data, "unknown": 1}) == alert
    assert alert.likely_cause() == "parameter inertia 50 -> 33.4 (-33%; interval 33.1 to 33.7)"


def test_a_stale_alert_is_major_with_its_age_over_the_limit():
    alert = stale_alert(asset_id="T-07", vehicle_class="turbine",
                        last_data="2026-03-01T06:00:00+00:00", age_days=3.0,
                        stale_after_days=2.0)
    assert (alert.kind, alert.tier, alert.channel, alert.severity) == (STALE, STALE, "*", "major")
    assert (alert.window_start, alert.window_end) == ("2026-03-01T06:00:00+00:00",) * 2
    assert math.isclose(alert.ratio, 1.5) and alert.zeta == 3.0 and alert.epsilon == 2.0
    assert alert.hint() == "no telemetry since 2026-03-01T06:00:00+00:00 (3.0 days)"


def test_the_severity_scale_round_trips_and_refuses_an_inverted_scale():
    scale = SeverityScale(1.5, 4.0)
    assert SeverityScale.from_dict(scale.to_dict()) == scale
    assert scale.to_dict() == {"major_ratio": 1.5, "critical_ratio": 4.0}
    assert SeverityScale.from_dict({}) == SeverityScale()
    with pytest.raises(ValueError, match="need 1 <= major_ratio <= critical_ratio"):
        SeverityScale(6.0, 5.0)
    with pytest.raises(ValueError, match="major_ratio=0.5"):
        SeverityScale(0.5, 5.0)
