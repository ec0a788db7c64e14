"""A batch's planning reads the registry together (flows.planning_reads): the same plans as
asset by asset, in three reads whatever the batch's size, and asset by asset again when the
reads together fail."""
from __future__ import annotations

import pytest

from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, day


def _plan_facts(jobs):
    """What planning decided per asset (no object identities)."""
    return [(job.ref.asset_id, job.result.status, job.result.note,
             job.result.watermark_before, job.reference is not None,
             [w.nights for w in job.windows]) for job in jobs]


@pytest.fixture
def watermarked(workspace):
    """The baselined store with every asset's watermark at its baseline's end: the
    look-back then holds the baseline's days (no candidate), and the nights after it are
    new."""
    registry = workspace.registry()
    for asset in ASSETS:
        registry.commit_watermark(asset, day(BASELINE_DAYS))
    return workspace


def test_a_batch_planned_together_is_planned_as_asset_by_asset(watermarked, monkeypatch):
    from flows.config import load_config
    from flows.discovery import AssetRef
    from flows.nightly import plan_asset, plan_batch

    config = load_config(watermarked.config)
    registry = watermarked.registry()
    refs = [AssetRef(asset, "turbine") for asset in ASSETS]
    calls = {"one": 0, "many": 0}
    for name in ("watermark", "recorded_windows", "baseline_window_end"):
        original = getattr(registry, name)
        monkeypatch.setattr(registry, name, lambda *a, _f=original, **k: (
            calls.__setitem__("one", calls["one"] + 1), _f(*a, **k))[1])
    for name in ("watermarks", "recorded_windows_of", "baseline_window_ends"):
        original = getattr(registry, name)
        monkeypatch.setattr(registry, name, lambda *a, _f=original, **k: (
            calls.__setitem__("many", calls["many"] + 1), _f(*a, **k))[1])

    for as_of in (day(BASELINE_DAYS), day(DAYS)):  # nothing new; then the nights after it
        alone = [plan_asset(config, registry, ref, as_of) for ref in refs]
        one_by_one = calls["one"]
        assert one_by_one >= 2 * len(refs)            # each asset asks on its own
        calls.update(one=0, many=0)
        together = plan_batch(config, refs, as_of, registry)
        assert calls == {"one": 0, "many": 3}         # the batch asks three times
        calls.update(one=0, many=0)
        assert _plan_facts(together.jobs) == _plan_facts(alone)
    # the nights planned: those after the baseline for every asset, against its baseline
    nights = [((day(i), day(i + 1)),) for i in range(BASELINE_DAYS, DAYS)]
    assert all([w.nights for w in job.windows] == nights and job.reference is not None
               for job in together.jobs)

    # reads together that fail: the batch is planned asset by asset, as before
    def fail(*args, **kwargs):
        raise RuntimeError("the store refused the query")
    monkeypatch.setattr(registry, "recorded_windows_of", fail)
    again = plan_batch(config, refs, day(DAYS), registry)
    assert calls["one"] >= 2 * len(refs)
    assert _plan_facts(again.jobs) == _plan_facts(alone)

    # a passing failure of the store is the batch's: it is retried, not read asset by asset
    from flows.errors import TransientError
    from registry.exceptions import TransientStoreError

    def away(*args, **kwargs):
        raise TransientStoreError("database is locked")
    monkeypatch.setattr(registry, "recorded_windows_of", away)
    with pytest.raises(TransientError, match="reading the registry for 5 asset"):
        plan_batch(config, refs, day(DAYS), registry)


def test_versions_to_read_cover_the_look_back(tmp_path):
    from flows.config import load_config
    from flows.planning_reads import versions_to_read

    from flowtest_config import write_config

    # a 1-day window, a 7-day look-back
    config = load_config(write_config(tmp_path / "fleet.toml", tmp_path, tmp_path / "m.db"))
    # from 7 days before the watermark to as_of one day after it: 8 nights, twice, plus 2
    assert versions_to_read(config, day(BASELINE_DAYS + 7), day(BASELINE_DAYS + 8)) == 18
