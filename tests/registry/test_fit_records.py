"""Recording fits: the run record, the round trip, idempotence, watermarks, history, alerts."""
from __future__ import annotations

import dataclasses
import json
import pathlib
import urllib.parse

import pandas as pd
import pytest

from benchmarks.langevin_fits import DAY0
from graybox.exceptions import ArtifactError, InvalidAssetIdError
from registry.store import naming
from graybox.alert import Alert, alerts_from_drift
from graybox.severity import SeverityScale
from registry.exceptions import NotFoundError


def _active_runs(registry, asset_id="T-01"):
    client = registry.backend.client
    experiment = client.get_experiment_by_name("fleet-health/turbine")
    return client.search_runs([experiment.experiment_id],
                              f"tags.`{naming.TAG_ASSET_ID}` = '{asset_id}'")


def test_round_trip_recorded_promoted_and_loaded_back_equal(registry, fits):
    record = registry.record_fit("T-01", "turbine", fits.baseline, role="baseline",
                                 calibration=fits.calibration, window=fits.days)
    assert record.created and record.version == 1
    promoted = registry.promote("T-01", record.version, reason="healthy after overhaul")
    assert promoted.status == "baseline" and promoted.promotion_reason == "healthy after overhaul"
    assert promoted.promoted_by == "tester"
    loaded = registry.baseline("T-01")
    assert loaded.version == record.version
    assert loaded.signature == fits.baseline
    assert loaded.calibration == fits.calibration
    assert loaded.signature.parameter_vector()[1].tolist() == \
        fits.baseline.parameter_vector()[1].tolist()


def test_run_record_holds_tags_params_metrics_and_artifacts(registry, fits):
    record = registry.record_fit("T-01", "turbine", fits.baseline, role="baseline",
                                 calibration=fits.calibration, window=fits.days)
    client = registry.backend.client
    run = client.get_run(record.run_id)
    tags = run.data.tags
    assert tags[naming.TAG_ASSET_ID] == "T-01"
    assert tags[naming.TAG_ROLE] == "baseline"
    assert tags[naming.TAG_WINDOW_START] == fits.baseline.window_start
    assert pd.Timestamp(tags[naming.TAG_WINDOW_END]) == pd.Timestamp(fits.baseline.window_end)
    assert tags[naming.TAG_DATA_HASH] == record.data_hash and len(record.data_hash) == 64
    assert tags[naming.TAG_CODE_VERSION]
    assert tags[naming.TAG_COMPLETE] == "true"
    assert run.info.status == "FINISHED"
    experiment = client.get_experiment(run.info.experiment_id)
    assert experiment.name == "fleet-health/turbine"
    params = run.data.params
    structure = fits.baseline.channel("omega").structure
    assert params["channels.omega.ar_order"] == str(structure.ar_order)
    assert params["channels.omega.embedding_dim"] == str(structure.embedding_dim)
    assert params["model.spec"] == fits.baseline.model.spec
    metrics = run.data.metrics
    for tier in ("linear", "nonlinear", "noise"):
        assert metrics[f"epsilon.omega.{tier}"] == fits.calibration.epsilon("omega", tier)
    for moment in ("mean", "variance", "skewness", "excess_kurtosis"):
        assert f"noise.omega.{moment}" in metrics
    assert "fit.omega.nn_train_mse" in metrics and "fit.omega.ar_innovation_variance" in metrics
    files = {a.path for a in client.list_artifacts(record.run_id, "signature")}
    assert files == {"signature/signature.json", "signature/calibration.json",
                     "signature/weights.safetensors", "signature/manifest.json"}
    plots = {a.path for a in client.list_artifacts(record.run_id, "plots")}
    assert plots == {"plots/residual_acf.png", "plots/tier_fits.png"}
    logged = client.get_logged_model(record.model_id)
    assert logged.source_run_id == record.run_id
    version = client.get_model_version("fleet-health.T-01", "1")
    assert version.tags[naming.TAG_FIT_KEY] == record.fit_key
    assert version.tags[naming.TAG_CALIBRATED] == "true"
    assert client.get_registered_model("fleet-health.T-01").aliases == {"candidate": 1}


