"""A group's fits recorded together (Registry.record_group: one transaction on SQLite and
PostgreSQL) and its watermarks committed together (Registry.commit_watermarks): the same
records as one by one, each asset on its own when something fails."""
from __future__ import annotations

import pathlib

import pandas as pd
import pytest
from mlflow.entities import ViewType
from mlflow.utils.file_utils import local_file_uri_to_path
from store_copies import copy_store
from test_fit_batches import ASSETS, NIGHTS, batch, night, snapshot

from benchmarks.langevin_fits import DAY0
from registry import FitRecord, Registry
from registry.exceptions import NotFoundError
from registry.store import naming


@pytest.fixture(params=["sqlite", "postgresql"])
def two_registries(request, tmp_path, template_db):
    """Two empty registries on stores of one kind."""
    out = []
    for side in "ab":
        workdir = tmp_path / side
        if request.param == "sqlite":
            uri = copy_store(template_db, workdir)
        else:
            workdir.mkdir()
            server = request.getfixturevalue("postgres_server")
            uri = server.create_database(f"group_{side}_{abs(hash(str(tmp_path))) % 10 ** 8}",
                                         template="mlflow_template")
        out.append(Registry(uri, workdir=workdir, user="tester"))
    return out


def _end(n: int) -> pd.Timestamp:
    return DAY0 + pd.Timedelta(days=n + 1)


def test_a_group_records_what_one_by_one_records(two_registries, fits):
    group, single = two_registries
    assert group.backend.sql_writer() is not None
    records = group.record_group(batch(fits))
    singles = [single.record_fit(s) for s in batch(fits)]
    assert all(isinstance(r, FitRecord) and r.created for r in records)
    assert [(r.asset_id, r.version, r.fit_key, r.alarm) for r in records] == \
        [(r.asset_id, r.version, r.fit_key, r.alarm) for r in singles]
    assert snapshot(group) == snapshot(single)      # runs, params, metrics, artifacts, versions
    for asset in ASSETS:
        assert group.aliases(asset) == single.aliases(asset) == {"candidate": len(NIGHTS)}
        assert [(v.version, v.role, v.aliases) for v in group.history(asset)] == \
            [(v.version, v.role, v.aliases) for v in single.history(asset)]
        assert group.load_version(asset, "candidate").signature == fits.candidate
    pd.testing.assert_frame_equal(group.zeta_history("T-02").drop(columns="run_id"),
                                  single.zeta_history("T-02").drop(columns="run_id"))
    # idempotent: a second recording returns the first
    again = group.record_group(batch(fits))
    assert [(r.created, r.version, r.run_id) for r in again] == \
        [(False, r.version, r.run_id) for r in records]
    assert snapshot(group) == snapshot(single)
    # the watermarks of the group, together; one asset nothing was recorded for fails alone
    ends = {asset: _end(NIGHTS[-1]) for asset in ASSETS} | {"T-99": _end(NIGHTS[-1])}
    committed = group.commit_watermarks(ends)
    assert list(committed) == list(ends)
    assert isinstance(committed.pop("T-99"), NotFoundError)
    assert committed == {asset: _end(NIGHTS[-1]) for asset in ASSETS}
    assert group.commit_watermarks({"T-01": _end(0), "T-02": _end(9)}) == \
        {"T-01": _end(NIGHTS[-1]), "T-02": _end(9)}           # never backwards
    for asset, end in (("T-01", NIGHTS[-1]), ("T-02", 9), ("T-03", NIGHTS[-1])):
        assert group.watermark(asset) == single.commit_watermark(asset, _end(end)) == _end(end)


def _runs(registry: Registry) -> list:
    client = registry.backend.client
    experiment = registry.backend.experiment_id("turbine")
    return client.search_runs([experiment], "", run_view_type=ViewType.ALL)


def _run_dirs(registry: Registry) -> set[str]:
    root = pathlib.Path(local_file_uri_to_path(registry.backend.store.artifact_root))
    return {p.name for p in root.glob("*/*") if p.is_dir()}


@pytest.mark.parametrize("stop_at_error", [True, False])
def test_a_bad_fit_fails_alone_and_the_others_land(registry, fits, stop_at_error,
                                                   monkeypatch):
    from mlflow.exceptions import MlflowException
    from mlflow.protos.databricks_pb2 import INVALID_PARAMETER_VALUE

    writer = registry.backend.sql_writer()
    write_many = writer.write_many

    def refuses_one(items):       # the store refuses the rows of one fit, whatever else
        if any(run.tags.get(naming.TAG_DATA_HASH) == "refused" for run, _ in items):
            raise MlflowException("the store refused a row", INVALID_PARAMETER_VALUE)
        return write_many(items)

    monkeypatch.setattr(writer, "write_many", refuses_one)
    bad = night(fits, "T-02", 5, data_hash="refused")
    submissions = [night(fits, "T-01", 5), bad, night(fits, "T-03", 5),
                   night(fits, "T-01", 6), night(fits, "T-02", 6), night(fits, "T-03", 6)]
    outcomes = registry.record_group(submissions, stop_at_error=stop_at_error)
    monkeypatch.undo()
    assert not isinstance(outcomes[1], FitRecord) and "refused a row" in str(outcomes[1])
    good = [0, 2, 3, 5] + ([] if stop_at_error else [4])
    assert all(isinstance(outcomes[i], FitRecord) and outcomes[i].created for i in good)
    if stop_at_error:
        assert outcomes[4] is None          # T-02's later night waits for the next run
    assert sorted(r.data.tags[naming.TAG_FIT_KEY] for r in _runs(registry)) == \
        sorted(outcomes[i].fit_key for i in good)
    assert _run_dirs(registry) == {outcomes[i].run_id for i in good}   # no orphan artifacts
    assert registry.aliases("T-01") == registry.aliases("T-03") == {"candidate": 2}
    assert registry.aliases("T-02") == ({} if stop_at_error else {"candidate": 1})
    # the next run records what is missing, and finds the rest
    fixed = [night(fits, "T-02", 5) if s is bad else s for s in submissions]
    again = registry.record_group(fixed)
    assert [r.created for r in again] == [i not in good for i in range(len(fixed))]


def test_a_passing_failure_of_the_group_is_raised_and_leaves_nothing(registry, fits,
                                                                     monkeypatch):
    writer = registry.backend.sql_writer()

    def away(items):
        raise ConnectionError("the store went away")

    monkeypatch.setattr(writer, "write_many", away)
    with pytest.raises(ConnectionError, match="went away"):
        registry.record_group(batch(fits))
    monkeypatch.undo()
    assert _runs(registry) == [] and _run_dirs(registry) == set()
    records = registry.record_group(batch(fits))
    assert all(r.created for r in records)


def test_a_failed_group_transaction_falls_back_to_one_per_fit(registry, fits, monkeypatch):
    """The group's transaction fails (here: a registered model deleted by hand since the
    backend saw it); each fit is then written alone, the model made again."""
    records = registry.record_group([night(fits, asset, 5) for asset in ASSETS])
    registry.backend.client.delete_registered_model(naming.model_name("T-02"))
    outcomes = registry.record_group([night(fits, asset, 6) for asset in ASSETS])
    assert [(r.created, r.version) for r in outcomes] == [(True, 2), (True, 1), (True, 2)]
    assert [r.version for r in records] == [1, 1, 1]
    assert registry.aliases("T-02") == {"candidate": 1}
    assert len(_runs(registry)) == len(_run_dirs(registry)) == 6
