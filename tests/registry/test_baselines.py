"""Baselines: alias moves, refusals, safe loading, tampering, pyfunc, serialized promotions."""
from __future__ import annotations

import pathlib
import pickle
import threading
import urllib.parse

import mlflow
import pandas as pd
import pytest
import yaml
from mlflow_loading import load_by_models_uri

from graybox.exceptions import ArtifactError
from registry.store import naming
from registry.exceptions import NotFoundError, PromotionError


class Boom:
    """Unpickling this creates ``marker``: proof of whether anything was unpickled."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (open, (str(self.marker), "w"))


def model_dir(registry, version: int, asset_id: str = "T-01") -> pathlib.Path:
    source = registry.backend.client.get_model_version(naming.model_name(asset_id),
                                                       str(version)).source
    return pathlib.Path(urllib.parse.urlparse(source).path)


def baselines_held(registry, asset_id="T-01"):
    return [v.version for v in registry.history(asset_id) if "baseline" in v.aliases]


def test_promote_then_rollback_leaves_exactly_one_baseline(rec, registry):
    first, second = rec.baseline(shift_days=0), rec.baseline(shift_days=10)
    assert registry.promote("T-01", first.version, reason="initial").version == first.version
    assert baselines_held(registry) == [first.version]
    promoted = registry.promote("T-01", second.version, reason="after overhaul")
    assert promoted.previous_baseline == first.version
    assert baselines_held(registry) == [second.version]
    restored = registry.rollback("T-01", reason="overhaul baseline was noisy")
    assert restored.version == first.version
    assert baselines_held(registry) == [first.version]
    assert registry.baseline("T-01").version == first.version
    rolled = registry.history("T-01")[second.version - 1]
    assert rolled.rollback_reason == "overhaul baseline was noisy" and rolled.rolled_back_by == "tester"
    assert rolled.aliases == ("candidate",)
    with pytest.raises(PromotionError, match="nothing to roll back to"):
        registry.rollback("T-01", reason="again")
    assert baselines_held(registry) == [first.version]


def test_promote_defaults_to_the_candidate_and_is_idempotent(rec, registry):
    record = rec.baseline()
    info = registry.promote("T-01", reason="initial")
    assert info.version == record.version and info.aliases == ("baseline", "candidate")
    again = registry.promote("T-01", reason="twice")
    assert again.promotion_reason == "initial"      # nothing changed


def test_uncalibrated_rejected_and_reasonless_promotions_are_refused(rec, registry):
    base = rec.baseline()
    night = rec.candidate(night=5)
    with pytest.raises(PromotionError, match=f"version {night.version} has no calibration.*"
                                             f"newest promotable version is {base.version}"):
        registry.promote("T-01", reason="try the nightly fit")
    with pytest.raises(PromotionError, match="needs a reason"):
        registry.promote("T-01", base.version, reason="  ")
    registry.reject("T-01", base.version, reason="bad sensor during the window")
    with pytest.raises(PromotionError, match="was rejected"):
        registry.promote("T-01", base.version, reason="anyway")
    with pytest.raises(NotFoundError):
        registry.promote("T-01", 99, reason="x")
    with pytest.raises(NotFoundError):
        registry.promote("T-99", reason="x")
    assert baselines_held(registry) == []


def test_reject_drops_the_candidate_alias_and_spares_the_baseline(rec, registry):
    base = rec.baseline()
    registry.promote("T-01", base.version, reason="initial")
    night = rec.candidate(night=5)
    info = registry.reject("T-01", night.version, reason="telemetry glitch")
    assert info.rejected and info.status == "rejected" and "candidate" not in info.aliases
    assert info.rejection_reason == "telemetry glitch" and info.rejected_by == "tester"
    assert registry.backend.client.get_registered_model("fleet-health.T-01").aliases == {
        "baseline": base.version}
    with pytest.raises(PromotionError, match="is the baseline"):
        registry.reject("T-01", base.version, reason="no")


def test_list_and_history(rec, registry):
    rec.baseline()
    registry.promote("T-01", 1, reason="initial")
    rec.candidate(night=5, alarmed=True)
    rec.baseline(asset_id="T-02")
    registry.commit_watermark("T-01", "2026-01-07")
    summaries = registry.list_baselines()
    assert [s.asset_id for s in summaries] == ["T-01", "T-02"]
    t1, t2 = summaries
    assert (t1.baseline.version, t1.candidate.version, t1.latest_version) == (1, 2, 2)
    assert t1.candidate.alarm is True and t1.watermark.startswith("2026-01-07")
    assert t2.baseline is None and t2.candidate.version == 1 and t2.vehicle_class == "turbine"
    assert registry.list_baselines("pump") == []
    assert [s.asset_id for s in registry.list_baselines("turbine")] == ["T-01", "T-02"]
    history = registry.history("T-01")
    assert [(v.version, v.status, v.role) for v in history] == [
        (1, "baseline", "baseline"), (2, "candidate", "candidate")]
    assert history[1].baseline_version == 1


def test_tampered_artifact_is_refused_never_executed(rec, registry, tmp_path):
    first, second = rec.baseline(shift_days=0), rec.baseline(shift_days=10)
    registry.promote("T-01", first.version, reason="initial")
    marker = tmp_path / "executed"
    bundle = model_dir(registry, second.version) / "data" / "signature"
    (bundle / "signature.json").write_bytes(pickle.dumps(Boom(marker)))
    with pytest.raises(PromotionError, match=r"version 2: its artifacts do not load: .*"
                                             r"signature\.json: sha256 does not match"):
        registry.promote("T-01", second.version, reason="after overhaul")
    assert baselines_held(registry) == [first.version]
    with pytest.raises(ArtifactError, match=r"asset 'T-01' version 2: signature\.json"):
        registry.load_version("T-01", second.version)
    # MLflow's own loader reaches registry.pyfunc, which refuses the bundle too
    with pytest.raises(ArtifactError, match="signature.json"):
        mlflow.pyfunc.load_model(str(model_dir(registry, second.version)))
    assert not marker.exists()


def test_pickled_model_dropped_into_a_version_is_refused(rec, registry, tmp_path):
    record = rec.baseline()
    root = model_dir(registry, record.version)
    marker = tmp_path / "executed"
    (root / "python_model.pkl").write_bytes(pickle.dumps(Boom(marker)))
    description = yaml.safe_load((root / "MLmodel").read_text())
    flavor = description["flavors"]["python_function"]
    flavor.pop("loader_module")
    flavor.update(python_model="python_model.pkl", cloudpickle_version="3.0.0")
    (root / "MLmodel").write_text(yaml.safe_dump(description))
    with pytest.raises(ArtifactError, match="python_model.pkl: unexpected file"):
        registry.load_pyfunc("T-01", record.version)
    (root / "python_model.pkl").unlink()
    with pytest.raises(ArtifactError, match="pickled python_model"):
        registry.load_version("T-01", record.version)
    with pytest.raises(PromotionError, match="do not load"):
        registry.promote("T-01", record.version, reason="x")
    assert not marker.exists()


def test_missing_artifacts_give_a_clear_error(rec, registry):
    first, second = rec.baseline(shift_days=0), rec.baseline(shift_days=10)
    (model_dir(registry, first.version) / "data" / "signature" / "weights.safetensors").unlink()
    with pytest.raises(ArtifactError, match=r"asset 'T-01' version 1: weights\.safetensors: missing"):
        registry.load_version("T-01", first.version)
    import shutil

    shutil.rmtree(model_dir(registry, second.version))
    with pytest.raises(ArtifactError, match="asset 'T-01' version 2: model artifacts"):
        registry.load_version("T-01", second.version)


def test_pyfunc_from_the_models_uri_returns_zeta_per_tier(rec, registry, fits):
    record = rec.baseline()
    registry.promote("T-01", record.version, reason="initial")
    model = load_by_models_uri(registry.tracking_uri, "models:/fleet-health.T-01@baseline")
    result = model.predict(fits.night)
    assert list(result.columns) == ["channel", "tier", "zeta", "epsilon", "ratio", "exceeded"]
    assert [(r.channel, r.tier) for r in result.itertuples()] == [
        ("omega", "linear"), ("omega", "nonlinear"), ("omega", "noise"), ("omega", "level")]
    expected = {(e.channel, e.tier): e for e in fits.drift.entries}
    for row in result.itertuples():
        assert row.zeta == pytest.approx(expected[row.channel, row.tier].zeta, rel=1e-6, abs=1e-12)
        assert row.epsilon == pytest.approx(expected[row.channel, row.tier].epsilon)
    # a timestamp column and a naive index are accepted too; an off-grid frame is refused
    with_column = fits.night.reset_index()
    assert model.predict(with_column)["zeta"].tolist() == pytest.approx(result["zeta"].tolist())
    with pytest.raises(ValueError, match="uniform grid"):
        model.predict(fits.night.iloc[::2])
    with pytest.raises(ValueError, match="lacks column"):
        model.predict(fits.night[["omega"]])
    # the registry's own (verified) route gives the same
    same = registry.load_pyfunc("T-01").predict(fits.night)
    assert same["zeta"].tolist() == pytest.approx(result["zeta"].tolist())


def test_promotions_of_one_asset_are_serialized(rec, registry):
    versions = [rec.baseline(shift_days=10 * k).version for k in range(4)]
    barrier = threading.Barrier(len(versions))
    errors = []

    def promote(version):
        barrier.wait()
        try:
            registry.promote("T-01", version, reason=f"race {version}")
        except Exception as error:   # pragma: no cover - reported below
            errors.append(error)

    threads = [threading.Thread(target=promote, args=(v,)) for v in versions]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors
    history = {v.version: v for v in registry.history("T-01")}
    assert baselines_held(registry) == [registry.baseline("T-01").version]
    # each promotion saw the one before it: the previous-baseline chain visits all four
    chain, current = [], registry.baseline("T-01").version
    while current is not None:
        chain.append(current)
        current = history[current].previous_baseline
    assert sorted(chain) == versions
    times = [pd.Timestamp(history[v].promoted_at) for v in reversed(chain)]
    assert times == sorted(times)
