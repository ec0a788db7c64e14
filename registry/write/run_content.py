"""What a recorded fit says about itself: tags, params, metrics, ``drift.json``, description.

(A candidate's ``diagnosis.json`` and its tags are written by :mod:`graybox.alert_diagnosis`.)

Pure functions of a :class:`registry.write.submission.ResolvedFit` (no MLflow call), so every
record of a fit says the same whichever path wrote it. Each writer has its reader here:
:func:`entry_metric` / :func:`parse_entry_metric` for the per-entry metric names (for the
MLflow UI and the zeta history), :func:`drift_document` / :func:`drift_from_document` for
``drift.json`` (the structured record the alerts are read back from).
"""
from __future__ import annotations

import functools
import json
import math
import os
import pathlib
import re
import subprocess
from typing import Any

from graybox.calibration import Calibration
from graybox.drift import Drift
from graybox.operating_conditions import covered
from graybox.signature import TIER_KINDS, Signature
from registry.store import naming
from graybox.alert_diagnosis import diagnosis_document
from registry.write.submission import ResolvedFit

_KEY_UNSAFE = re.compile(r"[^A-Za-z0-9_\-. /]")
#: the metrics logged per (channel, tier): ``<kind>.<channel>.<tier>``
ENTRY_METRICS = ("zeta", "epsilon", "ratio", "healthy_zeta", "outside")
MAX_TAG_CHARACTERS = 5000   #: a tag value's length (MLflow allows 8000)


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """The code that produced a fit: ``FLEET_HEALTH_CODE_VERSION`` if set, else the package
    version plus ``git describe --always --dirty`` of the checkout when there is one.

    Computed once per process (a ``git`` subprocess costs more than a whole record).
    """
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


def _key(name: str) -> str:
    return _KEY_UNSAFE.sub("_", name)[:250]


def _flatten(prefix: str, value: Any, out: dict[str, str]) -> None:
    if isinstance(value, dict):
        for key, item in value.items():
            _flatten(f"{prefix}.{key}" if prefix else str(key), item, out)
    else:
        out[_key(prefix)] = json.dumps(value) if isinstance(value, (list, tuple)) else str(value)


def entry_metric(kind: str, channel: str, tier: str) -> str:
    """The metric name of one (channel, tier) entry, ``<kind>.<channel>.<tier>``.

    Parameters
    ----------
    kind : str
        One of :data:`ENTRY_METRICS`.
    channel, tier : str
    """
    if kind not in ENTRY_METRICS:
        raise ValueError(f"unknown entry metric {kind!r}; known: {ENTRY_METRICS}")
    return _key(f"{kind}.{channel}.{tier}")


def parse_entry_metric(name: str) -> tuple[str, str, str] | None:
    """``(kind, channel, tier)`` of a metric named by :func:`entry_metric`, else None.

    The channel is as it appears in the name (characters MLflow does not allow in a key are
    replaced by ``_``); ``drift.json`` holds the exact names. Any tier name is read, so a tier
    added through ``kinds=`` is read back like the built-in ones.
    """
    kind, _, rest = name.partition(".")
    channel, _, tier = rest.rpartition(".")
    if kind not in ENTRY_METRICS or not tier or not channel:
        return None
    return kind, channel, tier


def structure_params(signature: Signature) -> dict[str, str]:
    """The frozen structure as flat MLflow params (``channels.omega.ar_order`` = ``6``...)."""
    params: dict[str, str] = {}
    _flatten("", signature.frozen_structure(), params)
    params["n_channels"] = str(len(signature.channels))
    return params


def fit_metrics(signature: Signature, calibration: Calibration | None,
                drift: Drift | None) -> dict[str, float]:
    """Each tier's own fit figures (:meth:`graybox.tiers.base.Tier.fit_metrics`: noise
    moments, fit errors, level), the tuned white box's estimates, epsilon (and zeta, ratio,
    alarm for a drift) as metrics."""
    metrics: dict[str, float] = {"n_samples": signature.n_samples}
    for channel in signature.channels:
        for kind in TIER_KINDS:
            if kind.present(channel):
                metrics.update(kind.fit_metrics(channel))
    if signature.tuning is not None:
        # the white box tuned to the asset: each estimate with its 95 % interval
        tuning = signature.tuning
        for name, value, error, (low, high), initial in zip(
                tuning.names, tuning.values, tuning.standard_errors, tuning.interval(),
                tuning.initial):
            metrics[f"tuning.{name}"] = value
            metrics[f"tuning.{name}.standard_error"] = error
            metrics[f"tuning.{name}.low"] = low
            metrics[f"tuning.{name}.high"] = high
            metrics[f"tuning.{name}.initial"] = initial
    if calibration is not None:
        metrics["calibration.false_alarm_rate"] = calibration.false_alarm_rate
        metrics["calibration.n_windows"] = calibration.n_windows
        for entry in calibration.thresholds:
            metrics[entry_metric("epsilon", entry.channel, entry.tier)] = entry.epsilon
            metrics[entry_metric("healthy_zeta", entry.channel, entry.tier)] = entry.mean_zeta
    if drift is not None:
        for entry in drift.entries:
            metrics[entry_metric("zeta", entry.channel, entry.tier)] = entry.zeta
            if entry.epsilon is not None:
                metrics[entry_metric("epsilon", entry.channel, entry.tier)] = entry.epsilon
                metrics[entry_metric("ratio", entry.channel, entry.tier)] = entry.ratio
            if entry.outside is not None:
                metrics[entry_metric("outside", entry.channel, entry.tier)] = entry.outside
        largest = drift.largest
        if largest is not None:
            metrics["max_ratio"] = largest.ratio
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


