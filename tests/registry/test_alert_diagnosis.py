"""An alarmed window's diagnosis on the alert record and the candidate run: the entries
(explained, no single cause, failed), the JSON round trip, ``diagnosis.json`` and its tags,
and the alerts read back from the registry with their diagnosis."""
from __future__ import annotations

import json
import pathlib
import urllib.parse

import pytest

from graybox.diagnosis import Diagnosis, Hypothesis
from registry.store import naming
from graybox.alert import Alert, alerts_from_drift
from graybox.alert_diagnosis import (ALERT_HYPOTHESES, NO_SINGLE_CAUSE, DiagnosisFailure,
                                      alert_entries, cause_text, diagnosis_document,
                                      entries_from_document)

INERTIA = Hypothesis("parameter inertia", "parameter", "inertia", 50.0, 33.4, (33.1, 33.7),
                     412.0, 210.0)
BIAS = Hypothesis("omega sensor bias", "bias", "omega", 0.0, 0.52, (0.47, 0.57), 30.0, 18.0)
NOISE = Hypothesis("omega noise level", "noise", "omega", 1.0, 1.02, (0.9, 1.2), -4.0, 0.5)


def diagnosis(*hypotheses, explained=True):
    return Diagnosis(tuple(hypotheses), explained, 0.0, ("omega",), 2000, 640.0)


def test_an_explained_diagnosis_ranks_its_hypotheses_as_dicts():
    entries = alert_entries(diagnosis(INERTIA, BIAS, NOISE))
    assert entries[0] == {"hypothesis": "parameter inertia", "kind": "parameter",
                          "target": "inertia", "baseline": 50.0, "estimate": 33.4,
                          "interval": [33.1, 33.7], "score": 412.0}
    assert [e["kind"] for e in entries] == ["parameter", "bias", "noise"]
    assert cause_text(entries[0]) == "parameter inertia 50 -> 33.4 (-33%; interval 33.1 to 33.7)"
    assert cause_text(entries[1]) == "omega sensor bias 0 -> 0.52 (interval 0.47 to 0.57)"
    many = diagnosis(*[INERTIA] * 9)
    assert len(alert_entries(many)) == ALERT_HYPOTHESES
    assert len(diagnosis_document(many)["hypotheses"]) == 9     # the artifact keeps them all


def test_a_change_fitted_from_a_later_night_says_since_when():
    # a candidate of two nights on the fault's onset night: the bias is fitted from the
    # second night on (graybox.diagnosis.Hypothesis.since); the alert and the likely cause
    # say so, and diagnosis.json reads back with it
    since = "2026-03-02T00:00:00+00:00"
    later = Hypothesis("omega sensor bias", "bias", "omega", 0.0, 0.52, (0.47, 0.57), 30.0,
                       18.0, since)
    entries = alert_entries(diagnosis(later, INERTIA))
    assert entries[0]["since"] == since and "since" not in entries[1]
    assert cause_text(entries[0]) == ("omega sensor bias 0 -> 0.52 (interval 0.47 to 0.57) "
                                      f"since {since}")
    document = json.loads(json.dumps(diagnosis_document(diagnosis(later, INERTIA))))
    assert document["likely_cause"] == cause_text(entries[0])
    assert entries_from_document(document) == entries


def test_no_single_cause_is_a_marker_ranked_above_the_hypotheses():
    found = diagnosis(NOISE, explained=False)
    entries = alert_entries(found)
    assert entries[0] == {"hypothesis": NO_SINGLE_CAUSE, "kind": "none", "target": None,
                          "baseline": None, "estimate": None, "interval": None, "score": 0.0}
    assert entries[1]["hypothesis"] == "omega noise level" and entries[1]["score"] == -4.0
    document = diagnosis_document(found)
    assert (document["status"], document["likely_cause"]) == ("unexplained", NO_SINGLE_CAUSE)


def test_a_failed_diagnosis_says_why():
    failed = DiagnosisFailure("InsufficientDataError: the baseline has no level tier")
    entries = alert_entries(failed)
    assert len(entries) == 1 and entries[0]["kind"] == "failed"
    assert cause_text(entries[0]) == ("diagnosis failed: InsufficientDataError: the baseline "
                                      "has no level tier")
    document = diagnosis_document(failed)
    assert document["status"] == "failed" and document["error"] == failed.reason
    assert entries_from_document(json.loads(json.dumps(document))) == entries
    assert alert_entries(None) == ()


