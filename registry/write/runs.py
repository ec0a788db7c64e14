"""Logging one fit as an MLflow run, in as few round trips as the record allows.

1. ``create_run`` with every tag but the completion tags;
2. one ``log_artifacts`` of a scratch directory holding the signature bundle
   (``signature/``), ``drift.json``, an alarmed candidate's ``diagnosis.json``, a
   candidate's pyfunc model (``model/``) and the plots (with a fresh diagnosis,
   ``plots/diagnosis.png``);
   a baseline's logged model is logged after it (:func:`registry.write.model_files.log_logged_model`);
3. one ``log_batch`` of params, metrics and, last, the tags ``manifest_sha256``,
   ``model_id`` and ``complete=true`` (MLflow writes a batch's tags after its params and
   metrics, so a run tagged complete holds everything);
4. ``set_terminated``.

(The client path: baselines, and every fit behind an ``mlflow server``. A candidate on an
SQLAlchemy store is written in one transaction instead: :mod:`registry.write.at_once`, with
the same :func:`write_artifacts`.)

A run without ``fleet_health.complete`` is an interrupted recording: the next attempt deletes
it and logs the fit again (:mod:`registry.write.recording`).
"""
from __future__ import annotations

import json
import logging
import pathlib
import tempfile
from dataclasses import dataclass

import numpy as np
import pandas as pd
from mlflow.entities import Metric, Param, RunTag

from graybox.decompose import decompose
from graybox.diagnosis import Diagnosis
from registry.store import naming
from graybox.alert_diagnosis import diagnosis_document
from registry.write.artifacts import DIAGNOSIS_FILE, DRIFT_FILE, write_bundle
from registry.store.backend import Backend
from registry.read.history import zeta_history
from registry.write.model_files import (BUNDLE_DIR, MODEL_DIR, PyfuncTemplate, log_logged_model,
                                  model_source)
from registry.write.run_content import drift_document, fit_metrics, run_tags, structure_params
from registry.write.submission import ResolvedFit, frames

logger = logging.getLogger(__name__)

TREND_NIGHTS = 90                 # nights shown in the zeta trend plot
DIAGNOSIS_PLOT = "diagnosis.png"  # under plots/: the residual and the best hypotheses' fits
MAX_PARAMS_AND_TAGS = 100         # MLflow's log_batch limits
MAX_ENTITIES = 1000


@dataclass(frozen=True)
class LoggedRun:
    """A complete run: its id, logged model id (empty for candidates and reanalyses), the
    manifest digest of its bundle and the source its version points at."""

    run_id: str
    model_id: str
    manifest_sha256: str
    source: str


def log_run(backend: Backend, experiment_id: str, fit: ResolvedFit,
            baseline_version: int | None, template: PyfuncTemplate) -> LoggedRun:
    """Log ``fit`` as a complete, finished run (see the module docstring)."""
    client = backend.client
    s = fit.submission
    run = client.create_run(experiment_id, tags=run_tags(fit, baseline_version),
                            run_name=fit.run_name)
    run_id = run.info.run_id
    try:
        with tempfile.TemporaryDirectory(prefix="fleet-health-") as scratch:
            root = pathlib.Path(scratch) / "artifacts"
            manifest_sha = write_artifacts(backend, fit, baseline_version, template, root,
                                           run_id)
            backend.log_artifacts(run.info.artifact_uri, str(root))
            model_id = ""
            if s.role == naming.BASELINE:
                model_id = log_logged_model(backend, experiment_id, run_id, s.asset_id,
                                            root / BUNDLE_DIR,
                                            pathlib.Path(scratch) / "logged-model")
        tags = {naming.TAG_MANIFEST_SHA256: manifest_sha}
        if model_id:
            tags[naming.TAG_MODEL_ID] = model_id
        tags[naming.TAG_COMPLETE] = "true"
        _log_batched(backend, run_id, structure_params(s.signature),
                     fit_metrics(s.signature, s.calibration, s.drift), tags)
        client.set_terminated(run_id, "FINISHED")
    except BaseException:
        try:
            client.set_terminated(run_id, "FAILED")
        except Exception:  # keep the original error
            logger.exception("could not mark run %s as failed", run_id)
        raise
    source = "" if s.reanalysis else model_source(backend, run, model_id)
    return LoggedRun(run_id, model_id, manifest_sha, source)