def test_candidate_logs_drift_alarm_and_trend_plot(rec, registry, fits):
    rec.baseline()
    registry.promote("T-01", 1, reason="initial")
    record = rec.candidate(night=5, alarmed=True, plots=True, window=fits.night)
    assert record.alarm is True and record.role == "candidate"
    client = registry.backend.client
    run = client.get_run(record.run_id)
    assert run.data.tags[naming.TAG_ALARM] == "true"
    assert run.data.tags[naming.TAG_BASELINE_VERSION] == "1"
    for entry in fits.alarmed.entries:
        key = f"{entry.channel}.{entry.tier}"
        assert run.data.metrics[f"zeta.{key}"] == pytest.approx(entry.zeta)
        assert run.data.metrics[f"epsilon.{key}"] == pytest.approx(entry.epsilon)
        assert run.data.metrics[f"ratio.{key}"] == pytest.approx(entry.ratio)
    assert run.data.metrics["alarm"] == 1.0
    with open(client.download_artifacts(record.run_id, "drift.json")) as handle:
        drift = json.load(handle)
    assert drift["alarmed"] is True and drift["baseline_version"] == 1
    plots = {a.path for a in client.list_artifacts(record.run_id, "plots")}
    assert "plots/zeta_trend.png" in plots and "plots/tier_fits.png" in plots
    mv = client.get_model_version("fleet-health.T-01", str(record.version))
    assert mv.tags[naming.TAG_ALARM] == "true" and mv.tags[naming.TAG_CALIBRATED] == "false"
    assert client.get_registered_model("fleet-health.T-01").aliases == {
        "baseline": 1, "candidate": record.version}


def test_recording_the_same_window_twice_leaves_one_version_and_one_run(rec, registry):
    first = rec.candidate(night=5)
    again = rec.candidate(night=5)
    assert first.created and not again.created
    assert (again.version, again.run_id, again.fit_key) == (first.version, first.run_id,
                                                             first.fit_key)
    assert [v.version for v in registry.history("T-01")] == [first.version]
    assert len(_active_runs(registry)) == 1
    other = rec.candidate(night=6)
    assert other.created and other.version == first.version + 1
    assert len(_active_runs(registry)) == 2


def test_a_baseline_fitted_again_with_another_configuration_is_a_new_version(registry, fits):
    # the same days fitted again: with the same configuration the same fit (a result that
    # differs in its last digits between processes included), with other settings or
    # another false-alarm rate a new one (it was the first version, silently)
    def record(signature=fits.baseline, calibration=fits.calibration):
        return registry.record_fit("T-01", "turbine", signature, role="baseline",
                                   calibration=calibration, window_start=DAY0,
                                   window_end=DAY0 + pd.Timedelta(days=4),
                                   data_hash="baseline-data", plots=False)

    first = record()
    again = record(dataclasses.replace(fits.baseline, n_samples=fits.baseline.n_samples + 1))
    assert first.created and not again.created and again.version == first.version
    splits = fits.baseline.settings.calibration_splits + 1
    other = record(dataclasses.replace(fits.baseline, settings=dataclasses.replace(
        fits.baseline.settings, calibration_splits=splits)))
    assert other.created and other.version == first.version + 1
    rate = record(calibration=dataclasses.replace(fits.calibration, false_alarm_rate=0.005))
    assert rate.created and rate.version == first.version + 2
    assert len({first.fit_key, other.fit_key, rate.fit_key}) == 3


def test_an_interrupted_recording_is_replaced_not_duplicated(rec, registry):
    client = registry.backend.client
    key = naming.fit_key("T-01", DAY0 + pd.Timedelta(days=5), DAY0 + pd.Timedelta(days=6),
                         "candidate", "night-5")
    experiment_id = registry.backend.experiment_id("turbine", create=True)
    crashed = client.create_run(experiment_id, tags={naming.TAG_FIT_KEY: key,
                                                     naming.TAG_ASSET_ID: "T-01"})
    record = rec.candidate(night=5)
    assert record.created and record.run_id != crashed.info.run_id
    assert [r.info.run_id for r in _active_runs(registry)] == [record.run_id]
    assert client.get_run(crashed.info.run_id).info.lifecycle_stage == "deleted"


def test_a_complete_run_without_its_version_gets_one_and_no_new_run(rec, registry, fits):
    first = rec.candidate(night=5)
    registry.backend.client.delete_model_version("fleet-health.T-01", str(first.version))
    again = rec.candidate(night=5)
    assert again.created and again.run_id == first.run_id and again.model_id == first.model_id
    assert [r.info.run_id for r in _active_runs(registry)] == [first.run_id]
    assert registry.load_version("T-01", again.version).signature == fits.candidate


