"""What a caller submits for recording: :class:`FitSubmission`, and the identity it resolves to.

A submission is checked when it is built (asset id, vehicle class, role, which of calibration
and drift it may carry), so a malformed one never reaches MLflow. :meth:`FitSubmission.resolve`
fixes its window bounds (one ISO UTC spelling per instant), its data hash and its
idempotence key (:func:`registry.store.naming.fit_key`).
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from graybox.calibration import Calibration
from graybox.diagnosis import Diagnosis
from graybox.drift import Drift
from graybox.signature import Signature
from graybox.timestamps import utc
from registry.store import naming
from graybox.alert_diagnosis import DiagnosisFailure


def frames(window) -> list[pd.DataFrame]:
    """The DataFrames of a TelemetryWindow, a DataFrame or a sequence of them."""
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
    for frame in frames(window):
        digest.update(json.dumps([str(c) for c in frame.columns]).encode())
        index = frame.index
        if isinstance(index, pd.DatetimeIndex):
            digest.update(np.ascontiguousarray(utc(index).as_unit("ns").asi8).tobytes())
        else:
            digest.update(np.ascontiguousarray(np.asarray(index, dtype=np.int64)).tobytes())
        digest.update(np.ascontiguousarray(frame.to_numpy(dtype=np.float64)).tobytes())
    return digest.hexdigest()


def configuration_hash(signature: Signature, calibration: Calibration | None) -> str:
    """sha256 of what a baseline was fitted with, as configured: the white box (class,
    columns, fingerprint, parameters as given, the estimated ones at their starting values),
    the gray-box settings, which parameters were estimated and the calibration's false-alarm
    rate. A baseline fitted again on the same telemetry with another configuration is a new
    fit; with the same one it is the same fit (the result, which may differ in its last digits
    between processes, is not hashed)."""
    model = signature.model.to_dict()
    tuning = signature.tuning
    if tuning is not None:
        model["parameters"] = {**model.get("parameters", {}),
                               **dict(zip(tuning.names, tuning.initial))}
    text = json.dumps({"model": model, "settings": signature.settings.to_dict(),
                       "estimate": list(tuning.names) if tuning is not None else [],
                       "false_alarm_rate": calibration.false_alarm_rate if calibration else None},
                      sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class FitSubmission:
    """One fit to record (see :meth:`registry.Registry.record_fit`).

    Parameters
    ----------
    asset_id : str
        Validated before any name is built.
    vehicle_class : str
        Selects the experiment ``fleet-health/<vehicle_class>``.
    signature : Signature
    role : {"baseline", "candidate"}
        ``baseline``: fitted on a healthy range, normally with its ``calibration`` (only
        calibrated versions can be promoted). ``candidate``: a nightly fit, normally with
        its ``drift`` against the baseline.
    window_start, window_end : timestamp-like, optional
        Default to the signature's.
    calibration : Calibration, optional
        Baseline fits only.
    drift : Drift, optional
        Candidate fits only: logs zeta, epsilon and ratio per tier and channel, the
        ``fleet_health.alarm`` tag, ``drift.json`` and (with plots) the zeta trend.
    baseline_version : int, optional
        The baseline a candidate's drift was computed against (default: the version
        holding ``baseline`` when it is recorded).
    data_hash : str, optional
        Overrides the hash of ``window`` (e.g. a hash of the Parquet files). Without
        either, the signature's own JSON identifies the fit.
    window : TelemetryWindow, DataFrame or sequence of them, optional
        The telemetry fitted: hashed, and drawn in the residual and tier-fit plots.
    plots : bool, default True
        PNG plots under ``plots/`` (they cost far more than the rest of a record).
    reanalysis : bool, default False
        An ad-hoc reanalysis (role ``candidate``, ``baseline_version`` required): only the
        run is recorded, tagged ``fleet_health.reanalysis``.
    diagnosis : Diagnosis or DiagnosisFailure, optional
        Candidate fits only (an alarmed window's): ``diagnosis.json`` and the tags
        ``fleet_health.diagnosis`` (explained, unexplained or failed) and
        ``fleet_health.likely_cause`` (see :mod:`graybox.alert_diagnosis`).

    Raises
    ------
    graybox.exceptions.InvalidAssetIdError
        If ``asset_id`` is malformed.
    ValueError
        If the vehicle class or role is invalid, or the fit carries what its role does not.
    """

    asset_id: str
    vehicle_class: str
    signature: Signature
    role: str
    window_start: Any = None
    window_end: Any = None
    calibration: Calibration | None = None
    drift: Drift | None = None
    baseline_version: int | None = None
    data_hash: str | None = None
    window: Any = None
    plots: bool = True
    reanalysis: bool = False
    diagnosis: Diagnosis | DiagnosisFailure | None = None

    def __post_init__(self):
        naming.model_name(self.asset_id)
        naming.validate_vehicle_class(self.vehicle_class)
        if self.role not in naming.ROLES:
            raise ValueError(f"role must be one of {naming.ROLES}, got {self.role!r}")
        if self.role == naming.BASELINE and self.drift is not None:
            raise ValueError("a baseline fit has no drift; record drifts with role='candidate'")
        if self.role == naming.BASELINE and self.diagnosis is not None:
            raise ValueError("a baseline fit has no diagnosis; diagnoses belong to alarmed "
                             "candidates (role='candidate')")
        if self.role == naming.CANDIDATE and self.calibration is not None:
            raise ValueError("a candidate fit carries no calibration; record the calibration "
                             "with the baseline fit it belongs to (role='baseline')")
        if self.signature.asset_id not in (None, self.asset_id):
            raise ValueError(f"the signature was fitted for asset {self.signature.asset_id!r}, "
                             f"not {self.asset_id!r}")
        if self.reanalysis:
            if self.role != naming.CANDIDATE:
                raise ValueError("a reanalysis records a candidate fit (role='candidate')")
            if self.baseline_version is None:
                raise ValueError("a reanalysis names the version it was compared with "
                                 "(baseline_version)")

    def resolve(self) -> "ResolvedFit":
        """The window bounds, data hash and idempotence key of this submission.

        Raises
        ------
        ValueError
            If the window bounds are unknown or not in order.
        """
        start = self.window_start if self.window_start is not None else self.signature.window_start
        end = self.window_end if self.window_end is not None else self.signature.window_end
        if start is None or end is None:
            raise ValueError("window start and end are unknown: pass window_start and "
                             "window_end (the signature does not carry them)")
        start, end = naming.iso_utc(start), naming.iso_utc(end)
        if not pd.Timestamp(start) < pd.Timestamp(end):
            raise ValueError(f"window start {start} is not before its end {end}")
        digest = self.data_hash
        if digest is None:
            digest = data_hash(self.window) if self.window is not None else \
                hashlib.sha256(self.signature.to_json().encode()).hexdigest()
        if self.reanalysis:
            variant = f"reanalysis:v{int(self.baseline_version)}"
        elif self.role == naming.BASELINE:
            variant = "configuration:" + configuration_hash(self.signature, self.calibration)
        else:
            variant = None
        key = naming.fit_key(self.asset_id, start, end, self.role, digest, variant=variant)
        return ResolvedFit(self, start, end, digest, key)


@dataclass(frozen=True)
class ResolvedFit:
    """A submission with its identity fixed.

    Attributes
    ----------
    submission : FitSubmission
    start, end : str
        ISO UTC window bounds (end exclusive).
    data_hash : str
    key : str
        The idempotence key, a tag on the run and on the version.
    """

    submission: FitSubmission
    start: str
    end: str
    data_hash: str
    key: str

    @property
    def asset_id(self) -> str:
        return self.submission.asset_id

    @property
    def run_name(self) -> str:
        kind = "reanalysis" if self.submission.reanalysis else self.submission.role
        return f"{self.asset_id} {kind} {self.start[:16]} .. {self.end[:16]}"
