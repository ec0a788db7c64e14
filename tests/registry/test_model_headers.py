"""Registered models read without their versions: the same tags and aliases as MLflow's
``get_registered_model`` on an asset with a long history, and no version read to get them."""
from __future__ import annotations

from types import SimpleNamespace

import pandas as pd
import pytest
import sqlalchemy

from registry.store import naming
from registry.exceptions import NotFoundError
from registry.store.model_headers import ModelHeader, read_headers

HISTORY = 40        # filler versions: a history much longer than one alias's worth


def add_history(registry, asset_id: str, source: str, count: int = HISTORY) -> None:
    """``count`` more versions of the asset's model (no runs: only the versions matter)."""
    inner = registry.backend.client.wrapped._get_registry_client()
    for k in range(count):
        inner.create_model_version(naming.model_name(asset_id), source=source, run_id=None,
                                   tags={naming.TAG_ROLE: "candidate",
                                         naming.TAG_FIT_KEY: f"history-{k}"})


@pytest.fixture
def long_history(registry, rec):
    """T-01: a promoted baseline, a watermark, HISTORY filler versions, then a candidate; T-02:
    a candidate only."""
    base = rec.baseline("T-01")
    registry.promote("T-01", base.version, reason="known answer")
    registry.commit_watermark("T-01", "2026-02-01")
    source = registry.backend.model_version("T-01", base.version).source
    add_history(registry, "T-01", source)
    candidate = rec.candidate("T-01", night=9)
    rec.candidate("T-02", night=9)
    return SimpleNamespace(baseline=base.version, candidate=candidate.version)


def mlflow_view(registry, asset_id: str) -> ModelHeader:
    return ModelHeader.from_registered_model(
        registry.backend.client.get_registered_model(naming.model_name(asset_id)))


def statements_during(registry, call) -> list[str]:
    """The SQL statements the registry store runs during ``call()``."""
    engine = registry.backend.client.wrapped._get_registry_client().store.engine
    seen: list[str] = []

    def record(conn, cursor, statement, *args):
        seen.append(statement)

    sqlalchemy.event.listen(engine, "before_cursor_execute", record)
    try:
        call()
    finally:
        sqlalchemy.event.remove(engine, "before_cursor_execute", record)
    return seen


def test_headers_equal_mlflows_registered_models_with_a_long_history(registry, long_history):
    assert long_history.candidate == HISTORY + 2
    for asset in ("T-01", "T-02"):
        assert registry.backend.registered_model(asset) == mlflow_view(registry, asset)
    header = registry.backend.registered_model("T-01")
    assert header.aliases == {"baseline": long_history.baseline,
                              "candidate": long_history.candidate}
    assert header.tags[naming.TAG_WATERMARK] == "2026-02-01T00:00:00+00:00"
    assert registry.backend.registered_model("T-03") is None
    with pytest.raises(NotFoundError):
        registry.backend.require_registered_model("T-03")


def test_several_headers_are_read_together(registry, long_history):
    found = registry.backend.registered_models(["T-01", "T-02", "T-03"])
    assert found == {a: mlflow_view(registry, a) for a in ("T-01", "T-02")}


def test_a_store_without_sql_reads_the_same_headers_by_search(registry, long_history):
    client = registry.backend.client.wrapped
    names = [naming.model_name(a) for a in ("T-01", "T-02", "T-03")]
    searched = SimpleNamespace(store=None,
                               search_registered_models=client.search_registered_models)
    direct = read_headers(client._get_registry_client(), names)
    assert read_headers(searched, names) == direct
    assert read_headers(searched, names[:1]) == {names[0]: direct[names[0]]}
    assert set(direct) == set(names[:2])


def test_watermark_and_baseline_read_no_version_but_the_baseline(registry, long_history):
    reads = {"watermark": lambda: registry.watermark("T-01"),
             "commit_watermark": lambda: registry.commit_watermark("T-01", "2026-02-02"),
             "baseline": lambda: registry.baseline("T-01")}
    for name, call in reads.items():
        statements = statements_during(registry, call)
        versions = [s for s in statements if "FROM model_versions" in s]
        # the baseline reads its one version by alias (and that version's tags); the
        # watermark reads none
        assert len(versions) <= (2 if name == "baseline" else 0), (name, versions)
        assert all("version = " in s for s in versions), (name, versions)
    assert registry.watermark("T-01") == pd.Timestamp("2026-02-02", tz="UTC")
    assert registry.baseline("T-01").version == long_history.baseline
