"""Typed records the registry returns (plain frozen dataclasses, JSON-ready via ``to_dict``)."""
from __future__ import annotations

from dataclasses import asdict, dataclass

from graybox.calibration import Calibration
from graybox.signature import Signature
from registry.store import naming


@dataclass(frozen=True)
class FitRecord:
    """Where a recorded fit went.

    Attributes
    ----------
    asset_id, vehicle_class, role : str
    version : int or None
        The registered model version of the fit (None for a reanalysis, which registers no
        version).
    run_id : str
        The MLflow run.
    model_id : str
        The logged model of a baseline fit; empty for a candidate (its model is in its run's
        ``model/`` artifacts) and for a reanalysis (no model).
    fit_key : str
        Idempotence key (see :func:`registry.store.naming.fit_key`).
    window_start, window_end : str
        ISO UTC bounds of the telemetry window (end exclusive).
    data_hash : str
    created : bool
        False when the same fit had already been recorded and was returned as it was.
    alarm : bool or None
        For a candidate with a drift, whether any zeta exceeded its epsilon.
    """

    asset_id: str
    vehicle_class: str
    role: str
    version: int | None
    run_id: str
    model_id: str
    fit_key: str
    window_start: str
    window_end: str
    data_hash: str
    created: bool
    alarm: bool | None = None

    def to_dict(self) -> dict:
        return asdict(self)


def _int_or_none(value: str | None) -> int | None:
    try:
        return int(value) if value not in (None, "") else None
    except ValueError:
        return None


def _bool_or_none(value: str | None) -> bool | None:
    if value is None or value == "":
        return None
    return value.lower() == "true"


@dataclass(frozen=True)
class VersionInfo:
    """One registered model version of an asset, as the registry describes it.

    Attributes
    ----------
    asset_id : str
    version : int
    role : str or None
        ``"baseline"`` (fitted on a healthy range) or ``"candidate"`` (nightly fit).
    aliases : tuple of str
        The aliases it holds (``baseline``, ``candidate``).
    calibrated : bool
        Whether it carries a calibration (only calibrated versions can become the baseline).
    rejected : bool
    alarm : bool or None
    window_start, window_end, data_hash, fit_key, run_id : str or None
    created : str
        ISO UTC creation time.
    baseline_version : int or None
        For a candidate: the baseline it was compared with.
    promoted_at, promoted_by, promotion_reason : str or None
        The last promotion of this version to baseline.
    previous_baseline : int or None
        The baseline this version replaced when it was last promoted (rollback goes there).
    rejected_at, rejected_by, rejection_reason : str or None
    rolled_back_at, rolled_back_by, rollback_reason : str or None
        The last time the baseline was rolled back from this version.
    """

    asset_id: str
    version: int
    role: str | None
    aliases: tuple[str, ...]
    calibrated: bool
    rejected: bool
    alarm: bool | None
    window_start: str | None
    window_end: str | None
    data_hash: str | None
    fit_key: str | None
    run_id: str | None
    created: str
    baseline_version: int | None = None
    promoted_at: str | None = None
    promoted_by: str | None = None
    promotion_reason: str | None = None
    previous_baseline: int | None = None
    rejected_at: str | None = None
    rejected_by: str | None = None
    rejection_reason: str | None = None
    rolled_back_at: str | None = None
    rolled_back_by: str | None = None
    rollback_reason: str | None = None

    @property
    def status(self) -> str:
        """``baseline``, ``candidate``, ``rejected``, ``former baseline`` or empty."""
        if naming.BASELINE in self.aliases:
            return "baseline"
        if self.rejected:
            return "rejected"
        if naming.CANDIDATE in self.aliases:
            return "candidate"
        if self.promoted_at:
            return "former baseline"
        return ""

    def to_dict(self) -> dict:
        data = asdict(self)
        data["aliases"] = list(self.aliases)
        data["status"] = self.status
        return data

    @classmethod
    def from_model_version(cls, asset_id: str, version) -> "VersionInfo":
        """Build from an ``mlflow.entities.model_registry.ModelVersion``."""
        import pandas as pd

        tags = dict(version.tags or {})
        created = pd.Timestamp(int(version.creation_timestamp or 0), unit="ms", tz="UTC")
        return cls(
            asset_id=asset_id,
            version=int(version.version),
            role=tags.get(naming.TAG_ROLE),
            aliases=tuple(sorted(version.aliases or ())),
            calibrated=tags.get(naming.TAG_CALIBRATED) == "true",
            rejected=tags.get(naming.TAG_REJECTED) == "true",
            alarm=_bool_or_none(tags.get(naming.TAG_ALARM)),
            window_start=tags.get(naming.TAG_WINDOW_START),
            window_end=tags.get(naming.TAG_WINDOW_END),
            data_hash=tags.get(naming.TAG_DATA_HASH),
            fit_key=tags.get(naming.TAG_FIT_KEY),
            run_id=version.run_id or tags.get(naming.TAG_RUN_ID),
            created=created.isoformat(),
            baseline_version=_int_or_none(tags.get(naming.TAG_BASELINE_VERSION)),
            promoted_at=tags.get(naming.TAG_PROMOTED_AT),
            promoted_by=tags.get(naming.TAG_PROMOTED_BY),
            promotion_reason=tags.get(naming.TAG_PROMOTION_REASON),
            previous_baseline=_int_or_none(tags.get(naming.TAG_PREVIOUS_BASELINE)),
            rejected_at=tags.get(naming.TAG_REJECTED_AT),
            rejected_by=tags.get(naming.TAG_REJECTED_BY),
            rejection_reason=tags.get(naming.TAG_REJECTION_REASON),
            rolled_back_at=tags.get(naming.TAG_ROLLED_BACK_AT),
            rolled_back_by=tags.get(naming.TAG_ROLLED_BACK_BY),
            rollback_reason=tags.get(naming.TAG_ROLLBACK_REASON),
        )


@dataclass(frozen=True)
class AssetSummary:
    """An asset's baseline state, as ``baseline list`` shows it.

    Attributes
    ----------
    asset_id, vehicle_class : str
    baseline, candidate : VersionInfo or None
        The versions holding the aliases.
    latest_version : int or None
    watermark : str or None
        ISO UTC end of the last committed window.
    """

    asset_id: str
    vehicle_class: str | None
    baseline: VersionInfo | None
    candidate: VersionInfo | None
    latest_version: int | None
    watermark: str | None

    def to_dict(self) -> dict:
        return {"asset_id": self.asset_id, "vehicle_class": self.vehicle_class,
                "baseline": None if self.baseline is None else self.baseline.to_dict(),
                "candidate": None if self.candidate is None else self.candidate.to_dict(),
                "latest_version": self.latest_version, "watermark": self.watermark}


@dataclass(frozen=True)
class LoadedVersion:
    """A version's signature and calibration, loaded and verified (no pickle).

    Attributes
    ----------
    info : VersionInfo
    signature : Signature
    calibration : Calibration or None
    manifest_sha256 : str
    """

    info: VersionInfo
    signature: Signature
    calibration: Calibration | None
    manifest_sha256: str

    @property
    def version(self) -> int:
        return self.info.version

    @property
    def asset_id(self) -> str:
        return self.info.asset_id
