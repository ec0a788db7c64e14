"""FitSubmission, batch recording (record_fits) and the candidate's model in its run."""
from __future__ import annotations

import dataclasses
import sqlite3

import pandas as pd
import pytest
from mlflow_loading import load_by_models_uri
from store_copies import copy_store

from benchmarks.langevin_fits import DAY0
from registry import FitSubmission, Registry
from registry.store import naming
from registry.exceptions import RegistryError

ASSETS = ("T-01", "T-02", "T-03")
NIGHTS = (5, 6)


def night(fits, asset_id: str, n: int, **changes) -> FitSubmission:
    start = DAY0 + pd.Timedelta(days=n)
    submission = FitSubmission(asset_id, "turbine", fits.candidate, role="candidate",
                               window_start=start, window_end=start + pd.Timedelta(days=1),
                               drift=fits.alarmed if n % 2 else fits.drift,
                               data_hash=f"{asset_id}-night-{n}", plots=False)
    return dataclasses.replace(submission, **changes)


def batch(fits) -> list[FitSubmission]:
    return [night(fits, asset, n) for n in NIGHTS for asset in ASSETS]


def other_registry(tmp_path, template_db, name: str) -> Registry:
    return Registry(copy_store(template_db, tmp_path / name), user="tester")


# not reproducible from one write to the next: safetensors orders its metadata keys at random
UNSTABLE = {naming.TAG_MODEL_ID, naming.TAG_RUN_ID, naming.TAG_MANIFEST_SHA256}


def snapshot(registry: Registry) -> list[tuple]:
    """Everything the UI shows of each recorded fit, minus ids, times and bundle digests."""
    client = registry.backend.client
    experiment = client.get_experiment_by_name("fleet-health/turbine")
    out = []
    for run in registry.backend.paged(client.search_runs, [experiment.experiment_id], ""):
        tags = {k: v for k, v in run.data.tags.items()
                if k.startswith("fleet_health.") and k not in UNSTABLE}
        files = sorted(a.path for a in client.list_artifacts(run.info.run_id))
        model = sorted(a.path for a in client.list_artifacts(run.info.run_id, "model"))
        version = client.search_model_versions(f"run_id = '{run.info.run_id}'")
        (version,) = version
        version_tags = {k: v for k, v in version.tags.items() if k not in UNSTABLE}
        out.append((run.info.run_name, run.info.status, tuple(sorted(tags.items())),
                    tuple(sorted(run.data.params.items())),
                    tuple(sorted(run.data.metrics.items())), tuple(files), tuple(model),
                    int(version.version), tuple(sorted(version_tags.items())),
                    version.description))
    return sorted(out)


def test_submission_is_frozen_and_checked_when_built(fits):
    submission = night(fits, "T-01", 5)
    with pytest.raises(dataclasses.FrozenInstanceError):
        submission.role = "baseline"
    with pytest.raises(ValueError, match="no calibration"):
        night(fits, "T-01", 5, calibration=fits.calibration)
    with pytest.raises(ValueError, match="names the version"):
        night(fits, "T-01", 5, reanalysis=True)
    with pytest.raises(ValueError, match="not before its end"):
        night(fits, "T-01", 5, window_end=DAY0).resolve()
    resolved = submission.resolve()
    assert resolved.key == naming.fit_key("T-01", DAY0 + pd.Timedelta(days=5),
                                          DAY0 + pd.Timedelta(days=6), "candidate",
                                          "T-01-night-5")


def test_record_fit_takes_a_submission_or_its_arguments(registry, fits):
    submission = night(fits, "T-01", 5)
    first = registry.record_fit(submission)
    again = registry.record_fit(submission.asset_id, submission.vehicle_class,
                                submission.signature, role="candidate",
                                window_start=submission.window_start,
                                window_end=submission.window_end, drift=submission.drift,
                                data_hash=submission.data_hash, plots=False)
    assert first.created and not again.created
    assert (again.version, again.run_id, again.fit_key) == (first.version, first.run_id,
                                                             first.fit_key)
    with pytest.raises(TypeError):
        registry.record_fit(submission, plots=True)


def test_batch_recording_equals_one_by_one_and_is_idempotent(registry, fits, tmp_path,
                                                             template_db):
    records = registry.record_fits(batch(fits))
    assert [r.created for r in records] == [True] * len(records)
    assert [(r.asset_id, r.version) for r in records] == [
        (asset, i + 1) for i in range(len(NIGHTS)) for asset in ASSETS]
    single = other_registry(tmp_path, template_db, "one-by-one")
    singles = [single.record_fit(s) for s in batch(fits)]
    assert [r.fit_key for r in records] == [r.fit_key for r in singles]
    assert [r.alarm for r in records] == [r.alarm for r in singles]
    assert snapshot(registry) == snapshot(single)
    for asset in ASSETS:
        model = registry.backend.client.get_registered_model(naming.model_name(asset))
        assert model.aliases == {"candidate": len(NIGHTS)}

    again = registry.record_fits(batch(fits))
    assert not any(r.created for r in again)
    assert [(r.version, r.run_id, r.fit_key) for r in again] == \
        [(r.version, r.run_id, r.fit_key) for r in records]
    assert snapshot(registry) == snapshot(single)