def test_non_finite_numbers_are_written_as_none():
    wide = Hypothesis("parameter inertia", "parameter", "inertia", 50.0, 50.0,
                      (float("-inf"), float("inf")), -7.0, 0.0)
    entry = alert_entries(diagnosis(wide, explained=False))[1]
    assert entry["interval"] == [None, None]
    json.dumps(entry, allow_nan=False)
    assert cause_text(entry) == "parameter inertia 50 -> 50 (+0%; interval ? to ?)"


def test_alert_with_a_diagnosis_round_trips_its_dict_and_json():
    entries = alert_entries(diagnosis(INERTIA, BIAS))
    alert = Alert("T-001", "turbine", "2026-01-05T00:00:00+00:00", "2026-01-06T00:00:00+00:00",
                  "omega", "level", 9.0, 1.0, 9.0, "critical", diagnosis=list(entries))
    assert isinstance(alert.diagnosis, tuple) and alert.diagnosis == entries
    data = alert.to_dict()
    assert data["diagnosis"][0]["estimate"] == 33.4 and isinstance(data["diagnosis"], list)
    assert Alert.from_dict(json.loads(json.dumps(data))) == alert
    assert alert.likely_cause() == "parameter inertia 50 -> 33.4 (-33%; interval 33.1 to 33.7)"
    # an alert written before diagnoses existed reads back without one
    del data["diagnosis"]
    old = Alert.from_dict(data)
    assert old.diagnosis == () and old.likely_cause() == ""


def test_candidate_run_records_the_diagnosis_and_its_alerts_read_it_back(rec, registry, fits):
    rec.baseline()
    registry.promote("T-01", 1, reason="initial")
    found = diagnosis(INERTIA, BIAS, NOISE)
    record = rec.candidate(night=5, alarmed=True, diagnosis=found)
    quiet = rec.candidate(night=6, alarmed=True)          # recorded without a diagnosis
    client = registry.backend.client
    tags = client.get_run(record.run_id).data.tags
    assert tags[naming.TAG_DIAGNOSIS] == "explained"
    assert tags[naming.TAG_LIKELY_CAUSE] == \
        "parameter inertia 50 -> 33.4 (-33%; interval 33.1 to 33.7)"
    with open(client.download_artifacts(record.run_id, "diagnosis.json")) as handle:
        document = json.load(handle)
    assert document == json.loads(json.dumps(diagnosis_document(found)))
    assert [h["log_likelihood_gain"] for h in document["hypotheses"]] == [210.0, 18.0, 0.5]
    assert naming.TAG_DIAGNOSIS not in client.get_run(quiet.run_id).data.tags
    alerts = registry.alerts()
    exceeded = len(fits.alarmed.alarms)
    assert len(alerts) == 2 * exceeded
    # the very records the pipeline makes of the drift and the diagnosis
    assert alerts[:exceeded] == alerts_from_drift(
        fits.alarmed, asset_id="T-01", vehicle_class="turbine",
        window_start=record.window_start, window_end=record.window_end,
        version=record.version, baseline_version=1, run_id=record.run_id,
        diagnosis=alert_entries(found))
    assert all(a.diagnosis[0]["target"] == "inertia" for a in alerts[:exceeded])
    assert all(a.diagnosis == () for a in alerts[exceeded:])


def test_a_lost_diagnosis_file_is_said_on_the_alerts_not_raised(rec, registry):
    record = rec.candidate(night=5, alarmed=True,
                           diagnosis=DiagnosisFailure("ModelSpecError: no parameters"))
    uri = registry.backend.client.get_run(record.run_id).info.artifact_uri
    assert registry.alerts()[0].likely_cause() == \
        "diagnosis failed: ModelSpecError: no parameters"
    (pathlib.Path(urllib.parse.urlparse(uri).path) / "diagnosis.json").unlink()
    alerts = registry.alerts()
    assert alerts and all(a.diagnosis[0]["kind"] == "failed" and
                          "diagnosis.json of run" in a.likely_cause() for a in alerts)


def test_a_baseline_fit_carries_no_diagnosis(rec):
    with pytest.raises(ValueError, match="no diagnosis"):
        rec.baseline(diagnosis=diagnosis(INERTIA))
