"""Recording fits: one MLflow run and one registered model version per (asset, window) fit.

A recorded fit is

* a **run** in the vehicle class's experiment, tagged with asset id, window start/end, role,
  data hash, code version and the idempotence key; its params hold the frozen structure, its
  metrics the noise moments, fit errors and (when known) zeta, epsilon and their ratio per
  tier and channel; its artifacts the signature bundle (``signature/``: JSON, safetensors,
  manifest), ``drift.json`` for a candidate and PNG plots (``plots/``);
* a **logged model** (pyfunc, loader module :mod:`registry.pyfunc`, no pickle) built from the
  same bundle;
* a **model version** of the asset's registered model, which takes the ``candidate`` alias.

Recording is idempotent on ``(asset_id, window_start, window_end, role, data_hash)``: the key
is a tag on the run and on the version, found with one filtered search (no scan), and a
second recording returns the first one. A recording interrupted half-way is finished or
replaced on the next attempt: an incomplete run (no ``fleet_health.complete`` tag) is
deleted and logged again; a complete run without a version gets its version.

A **reanalysis** (``reanalysis=True``) records only the run, tagged ``fleet_health.reanalysis``:
no logged model, no model version, no alias move (and the flows move no watermark). Its key
also names the baseline version it was compared with, so reanalysing a window against
another version is another record, and the same reanalysis twice is one. The zeta history
and the alerts leave reanalysis runs out.

Also here: the asset's zeta history and the recorded alerts, both found by tag-filtered
searches.
"""
from __future__ import annotations

import functools
import hashlib
import json
import logging
import math
import os
import pathlib
import re
import subprocess
import tempfile
from typing import Any, Iterable

import numpy as np
import pandas as pd
from mlflow.entities import LoggedModelOutput, LoggedModelStatus, Metric, Param
from mlflow.models import Model

from graybox.calibration import Calibration
from graybox.decompose import decompose
from graybox.drift import Drift
from graybox.models import load_model
from graybox.signature import TIERS, Signature
from registry import naming
from registry.artifacts import DRIFT_FILE, write_bundle
from registry.backend import Backend
from registry.entities import FitRecord

logger = logging.getLogger(__name__)

BUNDLE_DIR = "signature"          # run artifact dir, and the pyfunc data dir's name
MODEL_NAME = "pyfunc-model"       # logged model name (must differ from run artifact dirs)
LOADER_MODULE = "registry.pyfunc"
_KEY_UNSAFE = re.compile(r"[^A-Za-z0-9_\-. /]")
_BATCH = 100
TREND_NIGHTS = 90                 # nights shown in the zeta trend plot


