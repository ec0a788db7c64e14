"""MLflow names and tag keys (docs/design.md section 3.5, "MLflow naming").

* one experiment per vehicle class: ``fleet-health/<vehicle_class>``;
* one registered model per asset: ``fleet-health.<asset_id>``;
* aliases ``baseline`` (the healthy version) and ``candidate`` (the newest fit);
* every tag the registry writes starts with ``fleet_health.``.

Asset ids are validated with :func:`graybox.telemetry.validate_asset_id` *before* any name
is built, so a malformed id never reaches MLflow (or a lock-file path).
"""
from __future__ import annotations

import hashlib
import re

from graybox.telemetry import validate_asset_id
from graybox.timestamps import utc

EXPERIMENT_PREFIX = "fleet-health/"
MODEL_PREFIX = "fleet-health."
#: the fleet-level experiment: one run per night with the fleet's heat map (not a class)
FLEET_EXPERIMENT = EXPERIMENT_PREFIX + "fleet"
RESERVED_CLASSES = ("fleet",)
#: the experiment of ``fleet-health check``'s write probe (outside the prefix: no class's)
PROBE_EXPERIMENT = "fleet-health-check"

BASELINE = "baseline"
CANDIDATE = "candidate"
ROLES = (BASELINE, CANDIDATE)
ALIASES = (BASELINE, CANDIDATE)

_CLASS_PATTERN = re.compile(r"[A-Za-z0-9_.-]{1,64}")

# -- tag keys ---------------------------------------------------------------------------------
_P = "fleet_health."
TAG_ASSET_ID = _P + "asset_id"
TAG_VEHICLE_CLASS = _P + "vehicle_class"
TAG_EXPERIMENT_ID = _P + "experiment_id"
TAG_WINDOW_START = _P + "window_start"
TAG_WINDOW_END = _P + "window_end"
TAG_ROLE = _P + "role"
TAG_DATA_HASH = _P + "data_hash"
TAG_CODE_VERSION = _P + "code_version"
TAG_FIT_KEY = _P + "fit_key"
TAG_COMPLETE = _P + "complete"
TAG_MODEL_ID = _P + "model_id"
TAG_RUN_ID = _P + "run_id"
TAG_ALARM = _P + "alarm"
TAG_CALIBRATED = _P + "calibrated"
TAG_MANIFEST_SHA256 = _P + "manifest_sha256"
TAG_BASELINE_VERSION = _P + "baseline_version"   #: the baseline a candidate was compared with
TAG_WATERMARK = _P + "watermark"
TAG_PROMOTED_AT = _P + "promoted_at"
TAG_PROMOTED_BY = _P + "promoted_by"
TAG_PROMOTION_REASON = _P + "promotion_reason"
TAG_PREVIOUS_BASELINE = _P + "previous_baseline"
TAG_REJECTED = _P + "rejected"
TAG_REJECTED_AT = _P + "rejected_at"
TAG_REJECTED_BY = _P + "rejected_by"
TAG_REJECTION_REASON = _P + "rejection_reason"
TAG_ROLLED_BACK_AT = _P + "rolled_back_at"
TAG_ROLLED_BACK_BY = _P + "rolled_back_by"
TAG_ROLLBACK_REASON = _P + "rollback_reason"
TAG_REANALYSIS = _P + "reanalysis"               #: "true" on runs of an ad-hoc reanalysis
TAG_DIAGNOSIS = _P + "diagnosis"                 #: explained, unexplained or failed
TAG_LIKELY_CAUSE = _P + "likely_cause"           #: the diagnosis' first entry in a line
TAG_NIGHT = _P + "night"                         #: a fleet-level run's night (YYYY-MM-DD)


def validate_vehicle_class(vehicle_class: str) -> str:
    """Return ``vehicle_class`` if it matches ``[A-Za-z0-9_.-]{1,64}``, else raise ValueError."""
    if (not isinstance(vehicle_class, str) or _CLASS_PATTERN.fullmatch(vehicle_class) is None
            or vehicle_class in (".", "..")):
        raise ValueError(f"invalid vehicle class {vehicle_class!r}: must match "
                         f"[A-Za-z0-9_.-]{{1,64}} and not be '.' or '..'")
    if vehicle_class in RESERVED_CLASSES:
        raise ValueError(f"vehicle class {vehicle_class!r} is reserved: its experiment "
                         f"{FLEET_EXPERIMENT!r} holds the fleet-level runs of the nights")
    return vehicle_class


def experiment_name(vehicle_class: str) -> str:
    """The experiment of a vehicle class, ``fleet-health/<vehicle_class>``."""
    return EXPERIMENT_PREFIX + validate_vehicle_class(vehicle_class)


def model_name(asset_id: str) -> str:
    """The registered model of an asset, ``fleet-health.<asset_id>`` (id validated first).

    Raises
    ------
    graybox.exceptions.InvalidAssetIdError
        If ``asset_id`` is not a valid asset id.
    """
    return MODEL_PREFIX + validate_asset_id(asset_id)


def asset_from_model_name(name: str) -> str | None:
    """The asset id of a registered model name, or None if it is not one of ours."""
    if not name.startswith(MODEL_PREFIX):
        return None
    try:
        return validate_asset_id(name[len(MODEL_PREFIX):])
    except Exception:
        return None


def iso_utc(value) -> str:
    """A timestamp as an ISO-8601 UTC string (naive values are taken as UTC).

    One spelling per instant, so window bounds compare and hash the same however they were
    given (string, datetime or pandas Timestamp).
    """
    return utc(value).as_unit("ns").isoformat()


def fit_key(asset_id: str, window_start, window_end, role: str, data_hash: str,
            variant: str | None = None) -> str:
    """The idempotence key of a recorded fit.

    Recording the same ``(asset_id, window_start, window_end, role, data_hash)`` twice finds
    the first record through this key (a tag on its run and model version) instead of
    creating a second one.

    ``variant`` keeps other kinds of record of the same window apart (a reanalysis against
    baseline version 3 is ``"reanalysis:v3"``; a baseline's is the configuration it was
    fitted with, :func:`registry.write.submission.configuration_hash`, so a refit with other
    settings is a new version); None is a nightly fit.

    Returns
    -------
    str
        40 hex characters.
    """
    validate_asset_id(asset_id)
    if role not in ROLES:
        raise ValueError(f"role must be one of {ROLES}, got {role!r}")
    parts = [asset_id, iso_utc(window_start), iso_utc(window_end), role, data_hash]
    if variant is not None:
        parts.append(variant)
    text = "\n".join(parts)
    return hashlib.sha256(text.encode()).hexdigest()[:40]


def quote(value: str) -> str:
    """A string literal for an MLflow filter string (values we build are already safe; this
    also refuses anything that could break out of the literal)."""
    if "'" in value or "\\" in value:
        raise ValueError(f"refusing to put {value!r} in an MLflow filter string")
    return f"'{value}'"