def drift_from_document(data: dict) -> Drift:
    """The drift of a ``drift.json`` document (:func:`drift_document`), exactly as recorded
    (the added ``ratio``, ``exceeded``, ``alarmed`` and ``baseline_version`` follow from it
    or are in the run's tags)."""
    return Drift.from_dict(data)


def run_tags(fit: ResolvedFit, baseline_version: int | None) -> dict[str, str]:
    """The tags a run is created with (everything but the completion tags)."""
    s = fit.submission
    tags = {naming.TAG_ASSET_ID: s.asset_id, naming.TAG_VEHICLE_CLASS: s.vehicle_class,
            naming.TAG_WINDOW_START: fit.start, naming.TAG_WINDOW_END: fit.end,
            naming.TAG_ROLE: s.role, naming.TAG_DATA_HASH: fit.data_hash,
            naming.TAG_CODE_VERSION: code_version(), naming.TAG_FIT_KEY: fit.key}
    if s.drift is not None:
        tags[naming.TAG_ALARM] = "true" if s.drift.alarmed else "false"
    if baseline_version is not None:
        tags[naming.TAG_BASELINE_VERSION] = str(baseline_version)
    if s.reanalysis:
        tags[naming.TAG_REANALYSIS] = "true"
    if s.diagnosis is not None:
        document = diagnosis_document(s.diagnosis)
        tags[naming.TAG_DIAGNOSIS] = document["status"]
        tags[naming.TAG_LIKELY_CAUSE] = document["likely_cause"][:MAX_TAG_CHARACTERS]
    return tags


def version_tags(fit: ResolvedFit, run_id: str, model_id: str, manifest_sha: str,
                 baseline_version: int | None) -> dict[str, str]:
    """The tags of the fit's model version."""
    s = fit.submission
    tags = {naming.TAG_ASSET_ID: s.asset_id, naming.TAG_ROLE: s.role,
            naming.TAG_WINDOW_START: fit.start, naming.TAG_WINDOW_END: fit.end,
            naming.TAG_DATA_HASH: fit.data_hash, naming.TAG_FIT_KEY: fit.key,
            naming.TAG_RUN_ID: run_id, naming.TAG_MODEL_ID: model_id,
            naming.TAG_CALIBRATED: "true" if s.calibration is not None else "false",
            naming.TAG_MANIFEST_SHA256: manifest_sha, naming.TAG_CODE_VERSION: code_version()}
    if s.drift is not None:
        tags[naming.TAG_ALARM] = "true" if s.drift.alarmed else "false"
    if baseline_version is not None:
        tags[naming.TAG_BASELINE_VERSION] = str(baseline_version)
    return tags


def describe(fit: ResolvedFit, baseline_version: int | None) -> str:
    """The version description shown in the MLflow UI."""
    s = fit.submission
    text = f"{s.role.capitalize()} fit of {s.asset_id} over {fit.start} .. {fit.end}."
    if s.calibration is not None:
        text += (f" Calibrated on {s.calibration.n_windows} healthy windows at a false-alarm "
                 f"rate of {s.calibration.false_alarm_rate:g} per window.")
    ranges = covered(s.signature.conditions) if s.drift is None else ()
    if ranges:
        text += (f" Its days' conditions, which its nights are judged against (a night beyond "
                 f"them by extrapolation): {'; '.join(ranges)}.")
    if s.drift is not None:
        worst = max(s.drift.entries, key=lambda e: -1 if e.ratio is None else e.ratio)
        text += f" Compared with baseline version {baseline_version}:"
        text += " ALARM" if s.drift.alarmed else " no alarm"
        if worst.ratio is not None:
            text += f" (largest zeta/epsilon {worst.ratio:.2f}, {worst.channel} {worst.tier} tier)."
        beyond = s.drift.discounted
        if beyond:
            text += (" Outside the baseline's operating range, changes discounted: "
                     + "; ".join(f"{', '.join(tiers)} x{value:.1f}"
                                 for value, tiers in beyond.items())
                     + (f"; farthest: {s.drift.conditions}" if s.drift.conditions else "")
                     + " (a longer or more varied baseline covers it).")
    return text
