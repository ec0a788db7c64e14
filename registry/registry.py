"""The registry facade: what the flows and the command line call."""
from __future__ import annotations

import os

import pandas as pd

from graybox.calibration import Calibration
from graybox.drift import Drift
from graybox.signature import Signature
from registry import baselines, records, watermarks
from registry.backend import Backend
from registry.entities import AssetSummary, FitRecord, LoadedVersion, VersionInfo
from registry.store import RetryPolicy


class Registry:
    """Healthy baselines and nightly candidates in MLflow, the system of record.

    Parameters
    ----------
    tracking_uri : str, optional
        ``sqlite:///path.db`` (the embedded store; relative paths resolve against
        ``workdir``), ``http://host:port`` of an ``mlflow server``, or any MLflow tracking
        URI. None is ``sqlite:///<workdir>/mlflow.db``.
    workdir : path-like, optional
        Base of the default store and of relative SQLite paths (the current directory if
        omitted). SQLite stores keep their artifacts in ``<db dir>/mlartifacts``.
    user : str, optional
        Recorded with promotions, rejections and rollbacks (default ``FLEET_HEALTH_USER`` or
        the login name).
    retry : RetryPolicy, optional
        Backoff for "database is locked" errors.

    Examples
    --------
    >>> registry = Registry("sqlite:///mlflow.db")                          # doctest: +SKIP
    >>> fit = GrayBox(model).fit(healthy_days)                              # doctest: +SKIP
    >>> record = registry.record_fit("T-01", "turbine", fit.signature_, role="baseline",
    ...                              calibration=fit.calibration_, window=healthy_days)
    >>> registry.promote("T-01", record.version, reason="initial baseline")  # doctest: +SKIP
    >>> registry.baseline("T-01").signature == fit.signature_               # doctest: +SKIP
    True
    """

    def __init__(self, tracking_uri: str | None = None, *, workdir: str | os.PathLike | None = None,
                 user: str | None = None, retry: RetryPolicy = RetryPolicy()):
        self._backend = Backend(tracking_uri, workdir=workdir, user=user, retry=retry)

    def __repr__(self) -> str:
        return f"Registry({self.tracking_uri!r})"

    @property
    def tracking_uri(self) -> str:
        """The normalized tracking (and model registry) URI."""
        return self._backend.tracking_uri

    @property
    def backend(self) -> Backend:
        """The bound MLflow client and look-ups (for advanced use and tests)."""
        return self._backend

    # -- recording -----------------------------------------------------------------------------
    def record_fit(self, asset_id: str, vehicle_class: str, signature: Signature, *, role: str,
                   calibration: Calibration | None = None, drift: Drift | None = None,
                   window=None, data_hash: str | None = None, window_start=None,
                   window_end=None, baseline_version: int | None = None,
                   plots: bool = True, reanalysis: bool = False) -> FitRecord:
        """Record a fit as a run, a logged pyfunc model and a new version (alias ``candidate``).

        Idempotent: the same ``(asset_id, window_start, window_end, role, data_hash)``
        returns the first record (``created=False``) without a new run or version.

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
        calibration : Calibration, optional
        drift : Drift, optional
            Logs zeta, epsilon and ratio per tier and channel, the ``fleet_health.alarm`` tag,
            ``drift.json`` and the zeta trend plot.
        window : TelemetryWindow, DataFrame or sequence of them, optional
            The telemetry fitted. Used for the data hash and the residual and tier-fit
            plots (drawn on the last window); without it those plots are skipped.
        data_hash : str, optional
            Overrides the hash of ``window`` (e.g. a hash of the Parquet files). Without
            either, the signature's own JSON identifies the fit.
        window_start, window_end : timestamp-like, optional
            Default to the signature's.
        baseline_version : int, optional
            The baseline a candidate's drift was computed against (default: the version
            holding ``baseline`` now).
        plots : bool, default True
        reanalysis : bool, default False
            An ad-hoc reanalysis (role ``candidate``, ``baseline_version`` required): only the
            run is recorded, tagged ``fleet_health.reanalysis``, with no logged model, no
            version and no alias move; :meth:`zeta_history` and :meth:`alerts` leave it out.
            Idempotent on the window, data hash and ``baseline_version``.

        Returns
        -------
        FitRecord
        """
        return records.record_fit(self._backend, asset_id, vehicle_class, signature, role=role,
                                  calibration=calibration, drift=drift, window=window,
                                  data_hash_=data_hash, window_start=window_start,
                                  window_end=window_end, baseline_version=baseline_version,
                                  plots=plots, reanalysis=reanalysis)

    # -- nightly reads -------------------------------------------------------------------------
    def baseline(self, asset_id: str) -> LoadedVersion | None:
        """The asset's baseline signature and calibration, verified (None if it has none).

        Raises
        ------
        graybox.exceptions.ArtifactError
            If its artifacts are missing or were altered.
        """
        return baselines.baseline(self._backend, asset_id)

    def watermark(self, asset_id: str) -> pd.Timestamp | None:
        """End (exclusive, UTC) of the asset's last committed window: one registry call."""
        return watermarks.watermark(self._backend, asset_id)

    def commit_watermark(self, asset_id: str, end) -> pd.Timestamp:
        """Advance the asset's watermark to ``end`` once its results are committed (never
        backwards); returns the watermark in place."""
        return watermarks.commit_watermark(self._backend, asset_id, end)

    def load_version(self, asset_id: str, version: int | str | None = None) -> LoadedVersion:
        """Load and verify a version by number or alias (default ``baseline``)."""
        return baselines.load_version(self._backend, asset_id, version)

    def load_pyfunc(self, asset_id: str, version: int | str | None = None):
        """The version (default ``baseline``) as a verified ``mlflow.pyfunc`` model whose
        ``predict(telemetry_frame)`` returns zeta per tier and channel."""
        return baselines.load_pyfunc(self._backend, asset_id, version)

    # -- review --------------------------------------------------------------------------------
    def promote(self, asset_id: str, version: int | None = None, *, reason: str,
                user: str | None = None) -> VersionInfo:
        """Make a calibrated version (default: the candidate) the baseline, recording why."""
        return baselines.promote(self._backend, asset_id, version, reason=reason, user=user)

    def reject(self, asset_id: str, version: int, *, reason: str,
               user: str | None = None) -> VersionInfo:
        """Mark a version rejected; it loses the ``candidate`` alias and can't be promoted."""
        return baselines.reject(self._backend, asset_id, version, reason=reason, user=user)

    def rollback(self, asset_id: str, *, reason: str, user: str | None = None) -> VersionInfo:
        """Move ``baseline`` back to the baseline the current one replaced."""
        return baselines.rollback(self._backend, asset_id, reason=reason, user=user)

    def list_baselines(self, vehicle_class: str | None = None) -> list[AssetSummary]:
        """Every asset (optionally of one class) with its baseline and candidate versions."""
        return baselines.list_baselines(self._backend, vehicle_class)

    def history(self, asset_id: str) -> list[VersionInfo]:
        """Every version of the asset, oldest first."""
        return baselines.history(self._backend, asset_id)

    def zeta_history(self, asset_id: str, last: int | None = None) -> pd.DataFrame:
        """The asset's candidate zetas: columns ``window_start, window_end, channel, tier,
        zeta, epsilon, ratio, exceeded, run_id, baseline_version``, oldest first (only the
        ``last`` most recent windows when given). One row set per window: a window recorded
        again with other data keeps its latest record."""
        return records.zeta_history(self._backend, asset_id, last)

    def alerts(self, since=None) -> list[dict]:
        """Recorded alarms (window end at or after ``since``), oldest first."""
        return records.alerts(self._backend, since)
