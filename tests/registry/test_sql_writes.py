"""A candidate recorded in one SQL transaction (registry/store/sql_writes.py) reads back through
MLflow's own client exactly as one recorded through MlflowClient's calls, on SQLite and on
PostgreSQL; a transaction that fails leaves nothing behind."""
from __future__ import annotations

import pathlib

import numpy as np
import pandas as pd
import pytest
from mlflow.entities import ViewType
from mlflow.utils.file_utils import local_file_uri_to_path
from safetensors.numpy import load as load_tensors
from store_copies import copy_store

from benchmarks.langevin_fits import DAY0
from registry.store import naming
from registry.store.sql_writes import SqlWriter

ASSET = "T-01"
NAME = naming.model_name(ASSET)
MANIFEST = naming.TAG_MANIFEST_SHA256
NIGHT = DAY0 + pd.Timedelta(days=5)


@pytest.fixture(params=["sqlite", "postgresql"])
def two_stores(request, tmp_path, template_db):
    """Two empty stores of one kind (and a work directory each)."""
    if request.param == "sqlite":
        return [(copy_store(template_db, tmp_path / side), tmp_path / side) for side in "ab"]
    server = request.getfixturevalue("postgres_server")
    out = []
    for side in "ab":
        (tmp_path / side).mkdir()
        name = f"sqlwrites_{side}_{abs(hash(str(tmp_path))) % 10 ** 8}"
        out.append((server.create_database(name, template="mlflow_template"), tmp_path / side))
    return out


def _recorded(uri, workdir, fits, sql_writes: bool, alarmed: bool = True):
    from registry import Registry

    registry = Registry(uri, workdir=workdir, user="tester")
    registry.backend.sql_writes = sql_writes
    base = registry.record_fit(ASSET, "turbine", fits.baseline, role="baseline",
                               calibration=fits.calibration, window_start=DAY0,
                               window_end=DAY0 + pd.Timedelta(days=4), data_hash="b",
                               plots=False)
    registry.promote(ASSET, base.version, reason="healthy")
    record = registry.record_fit(ASSET, "turbine", fits.candidate, role="candidate",
                                 drift=fits.alarmed if alarmed else fits.drift,
                                 window_start=NIGHT, window_end=NIGHT + pd.Timedelta(days=1),
                                 data_hash="night-5", plots=False)
    return registry, record


def _files(registry, run) -> dict[str, bytes]:
    root = pathlib.Path(local_file_uri_to_path(
        registry.backend.store.local_artifact_uri(run.info.artifact_uri)))
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


def _but(tags: dict, *keys: str) -> dict:
    return {k: v for k, v in tags.items() if k not in keys}


def _version_fields(mv) -> dict:
    skip = {"_creation_time", "_last_updated_timestamp", "_run_id", "_source", "_tags"}
    return {k: v for k, v in vars(mv).items() if k not in skip and 'time' not in k}


