"""The registry facade: what the flows and the command line call.

Its constructor and methods raise the registry's errors, never MLflow's
(:mod:`registry.store.boundary`): a passing failure of the store is a
:class:`~registry.exceptions.TransientStoreError`.
"""
from __future__ import annotations

import os
from typing import Collection, Mapping, Sequence

import pandas as pd

from graybox.alert import Alert
from graybox.severity import SeverityScale
from registry import fleet_nights, review
from registry.fleet_nights import NightRatio
from registry.read import history, loading
from registry.records import AssetSummary, FitRecord, LoadedVersion, VersionInfo
from registry.store import probe
from registry.store.backend import Backend
from registry.store.boundary import facade
from registry.store.retry import RetryPolicy
from registry.write import group, recording, watermarks
from registry.write.model_files import PyfuncTemplate
from registry.write.submission import FitSubmission

@facade
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

    Raises
    ------
    registry.exceptions.TransientStoreError
        From the constructor and any method, when the store failed in a passing way (locked
        after the retries, unreachable, temporarily unavailable): a later try may succeed.
    registry.exceptions.StoreError
        When the store failed otherwise (MLflow's error, message kept).

    Examples
    --------
    >>> registry = Registry("sqlite:///mlflow.db")                          # doctest: +SKIP
    >>> fit = GrayBox(model).fit(healthy_days)                              # doctest: +SKIP
    >>> record = registry.record_fit(FitSubmission(
    ...     "T-01", "turbine", fit.signature_, role="baseline",
    ...     calibration=fit.calibration_, window=healthy_days))                 # doctest: +SKIP
    >>> registry.promote("T-01", record.version, reason="initial baseline")  # doctest: +SKIP
    >>> registry.baseline("T-01").signature == fit.signature_               # doctest: +SKIP
    True
    """

    def __init__(self, tracking_uri: str | None = None, *, workdir: str | os.PathLike | None = None,
                 user: str | None = None, retry: RetryPolicy = RetryPolicy()):
        self._backend = Backend(tracking_uri, workdir=workdir, user=user, retry=retry)
        self._template = PyfuncTemplate()

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
    def record_fit(self, submission: FitSubmission | str, *args, **kwargs) -> FitRecord:
        """Record a fit as a run with its pyfunc model, and a new version (alias ``candidate``).

        Idempotent: the same ``(asset_id, window_start, window_end, role, data_hash)`` (and
        for a baseline the same configuration) returns the first record
        (``created=False``) without a new run or version; a recording interrupted half-way
        is finished or replaced.

        Parameters
        ----------
        submission : FitSubmission
            What to record (see :class:`registry.write.submission.FitSubmission`). The arguments
            of ``FitSubmission`` may be given here instead: ``record_fit(asset_id,
            vehicle_class, signature, role=..., ...)``.

        Returns
        -------
        FitRecord
            A reanalysis (``reanalysis=True``) has no version and no model id: only its run
            is recorded, tagged ``fleet_health.reanalysis``, with no alias move;
            :meth:`zeta_history` and :meth:`alerts` leave it out.
        """
        if not isinstance(submission, FitSubmission):
            submission = FitSubmission(submission, *args, **kwargs)
        elif args or kwargs:
            raise TypeError("record_fit takes a FitSubmission or its arguments, not both")
        return recording.record_fit(self._backend, submission, self._template)

    def record_fits(self, submissions: Sequence[FitSubmission]) -> list[FitRecord]:
        """Record several fits (e.g. one night of a batch of assets), in order.

        The same records as :meth:`record_fit` of each, with the look-ups shared: the
        experiments and registered models of the batch are found once and an asset's
        ``candidate`` alias moves once. Every submission is checked before anything is
        written; if one fails its error is raised, the fits before it stay recorded and
        recording the batch again finds them.
        """
        return recording.record_fits(self._backend, list(submissions), self._template)

    def record_group(self, submissions: Sequence[FitSubmission], *,
                     stop_at_error: bool = True) -> list[FitRecord | Exception | None]:
        """Record the fits of a group of assets (a night's memory group), each asset on its
        own; on an SQLite or PostgreSQL store the new candidates go in one transaction.

        The same records as :meth:`record_fit` of each (idempotent on the fit key), with the
        look-ups, the locks and the commit shared (:mod:`registry.write.group`).

        Parameters
        ----------
        submissions : sequence of FitSubmission
            An asset's fits in time order.
        stop_at_error : bool, default True
            A failed fit stops its asset: its later fits are not recorded.

        Returns
        -------
        list
            Per submission, in order: its FitRecord; or the error that stopped it (the
            registry's, as :meth:`record_fit` would raise it: one asset's failure never
            stops the others); or None, not attempted after an earlier failure of its asset.

        Raises
        ------
        registry.exceptions.TransientStoreError
            When the store failed in a passing way for the whole group (retry it: what was
            recorded is found again, not duplicated).
        """
        return group.record_group(self._backend, list(submissions), self._template,
                                  stop_at_error)

    # -- nightly reads -------------------------------------------------------------------------
    def baseline(self, asset_id: str) -> LoadedVersion | None:
        """The asset's baseline signature and calibration, verified (None if it has none).

        Raises
        ------
        graybox.exceptions.ArtifactError
            If its artifacts are missing or were altered.
        """
        return loading.baseline(self._backend, asset_id)

    def reference(self, asset_id: str, version: int | str | None = None, *,
                  models: Collection[str] | None = None) -> LoadedVersion | None:
        """The version a run compares the asset with (default its baseline; None if it has
        none), verified, calibrated and naming one of ``models``.

        Raises
        ------
        registry.exceptions.UnusableBaselineError
            If it cannot be used; the message names the version and the command that fixes
            it (see :func:`registry.review.reference`).
        """
        return review.reference(self._backend, asset_id, version, models)

    def watermark(self, asset_id: str) -> pd.Timestamp | None:
        """End (exclusive, UTC) of the asset's last committed window: one registry call."""
        return watermarks.watermark(self._backend, asset_id)

    def watermarks(self, asset_ids: Sequence[str]) -> dict[str, pd.Timestamp | None]:
        """:meth:`watermark` of each asset, read together (one query on an SQL store)."""
        return watermarks.watermarks(self._backend, asset_ids)

    def commit_watermark(self, asset_id: str, end) -> pd.Timestamp:
        """Advance the asset's watermark to ``end`` once its results are committed (never
        backwards); returns the watermark in place."""
        return watermarks.commit_watermark(self._backend, asset_id, end)

    def commit_watermarks(self, ends: Mapping[str, object]
                          ) -> dict[str, pd.Timestamp | Exception]:
        """:meth:`commit_watermark` of several assets (``{asset_id: end}``), each on its own,
        in one transaction where the store allows; per asset the watermark in place or the
        error that kept it. A passing failure of the store is raised for all
        (``TransientStoreError``)."""
        return watermarks.commit_watermarks(self._backend, ends)

    def aliases(self, asset_id: str) -> dict[str, int]:
        """The asset's aliases (``baseline``, ``candidate``) and the version each names;
        empty when nothing is recorded. One read of its registered model, not its versions."""
        model = self._backend.registered_model(asset_id)
        return {} if model is None else {alias: int(v) for alias, v in model.aliases.items()}

    def load_version(self, asset_id: str, version: int | str | None = None, *,
                     models: Collection[str] | None = None) -> LoadedVersion:
        """Load and verify a version by number or alias (default ``baseline``); given
        ``models``, its signature must name one of these model specs."""
        return loading.load_version(self._backend, asset_id, version, models)

    def load_pyfunc(self, asset_id: str, version: int | str | None = None, *,
                    models: Collection[str] | None = None):
        """The version (default ``baseline``) as a verified ``mlflow.pyfunc`` model whose
        ``predict(telemetry_frame)`` returns zeta per tier and channel. ``models``: the
        model specs it may name (else its model's module must already be imported)."""
        return loading.load_pyfunc(self._backend, asset_id, version, models)

    # -- review --------------------------------------------------------------------------------
    def promote(self, asset_id: str, version: int | None = None, *, reason: str,
                user: str | None = None) -> VersionInfo:
        """Make a calibrated version (default: the candidate) the baseline, recording why."""
        return review.promote(self._backend, asset_id, version, reason=reason, user=user)

    def reject(self, asset_id: str, version: int, *, reason: str,
               user: str | None = None) -> VersionInfo:
        """Mark a version rejected; it loses the ``candidate`` alias and can't be promoted."""
        return review.reject(self._backend, asset_id, version, reason=reason, user=user)

    def rollback(self, asset_id: str, *, reason: str, user: str | None = None) -> VersionInfo:
        """Move ``baseline`` back to the baseline the current one replaced."""
        return review.rollback(self._backend, asset_id, reason=reason, user=user)

    def list_baselines(self, vehicle_class: str | None = None) -> list[AssetSummary]:
        """Every asset (optionally of one class) with its baseline and candidate versions."""
        return review.list_baselines(self._backend, vehicle_class)

    def history(self, asset_id: str) -> list[VersionInfo]:
        """Every version of the asset, oldest first."""
        return review.history(self._backend, asset_id)

    def zeta_history(self, asset_id: str, last: int | None = None) -> pd.DataFrame:
        """The asset's candidate zetas: columns ``window_start, window_end, channel, tier,
        zeta, epsilon, ratio, exceeded, run_id, baseline_version``, oldest first (only the
        ``last`` most recent windows when given). One row set per window: a window recorded
        again with other data keeps its latest record."""
        return history.zeta_history(self._backend, asset_id, last)

    def recorded_windows(self, asset_id: str, last: int) -> list[tuple[str, str]]:
        """``(window_start, window_end)`` (ISO strings) of the nightly candidates among the
        asset's ``last`` newest versions, newest first: what :meth:`zeta_history` would list,
        read without the runs' metrics."""
        return history.recorded_windows(self._backend, asset_id, last)

    def baseline_window_end(self, asset_id: str) -> pd.Timestamp | None:
        """End (exclusive, UTC) of the window the asset's baseline was fitted on (None
        without a baseline), read without loading the baseline: one registry call."""
        end = history.baseline_window_end(self._backend, asset_id)
        return None if not end else pd.Timestamp(end)

    def baseline_window_ends(self, asset_ids: Sequence[str]) -> dict[str, pd.Timestamp | None]:
        """:meth:`baseline_window_end` of each asset, read together (one query on an SQL
        store)."""
        ends = history.baseline_window_ends(self._backend, asset_ids)
        return {asset: (pd.Timestamp(end) if end else None) for asset, end in ends.items()}

    def recorded_windows_of(self, asset_ids: Sequence[str], last: int
                            ) -> dict[str, list[tuple[str, str]]]:
        """:meth:`recorded_windows` of each asset, read together (two queries on an SQL
        store)."""
        return history.recorded_windows_of(self._backend, asset_ids, last)

    def alerts(self, since=None, *, scale: SeverityScale = SeverityScale()) -> list[Alert]:
        """The recorded nightly alerts (window end at or after ``since``), oldest first.

        One :class:`graybox.alert.Alert` per asset, window, channel and tier whose zeta
        exceeded epsilon: the same records the nightly run wrote to its alerts file.
        ``scale`` grades their severity (``[alerts]`` of fleet.toml). Reanalyses are left
        out.
        """
        return history.alerts(self._backend, since, scale=scale)

    # -- the fleet's nights --------------------------------------------------------------------
    def night_ratios(self, nights: Sequence[str]) -> list[NightRatio]:
        """The worst recorded zeta/epsilon per asset and night, for the nights given
        (``YYYY-MM-DD``; see :func:`registry.fleet_nights.night_ratios`)."""
        return fleet_nights.night_ratios(self._backend, nights)

    def latest_night(self) -> str | None:
        """The latest night (``YYYY-MM-DD``) with a recorded candidate window or a published
        fleet-level run; None when there is neither."""
        return fleet_nights.latest_night(self._backend)

    def published_nights(self) -> dict[str, str]:
        """Every night published with :meth:`publish_night`: night -> its fleet-level run."""
        return fleet_nights.published_nights(self._backend)

    def night_statuses(self, runs: Mapping[str, str]) -> dict[str, dict]:
        """The statuses published with each night's fleet-level run given (night -> run, as
        :meth:`published_nights` returns; night -> document); nights without are left out."""
        return fleet_nights.night_statuses(self._backend, runs)

    def night_file(self, run_id: str, name: str) -> dict | None:
        """The JSON file ``name`` published with a night's fleet-level run (None if absent)."""
        return fleet_nights.run_document(self._backend, run_id, name)

    def publish_night(self, night: str, statuses: Mapping, files: Mapping[str, bytes],
                      metrics: Mapping[str, float] | None = None) -> str:
        """Publish the night's ``statuses`` (a JSON document), ``files`` (name -> content)
        and ``metrics`` with its fleet-level run, created once per night (a rerun replaces
        the files); returns the run's id."""
        return fleet_nights.publish_night(self._backend, night, statuses, files, metrics)

    # -- the store -----------------------------------------------------------------------------
    def probe_read(self) -> None:
        """Read the store once (``fleet-health check``); the registry's error if it cannot."""
        probe.probe_read(self._backend)

    def probe_write(self) -> str:
        """Write a probe run (a tag and an artifact), read it back and delete it; returns the
        probe's experiment (see :mod:`registry.store.probe`). Raises ``OSError`` when what was
        written does not read back."""
        return probe.probe_write(self._backend)