def write_artifacts(backend: Backend, fit: ResolvedFit, baseline_version: int | None,
                    template: PyfuncTemplate, root: pathlib.Path, run_id: str) -> str:
    """Write a run's artifacts into ``root`` (created): the bundle, ``drift.json``,
    ``diagnosis.json``, a candidate's pyfunc model and the plots; returns the bundle's
    manifest digest."""
    s = fit.submission
    bundle = root / BUNDLE_DIR
    manifest_sha = write_bundle(bundle, s.signature, s.calibration, s.asset_id)
    if s.drift is not None:
        (root / DRIFT_FILE).write_text(
            json.dumps(drift_document(s.drift, baseline_version), indent=2))
    if s.diagnosis is not None:
        (root / DIAGNOSIS_FILE).write_text(
            json.dumps(diagnosis_document(s.diagnosis), indent=2))
    if s.role == naming.CANDIDATE and not s.reanalysis:
        template.write(root / MODEL_DIR, bundle, run_id)
    if s.plots:
        _draw_plots(backend, fit, root / "plots")
    return manifest_sha


def _log_batched(backend: Backend, run_id: str, params: dict[str, str],
                 metrics: dict[str, float], tags: dict[str, str]) -> None:
    """One ``log_batch`` when MLflow's limits allow (they do for the signatures we know),
    more otherwise; the tags always go in the last one."""
    now = int(pd.Timestamp.now(tz="UTC").timestamp() * 1000)
    param_items = [Param(k, v[:6000]) for k, v in sorted(params.items())]
    metric_items = [Metric(k, v, now, 0) for k, v in sorted(metrics.items())]
    tag_items = [RunTag(k, v) for k, v in tags.items()]
    while (len(param_items) + len(tag_items) > MAX_PARAMS_AND_TAGS
           or len(param_items) + len(tag_items) + len(metric_items) > MAX_ENTITIES):
        params_now, param_items = param_items[:MAX_PARAMS_AND_TAGS], param_items[MAX_PARAMS_AND_TAGS:]
        room = MAX_ENTITIES - len(params_now)
        metrics_now, metric_items = metric_items[:room], metric_items[room:]
        backend.client.log_batch(run_id, params=params_now, metrics=metrics_now)
    backend.client.log_batch(run_id, params=param_items, metrics=metric_items, tags=tag_items)


def _draw_plots(backend: Backend, fit: ResolvedFit, directory: pathlib.Path) -> None:
    """Residual/ACF and tier fits of the last window, a drift's zeta trend and a fresh
    diagnosis' fits, as PNGs."""
    from registry.write import plots as figures

    s = fit.submission
    directory.mkdir(parents=True, exist_ok=True)
    window = s.window
    found = frames(window)
    try:
        if found:
            white_box = s.signature.model.load()
            last = window[-1] if isinstance(window, (list, tuple)) else window
            parts = decompose(s.signature, white_box, last)
            when = f"{found[-1].index[0]:%Y-%m-%d %H:%M} .. {found[-1].index[-1]:%Y-%m-%d %H:%M}"
            figures.residual_figure(parts, f"{s.asset_id} {s.role}: residual, {when}").savefig(
                directory / "residual_acf.png")
            figures.tier_fit_figure(parts, s.signature, f"{s.asset_id} {s.role}: tier fits, "
                                                        f"{when}").savefig(
                directory / "tier_fits.png")
        if s.drift is not None:
            history = zeta_history(backend, s.asset_id, last=TREND_NIGHTS)
            current = pd.DataFrame([{"window_end": fit.end, "channel": e.channel,
                                     "tier": e.tier, "zeta": e.zeta,
                                     "epsilon": np.nan if e.epsilon is None else e.epsilon}
                                    for e in s.drift.entries])
            if len(history):
                history = history[history["window_end"] != fit.end]
            history = pd.concat([history[list(current.columns)], current], ignore_index=True) \
                if len(history) else current
            figures.zeta_trend_figure(history, f"{s.asset_id}: zeta per tier over the nights "
                                               f"(epsilon dashed)").savefig(
                directory / "zeta_trend.png")
    except Exception:
        # a plot is never worth losing the record of a fit
        logger.exception("asset %s: could not draw the plots of this fit", s.asset_id)
    # only a diagnosis made in this process holds its fits (one read back or failed does not)
    if isinstance(s.diagnosis, Diagnosis) and s.diagnosis.evidence is not None:
        try:
            figures.diagnosis_figure(s.diagnosis, f"{s.asset_id} {fit.start[:16]} .. "
                                                  f"{fit.end[:16]}").savefig(
                directory / DIAGNOSIS_PLOT)
        except Exception:
            logger.exception("asset %s: could not draw the diagnosis of this fit", s.asset_id)
    if not any(directory.iterdir()):
        directory.rmdir()