def test_the_one_transaction_path_reads_back_as_the_client_path(two_stores, fits):
    (uri_a, dir_a), (uri_b, dir_b) = two_stores
    old_registry, old = _recorded(uri_a, dir_a, fits, sql_writes=False)
    new_registry, new = _recorded(uri_b, dir_b, fits, sql_writes=True)
    assert old_registry.backend.sql_writer() is None
    assert new_registry.backend.sql_writer() is not None
    assert (new.version, new.created, new.alarm, new.fit_key) == (old.version, True, True,
                                                                   old.fit_key) == \
        (2, True, True, old.fit_key)
    a, b = old_registry.backend.client.wrapped, new_registry.backend.client.wrapped
    run_a, run_b = a.get_run(old.run_id), b.get_run(new.run_id)
    # the run: the same tags, params and metrics; finished and active
    # (the manifest's digest is left out: safetensors orders its header's metadata
    # differently from one write to the next, so two writes of a bundle differ in bytes)
    assert _but(run_b.data.tags, MANIFEST) == _but(run_a.data.tags, MANIFEST)
    assert run_b.data.tags[MANIFEST] == new_registry.load_version(ASSET, 2).manifest_sha256
    assert run_b.data.params == run_a.data.params
    assert run_b.data.metrics == run_a.data.metrics and run_b.data.metrics["alarm"] == 1.0
    for field in ("status", "lifecycle_stage", "run_name", "user_id"):
        assert getattr(run_b.info, field) == getattr(run_a.info, field)
    assert run_b.info.status == "FINISHED" and run_b.info.run_name.startswith("T-01 candidate")
    assert run_b.info.start_time <= run_b.info.end_time
    assert run_b.info.artifact_uri.endswith(f"/{new.run_id}/artifacts")
    key = "zeta." + next(k.partition(".")[2] for k in run_a.data.metrics if k.startswith("zeta."))
    history_a, history_b = a.get_metric_history(old.run_id, key), b.get_metric_history(new.run_id,
                                                                                      key)
    assert [(m.value, m.step) for m in history_b] == [(m.value, m.step) for m in history_a]
    assert len(history_b) == 1
    # found by MLflow's search on a tag and on a metric (its latest_metrics)
    for client, run_id in ((a, old.run_id), (b, new.run_id)):
        experiment = [run_a.info.experiment_id] if client is a else [run_b.info.experiment_id]
        assert [r.info.run_id for r in client.search_runs(
            experiment, f"tags.`{naming.TAG_FIT_KEY}` = '{old.fit_key}'")] == [run_id]
        assert [r.info.run_id for r in client.search_runs(
            experiment, "metrics.alarm = 1 and attributes.status = 'FINISHED'")] == [run_id]
    # its version: the same fields and tags (but the run id), the candidate alias
    mv_a = a.get_model_version_by_alias(NAME, "candidate")
    mv_b = b.get_model_version_by_alias(NAME, "candidate")
    assert _version_fields(mv_b) == _version_fields(mv_a)
    assert mv_b.run_id == new.run_id and mv_b.source == f"{run_b.info.artifact_uri}/model"
    assert _but(mv_b.tags, MANIFEST, naming.TAG_RUN_ID) == _but(mv_a.tags, MANIFEST,
                                                                 naming.TAG_RUN_ID)
    assert mv_b.tags[naming.TAG_RUN_ID] == new.run_id
    assert mv_b.tags[MANIFEST] == run_b.data.tags[MANIFEST]
    assert mv_b.aliases == ["candidate"] and mv_b.description.startswith("Candidate fit")
    # the nightly path's direct read of a version by its alias is MLflow's own answer
    for alias in ("candidate", "baseline"):
        assert vars(new_registry.backend.version_by_alias(ASSET, alias)) == \
            vars(b.get_model_version_by_alias(NAME, alias))
    assert new_registry.backend.version_by_alias(ASSET, "nothing") is None
    assert new_registry.backend.version_by_alias("T-99", "baseline") is None
    assert b.get_registered_model(NAME).aliases == a.get_registered_model(NAME).aliases == \
        {"baseline": 1, "candidate": 2}
    assert [v.version for v in b.search_model_versions(f"name = '{NAME}'")] == \
        [v.version for v in a.search_model_versions(f"name = '{NAME}'")]
    # the same artifacts (MLmodel names its own run and time; the weights: see above)
    files_a, files_b = _files(old_registry, run_a), _files(new_registry, run_b)
    assert set(files_b) == set(files_a) and len(files_b) == 11
    varying = ("MLmodel", "manifest.json", "weights.safetensors")
    assert {k: v for k, v in files_b.items() if not k.endswith(varying)} == \
        {k: v for k, v in files_a.items() if not k.endswith(varying)}
    for name in files_b:
        if name.endswith("weights.safetensors"):
            tensors_a, tensors_b = load_tensors(files_a[name]), load_tensors(files_b[name])
            assert set(tensors_a) == set(tensors_b)
            assert all(np.array_equal(tensors_a[k], tensors_b[k]) for k in tensors_a)
    # and the review workflow reads the same
    assert new_registry.load_version(ASSET, "candidate").signature == fits.candidate
    columns = ["window_start", "window_end", "channel", "tier", "zeta", "epsilon", "ratio"]
    pd.testing.assert_frame_equal(new_registry.zeta_history(ASSET)[columns],
                                  old_registry.zeta_history(ASSET)[columns])
    assert [(x.channel, x.tier, x.ratio, x.version) for x in new_registry.alerts()] == \
        [(x.channel, x.tier, x.ratio, x.version) for x in old_registry.alerts()]
    for registry in (old_registry, new_registry):
        registry.reject(ASSET, 2, reason="a noisy night")
    assert new_registry.aliases(ASSET) == old_registry.aliases(ASSET) == {"baseline": 1}
    assert [(v.version, v.role, v.aliases, v.rejected) for v in new_registry.history(ASSET)] == \
        [(v.version, v.role, v.aliases, v.rejected) for v in old_registry.history(ASSET)]
    # recording again finds the first record
    again = new_registry.record_fit(ASSET, "turbine", fits.candidate, role="candidate",
                                    drift=fits.alarmed, window_start=NIGHT,
                                    window_end=NIGHT + pd.Timedelta(days=1), data_hash="night-5",
                                    plots=False)
    assert (again.created, again.version, again.run_id) == (False, 2, new.run_id)