# -- small helpers ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """The code that produced a fit: ``FLEET_HEALTH_CODE_VERSION`` if set, else the package
    version plus ``git describe --always --dirty`` of the checkout when there is one."""
    override = os.environ.get("FLEET_HEALTH_CODE_VERSION")
    if override:
        return override
    try:
        from importlib.metadata import version

        package = version("fleet-health")
    except Exception:
        package = "unknown"
    root = pathlib.Path(__file__).resolve().parent.parent
    try:
        described = subprocess.run(["git", "-C", str(root), "describe", "--always", "--dirty",
                                    "--abbrev=12"], capture_output=True, text=True, timeout=5)
        if described.returncode == 0 and described.stdout.strip():
            return f"{package}+git.{described.stdout.strip()}"
    except (OSError, subprocess.SubprocessError):
        pass
    return package


def _frames(window) -> list[pd.DataFrame]:
    if window is None:
        return []
    if isinstance(window, pd.DataFrame) or hasattr(window, "frame"):
        window = [window]
    return [getattr(w, "frame", w) for w in window]


def data_hash(window) -> str:
    """sha256 of telemetry (a TelemetryWindow, DataFrame or a sequence of them).

    Covers column names, timestamps (as UTC nanoseconds) and values (float64), so the same
    data hashes the same whatever its index resolution.
    """
    digest = hashlib.sha256()
    for frame in _frames(window):
        digest.update(json.dumps([str(c) for c in frame.columns]).encode())
        index = frame.index
        if isinstance(index, pd.DatetimeIndex):
            index = index.tz_localize("UTC") if index.tz is None else index.tz_convert("UTC")
            digest.update(np.ascontiguousarray(index.as_unit("ns").asi8).tobytes())
        else:
            digest.update(np.ascontiguousarray(np.asarray(index, dtype=np.int64)).tobytes())
        digest.update(np.ascontiguousarray(frame.to_numpy(dtype=np.float64)).tobytes())
    return digest.hexdigest()


def _key(name: str) -> str:
    return _KEY_UNSAFE.sub("_", name)[:250]


def _flatten(prefix: str, value: Any, out: dict[str, str]) -> None:
    if isinstance(value, dict):
        for key, item in value.items():
            _flatten(f"{prefix}.{key}" if prefix else str(key), item, out)
    else:
        out[_key(prefix)] = json.dumps(value) if isinstance(value, (list, tuple)) else str(value)


def structure_params(signature: Signature) -> dict[str, str]:
    """The frozen structure as flat MLflow params (``channels.omega.ar_order`` = ``6``...)."""
    params: dict[str, str] = {}
    _flatten("", signature.frozen_structure(), params)
    params["n_channels"] = str(len(signature.channels))
    return params


def fit_metrics(signature: Signature, calibration: Calibration | None,
                drift: Drift | None) -> dict[str, float]:
    """Noise moments, fit errors, epsilon (and zeta, ratio, alarm for a drift) as metrics."""
    metrics: dict[str, float] = {"n_samples": signature.n_samples}
    for channel in signature.channels:
        c = channel.channel
        metrics[f"fit.{c}.ar_innovation_variance"] = channel.linear.innovation_variance
        metrics[f"fit.{c}.nn_train_mse"] = channel.nonlinear.train_mse
        metrics[f"fit.{c}.nn_iterations"] = channel.nonlinear.iterations
        if channel.nonlinear.heldout_gain is not None:
            metrics[f"fit.{c}.nn_heldout_gain"] = channel.nonlinear.heldout_gain
        noise = channel.noise
        for name in ("mean", "variance", "skewness", "excess_kurtosis", "ljung_box_statistic",
                     "ljung_box_pvalue"):
            metrics[f"noise.{c}.{name}"] = getattr(noise, name)
    if calibration is not None:
        metrics["calibration.false_alarm_rate"] = calibration.false_alarm_rate
        metrics["calibration.n_windows"] = calibration.n_windows
        for entry in calibration.thresholds:
            metrics[f"epsilon.{entry.channel}.{entry.tier}"] = entry.epsilon
            metrics[f"healthy_zeta.{entry.channel}.{entry.tier}"] = entry.mean_zeta
    if drift is not None:
        ratios = []
        for entry in drift.entries:
            metrics[f"zeta.{entry.channel}.{entry.tier}"] = entry.zeta
            if entry.epsilon is not None:
                metrics[f"epsilon.{entry.channel}.{entry.tier}"] = entry.epsilon
                metrics[f"ratio.{entry.channel}.{entry.tier}"] = entry.ratio
                ratios.append(entry.ratio)
        if ratios:
            metrics["max_ratio"] = max(ratios)
        metrics["alarm"] = float(drift.alarmed)
    return {_key(k): float(v) for k, v in metrics.items()
            if v is not None and math.isfinite(float(v))}


def drift_document(drift: Drift, baseline_version: int | None) -> dict:
    """``drift.json``: every entry with zeta, epsilon, ratio, alarm and its top changes."""
    data = drift.to_dict()
    for entry, source in zip(data["entries"], drift.entries):
        entry["ratio"] = None if source.ratio is None or not math.isfinite(source.ratio) else source.ratio
        entry["exceeded"] = source.exceeded
    data["alarmed"] = drift.alarmed
    data["baseline_version"] = baseline_version
    return data


# -- recording -------------------------------------------------------------------------------

def record_fit(backend: Backend, asset_id: str, vehicle_class: str, signature: Signature, *,
               role: str, calibration: Calibration | None = None, drift: Drift | None = None,
               window=None, data_hash_: str | None = None, window_start=None, window_end=None,
               baseline_version: int | None = None, plots: bool = True,
               reanalysis: bool = False) -> FitRecord:
    """Record one fit (see :meth:`registry.Registry.record_fit` for the parameters)."""
    name = naming.model_name(asset_id)
    naming.validate_vehicle_class(vehicle_class)
    if role not in naming.ROLES:
        raise ValueError(f"role must be one of {naming.ROLES}, got {role!r}")
    if role == naming.BASELINE and drift is not None:
        raise ValueError("a baseline fit has no drift; record drifts with role='candidate'")
    if role == naming.CANDIDATE and calibration is not None:
        raise ValueError("a candidate fit carries no calibration; record the calibration with "
                         "the baseline fit it belongs to (role='baseline')")
    if signature.asset_id not in (None, asset_id):
        raise ValueError(f"the signature was fitted for asset {signature.asset_id!r}, "
                         f"not {asset_id!r}")
    start = window_start if window_start is not None else signature.window_start
    end = window_end if window_end is not None else signature.window_end
    if start is None or end is None:
        raise ValueError("window start and end are unknown: pass window_start and window_end "
                         "(the signature does not carry them)")
    start, end = naming.iso_utc(start), naming.iso_utc(end)
    if not pd.Timestamp(start) < pd.Timestamp(end):
        raise ValueError(f"window start {start} is not before its end {end}")
    if data_hash_ is None:
        data_hash_ = data_hash(window) if window is not None else \
            hashlib.sha256(signature.to_json().encode()).hexdigest()
    if reanalysis:
        if role != naming.CANDIDATE:
            raise ValueError("a reanalysis records a candidate fit (role='candidate')")
        return _record_reanalysis(backend, asset_id, vehicle_class, signature, drift, window,
                                  data_hash_, start, end, baseline_version, plots)
    key = naming.fit_key(asset_id, start, end, role, data_hash_)
    client = backend.client

    with backend.store.asset_lock(asset_id):
        experiment_id = backend.experiment_id(vehicle_class, create=True)
        model = backend.ensure_registered_model(asset_id, vehicle_class, experiment_id)
        existing = _find_version(backend, name, key)
        if existing is not None:
            _repair_candidate_alias(backend, name, model, int(existing.version))
            tags = existing.tags or {}
            return FitRecord(asset_id, vehicle_class, role, int(existing.version),
                             existing.run_id, tags.get(naming.TAG_MODEL_ID, ""), key, start, end,
                             data_hash_, created=False,
                             alarm=None if naming.TAG_ALARM not in tags else tags[naming.TAG_ALARM] == "true")
        if drift is not None and baseline_version is None:
            baseline_version = (model.aliases or {}).get(naming.BASELINE)
        run = _find_complete_run(backend, experiment_id, key)
        if run is None:
            run_id, model_id, manifest_sha = _log_run(
                backend, experiment_id, asset_id, vehicle_class, signature, role, calibration,
                drift, window, data_hash_, start, end, key, baseline_version, plots)
        else:
            run_id = run.info.run_id
            model_id = run.data.tags[naming.TAG_MODEL_ID]
            manifest_sha = run.data.tags[naming.TAG_MANIFEST_SHA256]
            recorded = run.data.tags.get(naming.TAG_BASELINE_VERSION)
            baseline_version = int(recorded) if recorded else baseline_version
            logger.info("asset %s: completing the registration of run %s", asset_id, run_id)
        source = client.get_logged_model(model_id).artifact_location
        alarm = None if drift is None else drift.alarmed
        tags = {naming.TAG_ASSET_ID: asset_id, naming.TAG_ROLE: role,
                naming.TAG_WINDOW_START: start, naming.TAG_WINDOW_END: end,
                naming.TAG_DATA_HASH: data_hash_, naming.TAG_FIT_KEY: key,
                naming.TAG_RUN_ID: run_id, naming.TAG_MODEL_ID: model_id,
                naming.TAG_CALIBRATED: "true" if calibration is not None else "false",
                naming.TAG_MANIFEST_SHA256: manifest_sha, naming.TAG_CODE_VERSION: code_version()}
        if alarm is not None:
            tags[naming.TAG_ALARM] = "true" if alarm else "false"
        if baseline_version is not None:
            tags[naming.TAG_BASELINE_VERSION] = str(baseline_version)
        version = client.create_model_version(
            name, source=source, run_id=run_id, model_id=model_id, tags=tags,
            description=_describe(asset_id, role, start, end, calibration, drift, baseline_version))
        client.set_registered_model_alias(name, naming.CANDIDATE, str(version.version))
        return FitRecord(asset_id, vehicle_class, role, int(version.version), run_id, model_id,
                         key, start, end, data_hash_, created=True, alarm=alarm)


def _record_reanalysis(backend: Backend, asset_id, vehicle_class, signature, drift, window,
                       data_hash_, start, end, baseline_version, plots) -> FitRecord:
    """A reanalysis run: no logged model, no version, no alias; idempotent on its key."""
    if baseline_version is None:
        raise ValueError("a reanalysis names the version it was compared with "
                         "(baseline_version)")
    key = naming.fit_key(asset_id, start, end, naming.CANDIDATE, data_hash_,
                         variant=f"reanalysis:v{int(baseline_version)}")
    with backend.store.asset_lock(asset_id):
        experiment_id = backend.experiment_id(vehicle_class, create=True)
        backend.ensure_registered_model(asset_id, vehicle_class, experiment_id)
        run = _find_complete_run(backend, experiment_id, key)
        created = run is None
        if created:
            run_id, _, _ = _log_run(backend, experiment_id, asset_id, vehicle_class, signature,
                                    naming.CANDIDATE, None, drift, window, data_hash_, start, end,
                                    key, baseline_version, plots, reanalysis=True)
        else:
            run_id = run.info.run_id
    alarm = None if drift is None else drift.alarmed
    return FitRecord(asset_id, vehicle_class, naming.CANDIDATE, None, run_id, "", key, start,
                     end, data_hash_, created=created, alarm=alarm)


def _describe(asset_id, role, start, end, calibration, drift, baseline_version) -> str:
    text = f"{role.capitalize()} fit of {asset_id} over {start} .. {end}."
    if calibration is not None:
        text += (f" Calibrated on {calibration.n_windows} healthy windows at a false-alarm rate "
                 f"of {calibration.false_alarm_rate:g} per window.")
    if drift is not None:
        worst = max(drift.entries, key=lambda e: -1 if e.ratio is None else e.ratio)
        text += f" Compared with baseline version {baseline_version}:"
        text += " ALARM" if drift.alarmed else " no alarm"
        if worst.ratio is not None:
            text += f" (largest zeta/epsilon {worst.ratio:.2f}, {worst.channel} {worst.tier} tier)."
    return text


def _find_version(backend: Backend, name: str, key: str):
    versions = backend.client.search_model_versions(
        f"name = {naming.quote(name)} and tags.`{naming.TAG_FIT_KEY}` = {naming.quote(key)}",
        max_results=10)
    return min(versions, key=lambda v: int(v.version)) if versions else None


def _repair_candidate_alias(backend: Backend, name: str, model, version: int) -> None:
    """A recording interrupted after its version was created but before the alias moved."""
    current = (model.aliases or {}).get(naming.CANDIDATE)
    if current is None or int(current) < version:
        mv = backend.client.get_model_version(name, str(version))
        if (mv.tags or {}).get(naming.TAG_REJECTED) != "true":
            backend.client.set_registered_model_alias(name, naming.CANDIDATE, str(version))


def _find_complete_run(backend: Backend, experiment_id: str, key: str):
    runs = backend.client.search_runs(
        [experiment_id], f"tags.`{naming.TAG_FIT_KEY}` = {naming.quote(key)}", max_results=10)
    complete = None
    for run in runs:
        if run.data.tags.get(naming.TAG_COMPLETE) == "true" and complete is None:
            complete = run
        elif run.data.tags.get(naming.TAG_COMPLETE) != "true":
            logger.warning("deleting incomplete run %s of an interrupted recording",
                           run.info.run_id)
            backend.client.delete_run(run.info.run_id)
    return complete


def _log_run(backend: Backend, experiment_id, asset_id, vehicle_class, signature, role,
             calibration, drift, window, data_hash_, start, end, key, baseline_version,
             plots, reanalysis: bool = False) -> tuple[str, str, str]:
    client = backend.client
    tags = {naming.TAG_ASSET_ID: asset_id, naming.TAG_VEHICLE_CLASS: vehicle_class,
            naming.TAG_WINDOW_START: start, naming.TAG_WINDOW_END: end, naming.TAG_ROLE: role,
            naming.TAG_DATA_HASH: data_hash_, naming.TAG_CODE_VERSION: code_version(),
            naming.TAG_FIT_KEY: key}
    if drift is not None:
        tags[naming.TAG_ALARM] = "true" if drift.alarmed else "false"
    if baseline_version is not None:
        tags[naming.TAG_BASELINE_VERSION] = str(baseline_version)
    if reanalysis:
        tags[naming.TAG_REANALYSIS] = "true"
    kind = "reanalysis" if reanalysis else role
    run_name = f"{asset_id} {kind} {start[:16]} .. {end[:16]}"
    run = client.create_run(experiment_id, tags=tags, run_name=run_name)
    run_id = run.info.run_id
    try:
        params = structure_params(signature)
        metrics = fit_metrics(signature, calibration, drift)
        _log_batched(backend, run_id, params, metrics)
        with tempfile.TemporaryDirectory(prefix="fleet-health-") as scratch:
            scratch = pathlib.Path(scratch)
            bundle = scratch / BUNDLE_DIR
            manifest_sha = write_bundle(bundle, signature, calibration, asset_id)
            client.log_artifacts(run_id, str(bundle), BUNDLE_DIR)
            if drift is not None:
                (scratch / DRIFT_FILE).write_text(json.dumps(drift_document(drift, baseline_version),
                                                             indent=2))
                client.log_artifact(run_id, str(scratch / DRIFT_FILE))
            if plots:
                _log_plots(backend, run_id, asset_id, role, signature, drift, window, end,
                           scratch / "plots")
            model_id = "" if reanalysis else _log_model(backend, experiment_id, run_id,
                                                        asset_id, bundle, scratch / "model")
        if model_id:
            client.set_tag(run_id, naming.TAG_MODEL_ID, model_id)
        client.set_tag(run_id, naming.TAG_MANIFEST_SHA256, manifest_sha)
        client.set_tag(run_id, naming.TAG_COMPLETE, "true")
        client.set_terminated(run_id, "FINISHED")
    except BaseException:
        try:
            client.set_terminated(run_id, "FAILED")
        except Exception:  # keep the original error
            logger.exception("could not mark run %s as failed", run_id)
        raise
    return run_id, model_id, manifest_sha


def _log_batched(backend: Backend, run_id: str, params: dict[str, str],
                 metrics: dict[str, float]) -> None:
    now = int(pd.Timestamp.now(tz="UTC").timestamp() * 1000)
    param_items = [Param(k, v[:6000]) for k, v in sorted(params.items())]
    metric_items = [Metric(k, v, now, 0) for k, v in sorted(metrics.items())]
    for i in range(0, len(param_items), _BATCH):
        backend.client.log_batch(run_id, params=param_items[i:i + _BATCH])
    for i in range(0, len(metric_items), 1000):
        backend.client.log_batch(run_id, metrics=metric_items[i:i + 1000])


def _pip_requirements() -> list[str]:
    try:
        from importlib.metadata import version

        return [f"fleet-health=={version('fleet-health')}"]
    except Exception:
        return ["fleet-health"]


def _log_model(backend: Backend, experiment_id: str, run_id: str, asset_id: str,
               bundle: pathlib.Path, path: pathlib.Path) -> str:
    """Log the bundle as a pyfunc (loader-module form) LoggedModel linked to the run.

    The steps of ``mlflow.pyfunc.log_model`` done with our own client, so that no global
    tracking URI or active run is needed (and threads recording to different stores cannot
    mix them up).
    """
    import mlflow.pyfunc

    client = backend.client
    logged = client.create_logged_model(
        experiment_id, name=MODEL_NAME, source_run_id=run_id,
        tags={naming.TAG_ASSET_ID: asset_id}, model_type="fleet-health-signature")
    try:
        description = Model(artifact_path=logged.artifact_location, model_uuid=logged.model_id,
                            run_id=run_id, model_id=logged.model_id)
        mlflow.pyfunc.save_model(str(path), loader_module=LOADER_MODULE, data_path=str(bundle),
                                 mlflow_model=description, pip_requirements=_pip_requirements())
        client.log_model_artifacts(logged.model_id, str(path))
        client.finalize_logged_model(logged.model_id, LoggedModelStatus.READY)
        client.log_outputs(run_id, [LoggedModelOutput(logged.model_id, step=0)])
    except BaseException:
        try:
            client.finalize_logged_model(logged.model_id, LoggedModelStatus.FAILED)
        except Exception:
            logger.exception("could not mark logged model %s as failed", logged.model_id)
        raise
    return logged.model_id


def _log_plots(backend: Backend, run_id: str, asset_id: str, role: str, signature: Signature,
               drift: Drift | None, window, end: str, directory: pathlib.Path) -> None:
    from registry import plots as figures

    directory.mkdir(parents=True, exist_ok=True)
    frames = _frames(window)
    try:
        if frames:
            spec = signature.model
            white_box = load_model(spec["spec"], spec.get("parameters"), spec.get("columns"))
            last = window[-1] if isinstance(window, (list, tuple)) else window
            parts = decompose(signature, white_box, last)
            when = f"{frames[-1].index[0]:%Y-%m-%d %H:%M} .. {frames[-1].index[-1]:%Y-%m-%d %H:%M}"
            figures.residual_figure(parts, f"{asset_id} {role}: residual, {when}").savefig(
                directory / "residual_acf.png")
            figures.tier_fit_figure(parts, signature, f"{asset_id} {role}: tier fits, {when}") \
                .savefig(directory / "tier_fits.png")
        if drift is not None:
            history = zeta_history(backend, asset_id, last=TREND_NIGHTS)
            current = pd.DataFrame([{"window_end": end, "channel": e.channel,
                                     "tier": e.tier, "zeta": e.zeta,
                                     "epsilon": np.nan if e.epsilon is None else e.epsilon}
                                    for e in drift.entries])
            if len(history):
                history = history[history["window_end"] != end]
            history = pd.concat([history[list(current.columns)], current], ignore_index=True) \
                if len(history) else current
            figures.zeta_trend_figure(history, f"{asset_id}: zeta per tier over the nights "
                                               f"(epsilon dashed)").savefig(
                directory / "zeta_trend.png")
    except Exception:
        # a plot is never worth losing the record of a fit
        logger.exception("asset %s: could not draw the plots of this fit", asset_id)
    if any(directory.iterdir()):
        backend.client.log_artifacts(run_id, str(directory), "plots")


# -- queries ---------------------------------------------------------------------------------

HISTORY_COLUMNS = ("window_start", "window_end", "channel", "tier", "zeta", "epsilon", "ratio",
                   "exceeded", "run_id", "baseline_version")


def _asset_runs(backend: Backend, experiment_ids: list[str], filters: Iterable[str],
                last: int | None = None) -> list:
    """Complete runs matching ``filters``, one per (asset, window) (the last recorded), by
    window end; only the ``last`` latest windows when given (one page, newest first)."""
    clause = " and ".join([f"tags.`{naming.TAG_COMPLETE}` = 'true'", *filters])
    if last is None:
        runs = list(backend.paged(backend.client.search_runs, experiment_ids, clause))
    else:
        runs = list(backend.client.search_runs(
            experiment_ids, clause, max_results=2 * last,
            order_by=[f"tags.`{naming.TAG_WINDOW_END}` DESC", "attributes.start_time DESC"]))
    latest: dict[tuple, Any] = {}
    for run in runs:
        tags = run.data.tags
        if tags.get(naming.TAG_REANALYSIS) == "true":
            continue  # ad-hoc reanalyses are not part of the nightly record
        key = (tags.get(naming.TAG_ASSET_ID), tags.get(naming.TAG_WINDOW_START),
               tags.get(naming.TAG_WINDOW_END))
        if key not in latest or run.info.start_time > latest[key].info.start_time:
            latest[key] = run
    ordered = sorted(latest.values(), key=lambda r: (r.data.tags.get(naming.TAG_WINDOW_END, ""),
                                                     r.data.tags.get(naming.TAG_ASSET_ID, "")))
    return ordered if last is None else ordered[-last:]


def zeta_history(backend: Backend, asset_id: str, last: int | None = None) -> pd.DataFrame:
    """The asset's candidate zetas, one row per (window, channel, tier), oldest first.

    Parameters
    ----------
    last : int, optional
        Only the ``last`` most recent windows (one bounded query; the trend plot uses this).
    """
    model = backend.registered_model(asset_id)
    experiment_id = None if model is None else (model.tags or {}).get(naming.TAG_EXPERIMENT_ID)
    if experiment_id is None:
        return pd.DataFrame(columns=list(HISTORY_COLUMNS))
    runs = _asset_runs(backend, [experiment_id], [
        f"tags.`{naming.TAG_ASSET_ID}` = {naming.quote(asset_id)}",
        f"tags.`{naming.TAG_ROLE}` = '{naming.CANDIDATE}'"], last=last)
    rows = []
    for run in runs:
        metrics, tags = run.data.metrics, run.data.tags
        for metric, zeta in metrics.items():
            if not metric.startswith("zeta."):
                continue
            channel, tier = metric[len("zeta."):].rsplit(".", 1)
            epsilon = metrics.get(f"epsilon.{channel}.{tier}", np.nan)
            rows.append({"window_start": tags.get(naming.TAG_WINDOW_START),
                         "window_end": tags.get(naming.TAG_WINDOW_END), "channel": channel,
                         "tier": tier, "zeta": zeta, "epsilon": epsilon,
                         "ratio": metrics.get(f"ratio.{channel}.{tier}", np.nan),
                         "exceeded": bool(np.isfinite(epsilon) and zeta > epsilon),
                         "run_id": run.info.run_id,
                         "baseline_version": tags.get(naming.TAG_BASELINE_VERSION)})
    frame = pd.DataFrame(rows, columns=list(HISTORY_COLUMNS))
    order = {tier: i for i, tier in enumerate(TIERS)}
    if len(frame):
        frame = frame.assign(_t=frame["tier"].map(order)).sort_values(
            ["window_end", "channel", "_t"]).drop(columns="_t").reset_index(drop=True)
    return frame


def alerts(backend: Backend, since=None) -> list[dict]:
    """Recorded alarms (candidate runs with any zeta above epsilon), oldest window first."""
    experiment_ids = backend.experiment_ids()
    if not experiment_ids:
        return []
    since = None if since is None else naming.iso_utc(since)
    out = []
    for run in _asset_runs(backend, experiment_ids, [f"tags.`{naming.TAG_ALARM}` = 'true'"]):
        tags, metrics = run.data.tags, run.data.metrics
        if since is not None and pd.Timestamp(tags[naming.TAG_WINDOW_END]) < pd.Timestamp(since):
            continue
        exceeded = []
        for metric, zeta in metrics.items():
            if not metric.startswith("zeta."):
                continue
            channel, tier = metric[len("zeta."):].rsplit(".", 1)
            epsilon = metrics.get(f"epsilon.{channel}.{tier}")
            if epsilon is not None and zeta > epsilon:
                exceeded.append({"channel": channel, "tier": tier, "zeta": zeta,
                                 "epsilon": epsilon,
                                 "ratio": metrics.get(f"ratio.{channel}.{tier}")})
        exceeded.sort(key=lambda e: -(e["ratio"] or 0))
        baseline = tags.get(naming.TAG_BASELINE_VERSION)
        out.append({"asset_id": tags.get(naming.TAG_ASSET_ID),
                    "vehicle_class": tags.get(naming.TAG_VEHICLE_CLASS),
                    "window_start": tags.get(naming.TAG_WINDOW_START),
                    "window_end": tags.get(naming.TAG_WINDOW_END),
                    "baseline_version": int(baseline) if baseline else None,
                    "run_id": run.info.run_id, "max_ratio": metrics.get("max_ratio"),
                    "exceeded": exceeded})
    return out
