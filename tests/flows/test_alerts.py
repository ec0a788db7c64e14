"""Alert records: severity, root-cause hint, and the idempotent JSON-lines file."""
from __future__ import annotations

import json
import threading

import pytest

from flows.alerts import AlertLog
from graybox.alert import Alert, alerts_from_drift
from graybox.severity import SeverityScale


def alert(asset="T-001", start="2026-01-05T00:00:00+00:00", end="2026-01-06T00:00:00+00:00",
          channel="omega", tier="noise", ratio=3.0):
    return Alert(asset, "turbine", start, end, channel, tier, zeta=ratio * 0.5, epsilon=0.5,
                 ratio=ratio, severity=SeverityScale().grade(ratio),
                 top_changes=[{"name": "variance", "baseline": 0.2, "candidate": 0.4,
                               "contribution": 1.2}], version=3, baseline_version=1,
                 run_id="abc")


@pytest.mark.parametrize("ratio, expected", [(1.01, "minor"), (1.99, "minor"), (2.0, "major"),
                                             (4.9, "major"), (5.0, "critical"),
                                             (float("inf"), "critical"), (None, "minor")])
def test_severity(ratio, expected):
    assert SeverityScale().grade(ratio) == expected


def test_alerts_from_drift_keeps_exceeded_entries_with_their_hint():
    from graybox.drift import Drift, ParameterChange, TierDrift

    changes = (ParameterChange("a1", 1.2, 0.9, 0.09), ParameterChange("a2", -0.6, -0.4, 0.04))
    drift = Drift((TierDrift("omega", "linear", 0.13, 0.05, changes),
                   TierDrift("omega", "nonlinear", 0.01, 0.05, ()),
                   TierDrift("omega", "noise", 0.9, 0.1, changes[:1])), 2880)
    alerts = alerts_from_drift(drift, asset_id="T-001", vehicle_class="turbine",
                               window_start="s", window_end="e", version=4,
                               baseline_version=1, run_id="r")
    assert [(a.tier, a.severity) for a in alerts] == [("noise", "critical"), ("linear", "major")]
    assert alerts[1].top_changes[0] == {"name": "a1", "baseline": 1.2, "candidate": 0.9,
                                        "contribution": 0.09}
    assert alerts[1].hint() == "a1 1.2→0.9, a2 -0.6→-0.4"


def test_jsonl_append_is_idempotent(tmp_path):
    log = AlertLog(tmp_path / "out" / "alerts.jsonl")
    first = [alert(), alert(tier="linear", ratio=1.5)]
    assert log.append(first) == first
    assert log.append(first) == []
    later = alert(start="2026-01-06T00:00:00+00:00", end="2026-01-07T00:00:00+00:00")
    assert log.append([first[0], later]) == [later]
    lines = (tmp_path / "out" / "alerts.jsonl").read_text().splitlines()
    assert len(lines) == 3 and json.loads(lines[0])["top_changes"][0]["name"] == "variance"
    assert [a.key for a in log.read()] == [first[0].key, first[1].key, later.key]
    assert [a.key for a in log.read(since="2026-01-07")] == [later.key]
    assert log.read(assets=["T-002"]) == []
    assert [a.key for a in log.read(windows=[("T-001", "2026-01-06", "2026-01-07")])] == \
        [later.key]


def test_a_torn_last_line_is_skipped_and_repaired(tmp_path):
    path = tmp_path / "alerts.jsonl"
    log = AlertLog(path)
    log.append([alert()])
    with open(path, "a") as handle:
        handle.write('{"asset_id": "T-00')          # a crash mid-write
    assert len(log.read()) == 1
    log.append([alert(asset="T-002")])
    assert [a.asset_id for a in log.read()] == ["T-001", "T-002"]


def test_concurrent_appends_write_each_alert_once(tmp_path):
    log = AlertLog(tmp_path / "alerts.jsonl")
    batch = [alert(asset=f"T-{i:03d}") for i in range(20)]
    threads = [threading.Thread(target=lambda: AlertLog(log.path).append(batch))
               for _ in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(log.path.read_text().splitlines()) == 20


def test_one_alert_type_with_an_exact_json_round_trip():
    from graybox.alert import Alert as RecordedAlert

    assert Alert is RecordedAlert          # the flows use the registry's record
    record = alert()
    assert isinstance(record.top_changes, tuple)
    assert Alert.from_dict(json.loads(json.dumps(record.to_dict()))) == record
    assert Alert.from_dict({**record.to_dict(), "unknown": 1}) == record


def test_a_stuck_lock_holder_fails_the_append_instead_of_hanging_it(tmp_path):
    import time

    from registry.exceptions import RegistryError
    from registry.store.locks import file_lock

    log = AlertLog(tmp_path / "alerts.jsonl")
    with file_lock(tmp_path / "alerts.jsonl.lock"):          # another run holds the file
        started = time.monotonic()
        with pytest.raises(RegistryError, match="alerts file"):
            with log._locked(timeout=0.3):
                pass
        assert time.monotonic() - started < 5
    with log._locked(timeout=0.3):                           # free again
        pass


def test_jsonl_keeps_an_alerts_diagnosis(tmp_path):
    """The JSON-lines file writes and reads the ranked diagnosis (and its 'no single cause'
    marker) as the alert holds it."""
    from graybox.diagnosis import Diagnosis, Hypothesis
    from graybox.alert_diagnosis import alert_entries

    friction = Hypothesis("parameter inertia", "parameter", "inertia", 50.0, 33.4,
                          (33.1, 33.7), 412.0, 210.0)
    explained = Diagnosis((friction,), True, 0.0, ("omega",), 2000, 640.0)
    unexplained = Diagnosis((friction,), False, 500.0, ("omega",), 2000, 640.0)
    log = AlertLog(tmp_path / "alerts.jsonl")
    first = Alert(**{**alert().to_dict(), "diagnosis": alert_entries(explained)})
    second = Alert(**{**alert(tier="level").to_dict(), "diagnosis": alert_entries(unexplained)})
    assert log.append([first, second]) == [first, second]
    assert log.read() == [first, second]
    lines = [json.loads(line) for line in log.path.read_text().splitlines()]
    assert lines[0]["diagnosis"][0]["interval"] == [33.1, 33.7]
    assert [e["kind"] for e in lines[1]["diagnosis"]] == ["none", "parameter"]