def _promoted_baseline_and_a_night(registry, fits):
    """The asset's baseline recorded and promoted; the store's SQL writer and the night's
    candidate submission, not yet recorded."""
    from registry import FitSubmission

    base = registry.record_fit(ASSET, "turbine", fits.baseline, role="baseline",
                               calibration=fits.calibration, window_start=DAY0,
                               window_end=DAY0 + pd.Timedelta(days=4), data_hash="b",
                               plots=False)
    registry.promote(ASSET, base.version, reason="healthy")
    return registry.backend.sql_writer(), FitSubmission(
        ASSET, "turbine", fits.candidate, role="candidate", drift=fits.drift,
        window_start=NIGHT, window_end=NIGHT + pd.Timedelta(days=1), data_hash="night-5",
        plots=False)


def test_a_failed_transaction_leaves_no_run_version_alias_or_artifacts(registry, fits,
                                                                       monkeypatch):
    writer, submission = _promoted_baseline_and_a_night(registry, fits)
    artifacts = pathlib.Path(local_file_uri_to_path(registry.backend.store.artifact_root))
    before = sorted(artifacts.rglob("*"))

    def broken():     # the version's rows fail after the run's rows were written
        raise RuntimeError("the store went away mid-transaction")

    monkeypatch.setattr(writer.registry, "_get_active_workspace", broken)
    with pytest.raises(Exception, match="went away"):
        registry.record_fit(submission)
    monkeypatch.undo()
    client = registry.backend.client
    experiment = registry.backend.experiment_id("turbine")
    assert client.search_runs([experiment], f"tags.`{naming.TAG_FIT_KEY}` = "
                                            f"'{submission.resolve().key}'",
                              run_view_type=ViewType.ALL) == []
    assert [v.version for v in client.search_model_versions(f"name = '{NAME}'")] == [1]
    assert registry.aliases(ASSET) == {"baseline": 1, "candidate": 1}
    assert vars(registry.backend.version_by_alias(ASSET, "baseline")) == \
        vars(client.get_model_version_by_alias(NAME, "baseline"))     # two aliases
    assert sorted(artifacts.rglob("*")) == before
    record = registry.record_fit(submission)
    assert record.created and record.version == 2
    assert registry.aliases(ASSET) == {"baseline": 1, "candidate": 2}


def test_no_writer_for_a_server_store():
    class Remote:      # an MlflowClient whose stores are REST stores
        class _tracking_client:
            store = object()

        def _get_registry_client(self):
            return type("R", (), {"store": object()})()

    assert SqlWriter.of(Remote()) is None


def test_a_commit_whose_answer_is_lost_keeps_its_artifacts_and_is_found_again(registry, fits,
                                                                               monkeypatch):
    writer, submission = _promoted_baseline_and_a_night(registry, fits)
    written = writer.write

    def committed_then_lost(*args):
        written(*args)
        raise ConnectionError("the server's answer to COMMIT never came")

    monkeypatch.setattr(writer, "write", committed_then_lost)
    with pytest.raises(Exception, match="never came"):
        registry.record_fit(submission)
    monkeypatch.undo()
    again = registry.record_fit(submission)
    assert not again.created and again.version == 2
    assert registry.load_version(ASSET, 2).signature == fits.candidate   # artifacts kept
    assert registry.aliases(ASSET) == {"baseline": 1, "candidate": 2}