def test_batch_finishes_what_an_interrupted_one_left(registry, fits):
    submissions = batch(fits)
    done = registry.record_fit(submissions[0])
    crashed_key = submissions[1].resolve().key
    client = registry.backend.client
    experiment_id = registry.backend.experiment_id("turbine", create=True)
    crashed = client.create_run(experiment_id, tags={naming.TAG_FIT_KEY: crashed_key,
                                                     naming.TAG_ASSET_ID: "T-02"})
    records = registry.record_fits(submissions)
    assert [r.created for r in records] == [False] + [True] * (len(submissions) - 1)
    assert records[0].run_id == done.run_id
    assert records[1].run_id != crashed.info.run_id
    assert client.get_run(crashed.info.run_id).info.lifecycle_stage == "deleted"
    assert len(snapshot(registry)) == len(submissions)


def test_a_batch_is_checked_before_anything_is_written(registry, fits):
    bad = night(fits, "T-02", 6, window_end=DAY0)
    with pytest.raises(ValueError, match="not before its end"):
        registry.record_fits([night(fits, "T-01", 5), bad])
    assert registry.backend.registered_model("T-01") is None


def test_candidate_model_lives_in_its_run_and_loads(registry, rec, fits):
    rec.baseline()
    registry.promote("T-01", 1, reason="initial")
    record = registry.record_fit(night(fits, "T-01", 5, baseline_version=1))
    assert record.model_id == ""
    client = registry.backend.client
    version = client.get_model_version("fleet-health.T-01", str(record.version))
    run = client.get_run(record.run_id)
    assert version.source == f"{run.info.artifact_uri}/model"
    assert version.run_id == record.run_id
    loaded = registry.load_version("T-01", record.version)
    assert loaded.signature == fits.candidate and loaded.calibration is None
    model = registry.load_pyfunc("T-01", record.version)
    assert set(model.predict(fits.night)["tier"]) == {"linear", "nonlinear", "noise", "level"}
    by_uri = load_by_models_uri(registry.tracking_uri, f"models:/fleet-health.T-01/{record.version}")
    assert by_uri.predict(fits.night)["zeta"].tolist() == pytest.approx(
        model.predict(fits.night)["zeta"].tolist())
    assert registry.load_version("T-01", record.version).signature == fits.candidate


def test_a_remembered_asset_still_cannot_change_class(registry, rec, fits):
    rec.baseline()
    assert registry.watermark("T-01") is None        # the backend has now seen T-01
    with pytest.raises(RegistryError, match="vehicle class 'turbine'"):
        registry.record_fits([dataclasses.replace(night(fits, "T-01", 5), vehicle_class="pump")])


def test_sqlite_store_commits_without_fsync_per_transaction(registry, store_uri):
    engine = registry.backend.client.wrapped._tracking_client.store.engine
    with engine.connect() as connection:
        assert connection.exec_driver_sql("PRAGMA synchronous").scalar() == 1      # NORMAL
        assert connection.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
    path = store_uri[len("sqlite:///"):]
    with sqlite3.connect(path) as other:                 # a connection of its own: default
        assert other.execute("PRAGMA synchronous").fetchone()[0] == 2


def test_a_fit_whose_run_was_deleted_by_hand_keeps_its_version(registry, fits):
    first = registry.record_fit(night(fits, "T-01", 5))
    registry.backend.client.delete_run(first.run_id)
    again = registry.record_fit(night(fits, "T-01", 5))
    assert not again.created and again.version == first.version
    assert [v.version for v in registry.history("T-01")] == [first.version]


def test_fit_keys_are_found_through_an_index(registry, store_uri):
    path = store_uri[len("sqlite:///"):]
    with sqlite3.connect(path) as connection:
        plan = connection.execute(
            "EXPLAIN QUERY PLAN SELECT run_uuid FROM tags WHERE key = ? AND value = ?",
            (naming.TAG_FIT_KEY, "0" * 40)).fetchall()
    assert "fleet_health_tags_key_value" in " ".join(str(row) for row in plan)


def test_a_registered_model_deleted_by_hand_is_made_again(registry, fits):
    registry.record_fit(night(fits, "T-01", 5))          # the backend now remembers T-01
    registry.backend.client.delete_registered_model(naming.model_name("T-01"))
    record = registry.record_fit(night(fits, "T-01", 6))
    assert record.created and record.version == 1
    model = registry.backend.client.get_registered_model(naming.model_name("T-01"))
    assert model.tags[naming.TAG_VEHICLE_CLASS] == "turbine"
    assert model.aliases == {"candidate": 1}
