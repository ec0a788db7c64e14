"""Plan -> execute -> commit: planning a batch reads no telemetry; executing the plan reads it,
and a read error is the asset's own (named with its file), while the other assets go on."""
from __future__ import annotations

import pytest

from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, day
from flows.results import FAILED, OK, UP_TO_DATE

BROKEN = "T-002"


@pytest.fixture
def unreadable(tmp_path, fleet):
    """A copy of the fleet's telemetry whose every Parquet file of BROKEN's nights is not
    Parquet at all; returns (root, the files, oldest first)."""
    import shutil

    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)
    files = [root / f"asset_id={BROKEN}" / f"date={day(i):%Y-%m-%d}" / "part-0.parquet"
             for i in range(BASELINE_DAYS, DAYS)]
    for path in files:
        path.write_bytes(b"not parquet")
    return root, files


def test_planning_reads_no_telemetry_and_execute_names_the_unreadable_file(
        workspace, unreadable, monkeypatch):
    import flows.pipeline
    from flows.config import load_config
    from flows.discovery import AssetRef
    from flows.nightly import plan_batch
    from flows.pipeline import execute

    root, files = unreadable
    config = load_config(workspace.configure(telemetry=root))
    registry = workspace.registry()
    reads = []
    original = flows.pipeline.read_window
    monkeypatch.setattr(flows.pipeline, "read_window",
                        lambda *args, **kwargs: reads.append(args[1]) or original(*args,
                                                                                   **kwargs))
    refs = [AssetRef(asset, "turbine") for asset in ASSETS]

    plan = plan_batch(config, refs, day(DAYS), registry)
    assert reads == []
    jobs = {job.ref.asset_id: job for job in plan.jobs}
    assert [job.ref.asset_id for job in plan.jobs] == list(ASSETS)
    nights = [(day(i), day(i + 1)) for i in range(BASELINE_DAYS, DAYS)]
    for asset in ASSETS:   # the unreadable asset is planned like every other
        job = jobs[asset]
        assert job.result.status == OK and job.result.error is None, asset
        assert [w.nights for w in job.windows] == [(night,) for night in nights], asset
        assert job.reference is not None and job.stop_at_error, asset

    results = {r.asset_id: r for r in execute(config, plan)}
    assert sorted(set(reads)) == list(ASSETS)
    broken = results[BROKEN]
    assert broken.status == FAILED and broken.windows == []
    assert broken.error.kind == "unreadable" and broken.error.file == str(files[0])
    assert broken.error.window_start == day(BASELINE_DAYS).isoformat()
    assert registry.watermark(BROKEN) is None    # nothing committed: the night is retried
    for asset in set(ASSETS) - {BROKEN}:
        assert results[asset].status == OK, results[asset]
        assert len(results[asset].windows) == len(nights)
        assert registry.watermark(asset) == day(DAYS)

    # planned again: only the failed asset has windows left, and still nothing is read
    reads.clear()
    again = plan_batch(config, refs, day(DAYS), registry)
    assert reads == []
    assert [len(job.windows) for job in again.jobs] == \
        [len(nights) if asset == BROKEN else 0 for asset in ASSETS]
    # the baseline's days lie in the look-back and have no candidate: read as the baseline's
    # from its tag, so an asset up to date loads no baseline (only the failed one does)
    assert day(DAYS) - config.nightly.lookback_delta < day(BASELINE_DAYS)
    assert [job.reference is not None for job in again.jobs] == \
        [asset == BROKEN for asset in ASSETS]
    assert [r.status for r in execute(config, again)] == \
        [FAILED if asset == BROKEN else UP_TO_DATE for asset in ASSETS]


def test_a_baseline_plan_of_unreadable_telemetry_fails_only_when_executed(workspace, unreadable):
    from flows.baseline import plan_baseline_batch
    from flows.config import load_config
    from flows.discovery import AssetRef
    from flows.pipeline import execute

    root, files = unreadable
    config = load_config(workspace.configure(telemetry=root))
    refs = [AssetRef(asset, "turbine") for asset in (BROKEN, "T-001")]
    plan = plan_baseline_batch(config, refs, day(BASELINE_DAYS), day(DAYS),
                               registry=workspace.registry())
    assert [job.result.status for job in plan.jobs] == [OK, OK]
    assert all(job.reference is None and len(job.windows) == DAYS - BASELINE_DAYS
               for job in plan.jobs)

    broken, healthy = execute(config, plan)
    assert broken.status == FAILED and broken.error.file == str(files[0])
    assert broken.note == "bad telemetry never enters a baseline"
    assert healthy.status == OK and healthy.baseline_version is None and healthy.windows