def test_record_validates_inputs(registry, fits):
    with pytest.raises(InvalidAssetIdError):
        registry.record_fit("../etc", "turbine", fits.baseline, role="baseline")
    with pytest.raises(ValueError, match="role"):
        registry.record_fit("T-01", "turbine", fits.baseline, role="nightly")
    with pytest.raises(ValueError, match="no drift"):
        registry.record_fit("T-01", "turbine", fits.baseline, role="baseline", drift=fits.drift)
    with pytest.raises(ValueError, match="no calibration"):
        registry.record_fit("T-01", "turbine", fits.candidate, role="candidate",
                            calibration=fits.calibration)
    with pytest.raises(ValueError, match="vehicle class"):
        registry.record_fit("T-01", "a/b", fits.baseline, role="baseline")


def test_asset_cannot_change_vehicle_class(rec, registry, fits):
    rec.baseline()
    from registry.exceptions import RegistryError

    with pytest.raises(RegistryError, match="vehicle class 'turbine'"):
        registry.record_fit("T-01", "pump", fits.baseline, role="baseline",
                            calibration=fits.calibration, data_hash="x")


def test_watermark_is_read_from_the_registered_model_and_only_advances(rec, registry):
    assert registry.watermark("T-01") is None
    with pytest.raises(NotFoundError):
        registry.commit_watermark("T-01", "2026-01-06")
    rec.candidate(night=5)
    assert registry.watermark("T-01") is None          # recording alone does not commit
    assert registry.commit_watermark("T-01", "2026-01-07") == pd.Timestamp("2026-01-07", tz="UTC")
    assert registry.commit_watermark("T-01", "2026-01-06") == pd.Timestamp("2026-01-07", tz="UTC")
    assert registry.watermark("T-01") == pd.Timestamp("2026-01-07", tz="UTC")
    registry.commit_watermark("T-01", pd.Timestamp("2026-01-08 01:00", tz="Europe/Paris"))
    assert registry.watermark("T-01") == pd.Timestamp("2026-01-08", tz="UTC")


def test_baseline_window_end_is_the_window_of_the_version_the_alias_names(rec, registry):
    """Read from the alias's version tag without loading it, on SQLite's rows and through
    MLflow's client alike: None before a promotion, then the promoted version's window end,
    which moves with the alias."""
    day4 = DAY0 + pd.Timedelta(days=4)
    rec.baseline()
    later = rec.baseline(shift_days=2)
    for sql_writes in (True, False):
        registry.backend.sql_writes = sql_writes
        try:
            assert registry.baseline_window_end("T-01") is None    # recorded, not promoted
            assert registry.baseline_window_end("T-99") is None    # nothing recorded
        finally:
            registry.backend.sql_writes = True
    registry.promote("T-01", 1, reason="initial")
    for sql_writes in (True, False):
        registry.backend.sql_writes = sql_writes
        try:
            assert registry.baseline_window_end("T-01") == day4
        finally:
            registry.backend.sql_writes = True
    registry.promote("T-01", later.version, reason="the later window")
    assert registry.baseline_window_end("T-01") == day4 + pd.Timedelta(days=2)
    assert registry.baseline_window_end("T-01") == pd.Timestamp(
        registry.reference("T-01").info.window_end)


def test_the_reads_of_many_assets_are_each_assets_read(rec, registry):
    """``watermarks``, ``baseline_window_ends`` and ``recorded_windows_of`` give, asset by
    asset, what the one-asset reads give, whatever ``last`` (the versions ranked in the
    database), on SQLite's rows and through MLflow's client alike."""
    rec.baseline()
    registry.promote("T-01", 1, reason="initial")
    for night in (5, 6, 7):
        rec.candidate(night=night)
    rec.baseline(shift_days=1)                    # a baseline version among the candidates
    rec.candidate(night=8)
    rec.candidate(asset_id="T-02", night=6)
    registry.commit_watermark("T-01", "2026-01-09")
    assets = ["T-01", "T-02", "T-99"]
    for sql_writes in (True, False):
        registry.backend.sql_writes = sql_writes
        try:
            assert registry.watermarks(assets) == {a: registry.watermark(a) for a in assets}
            assert registry.baseline_window_ends(assets) == {
                a: registry.baseline_window_end(a) for a in assets}
            for last in (1, 2, 3, 10):
                assert registry.recorded_windows_of(assets, last) == {
                    a: registry.recorded_windows(a, last) for a in assets}
        finally:
            registry.backend.sql_writes = True
    assert registry.watermarks(["T-01"])["T-01"] == pd.Timestamp("2026-01-09", tz="UTC")
    assert len(registry.recorded_windows_of(assets, 10)["T-01"]) == 4
    assert registry.recorded_windows_of(assets, 10)["T-99"] == []


def test_zeta_history_and_alerts(rec, registry, fits):
    rec.baseline()
    registry.promote("T-01", 1, reason="initial")
    rec.candidate(night=5)
    alarmed = rec.candidate(night=6, alarmed=True)
    other = rec.candidate(asset_id="T-02", night=6, alarmed=True)
    history = registry.zeta_history("T-01")
    assert list(history.columns[:5]) == ["window_start", "window_end", "channel", "tier", "zeta"]
    assert len(history) == 2 * 4                       # two windows, four tiers
    assert history["window_end"].is_monotonic_increasing
    first = history[history["window_end"] == history["window_end"].iloc[0]]
    assert first.set_index("tier")["zeta"].to_dict() == pytest.approx(
        {e.tier: e.zeta for e in fits.drift.entries})
    assert registry.zeta_history("T-99").empty
    latest = registry.zeta_history("T-01", last=1)
    assert len(latest) == 4 and set(latest["window_end"]) == {history["window_end"].iloc[-1]}
    # the flags recorded are the drift's: every tier but the noise tier, whose epsilon is
    # at least what its moments' sampling noise crosses (the fixture's 1e-6 times the
    # calibrated epsilons cannot take it below that, and the night is healthy)
    assert latest.set_index("tier")["exceeded"].to_dict() == \
        {e.tier: e.exceeded for e in fits.alarmed.entries}
    assert {e.tier for e in fits.alarmed.entries if not e.exceeded} == {"noise"}
    # the same windows without the metrics, newest first; the baseline is not a candidate
    windows = history.drop_duplicates("window_end")[["window_start", "window_end"]]
    assert registry.recorded_windows("T-01", last=5) == \
        [tuple(w) for w in windows.to_numpy()][::-1]
    assert registry.recorded_windows("T-01", last=1) == [tuple(windows.to_numpy()[-1])]
    assert registry.recorded_windows("T-99", last=3) == []
    # read from the tags' rows (SQLite) as the client's search of the versions reads them
    assert registry.backend.sql_writer() is not None
    registry.backend.sql_writes = False
    try:
        assert registry.recorded_windows("T-01", last=5) == \
            [tuple(w) for w in windows.to_numpy()][::-1]
        assert registry.recorded_windows("T-01", last=1) == [tuple(windows.to_numpy()[-1])]
        assert registry.recorded_windows("T-99", last=3) == []
    finally:
        registry.backend.sql_writes = True
    # one Alert per exceeded (channel, tier) of each alarmed window, oldest window first
    alerts = registry.alerts()
    exceeded = len(fits.alarmed.alarms)
    assert exceeded
    assert [(a.asset_id, a.window_end[:10]) for a in alerts] == (
        [("T-01", "2026-01-08")] * exceeded + [("T-02", "2026-01-08")] * exceeded)
    assert all(isinstance(a, Alert) and a.zeta > a.epsilon and a.source == "nightly"
               for a in alerts)
    assert {a.baseline_version for a in alerts[:exceeded]} == {1}
    assert {a.baseline_version for a in alerts[exceeded:]} == {None}   # T-02 has no baseline
    # the very records the nightly run makes of the drift (top changes, version and all)
    for record, baseline, mine in ((alarmed, 1, alerts[:exceeded]),
                                   (other, None, alerts[exceeded:])):
        assert mine == alerts_from_drift(
            fits.alarmed, asset_id=record.asset_id, vehicle_class="turbine",
            window_start=record.window_start, window_end=record.window_end,
            version=record.version, baseline_version=baseline, run_id=record.run_id)
    assert len(registry.alerts(since="2026-01-08")) == 2 * exceeded
    assert registry.alerts(since="2026-01-09") == []
    graded = registry.alerts(scale=SeverityScale(1e12, 1e13))
    assert {a.severity for a in graded} == {"minor"}
    assert [a.key for a in graded] == [a.key for a in alerts]


def test_alerts_need_the_recorded_drift(rec, registry):
    record = rec.candidate(night=6, alarmed=True)
    uri = registry.backend.client.get_run(record.run_id).info.artifact_uri
    artifacts = pathlib.Path(urllib.parse.urlparse(uri).path)
    (artifacts / "drift.json").unlink()
    with pytest.raises(ArtifactError, match="drift.json"):
        registry.alerts()
