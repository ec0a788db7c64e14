"""What a run reports: per window, per asset, per run; and how errors are described.

Statuses of an asset in a run:

``ok``            every pending window processed and committed
``failed``        stopped by an error (its ``error`` says why, with file and row for bad
                  telemetry); windows before the error are committed, the rest wait
``no baseline``   nothing to compare with yet: fit and promote a baseline (skipped, not a
                  failure)
``up to date``    no new whole window since the watermark
``not operating`` new windows arrived, but none ran long enough to monitor (each was too
                  short to read or to fit: a calm turbine, a parked vehicle): not monitored,
                  named with its windows; the watermark moves past them and the exit status
                  stays 0 (the plant gave nothing to monitor, no part of the run failed)
``dormant``       ``not operating``, and its last monitored night (or its baseline, when none
                  since) ended longer than ``[alerts] not_operating_after`` before the run's
                  as-of time: not monitored, exit status 1; its note says since when, the
                  limit, and what to check (out of service? the class's grid too strict?)
``no telemetry``  listed in fleet.toml or on the command line but no data in the store
``stale``         its newest telemetry is older than ``[alerts] stale_after`` before the
                  run's as-of time (a ``stale`` alert is raised): not monitored, exit status 1
``unusable baseline``  the version to compare with cannot be used (no calibration, artifacts
                  that fail verification, another model than the configured one): not
                  monitored, exit status 1; its note names the version and the fix

Every status but ``ok`` and ``up to date`` means an asset that should be monitored was not:
:class:`Coverage` counts and names them, and the run's exit status is then 1, except for
``not operating`` (which escalates to ``dormant`` once it lasts).
"""
from __future__ import annotations

import errno
import logging
from dataclasses import asdict, dataclass, field

import pandas as pd

from graybox.exceptions import GrayBoxError, TelemetryError
from graybox.alert import Alert
from flows.terminal import EXIT_FAILED, EXIT_OK
from registry import RegistryError, TransientStoreError
from flows.errors import AssetsNotMonitored, TransientError

logger = logging.getLogger(__name__)

OK, FAILED, NO_BASELINE, UP_TO_DATE, NO_TELEMETRY = (
    "ok", "failed", "no baseline", "up to date", "no telemetry")
STALE = "stale"
UNUSABLE_BASELINE = "unusable baseline"
NOT_OPERATING = "not operating"
DORMANT = "dormant"
STATUSES = (OK, FAILED, NO_BASELINE, UP_TO_DATE, NO_TELEMETRY, STALE, UNUSABLE_BASELINE,
            NOT_OPERATING, DORMANT)
#: statuses of an asset that was monitored this run (checked against its baseline)
MONITORED = (OK, UP_TO_DATE)
#: statuses that leave the run's exit status 0: monitored, or nothing there to monitor
SETTLED = (*MONITORED, NOT_OPERATING)


@dataclass
class ErrorInfo:
    """Why an asset failed: the message, and for bad telemetry its kind, file and row."""

    message: str
    type: str
    kind: str | None = None
    file: str | None = None
    row: int | None = None
    window_start: str | None = None

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict | None) -> "ErrorInfo | None":
        return None if data is None else cls(**data)


def describe_error(error: BaseException, window_start=None) -> ErrorInfo:
    """An :class:`ErrorInfo` for an exception (TelemetryError keeps kind, file and row)."""
    start = None if window_start is None else pd.Timestamp(window_start).isoformat()
    if isinstance(error, TelemetryError):
        return ErrorInfo(str(error), type(error).__name__, error.kind, error.file, error.row,
                         start)
    text = str(error) or type(error).__name__
    return ErrorInfo(text, type(error).__name__, None, None, None, start)


def is_transient(error: BaseException) -> bool:
    """Whether retrying could help: the registry or a file system was briefly unavailable.

    Data and configuration errors (GrayBoxError, RegistryError, ConfigError, ValueError) are
    never transient; neither are missing files or permissions. Whether the tracking store's
    failure is a passing one, the registry says: it raises
    :class:`~registry.exceptions.TransientStoreError` for those (:mod:`registry.store.boundary`).
    """
    if isinstance(error, (TransientError, TransientStoreError)):
        return True
    if isinstance(error, (GrayBoxError, RegistryError, ValueError, TypeError, KeyError)):
        return False
    if isinstance(error, (ConnectionError, TimeoutError)):
        return True
    if isinstance(error, OSError):
        return error.errno not in (errno.ENOENT, errno.EACCES, errno.EPERM, errno.EISDIR,
                                   errno.ENOTDIR, errno.EROFS)
    return False


@dataclass
class WindowResult:
    """One committed window of an asset.

    ``max_ratio`` is the window's largest zeta / epsilon and ``max_ratio_at`` where it is
    (``"temp nonlinear"``: channel and tier), so that a night below every threshold still
    says which tier came nearest; ``conditions``, for a window driven beyond every baseline
    day's input conditions, the input figure farthest outside with the baseline days' range
    (``Drift.conditions``), alarmed or not: its changes were discounted for it.
    """

    window_start: str
    window_end: str
    version: int | None
    run_id: str
    alarm: bool
    max_ratio: float | None
    created: bool
    max_ratio_at: str | None = None
    conditions: str | None = None

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class AssetResult:
    """One asset's outcome in a run."""

    asset_id: str
    vehicle_class: str
    status: str
    windows: list[WindowResult] = field(default_factory=list)
    watermark_before: str | None = None
    watermark_after: str | None = None
    baseline_version: int | None = None
    error: ErrorInfo | None = None
    alerts: list[Alert] = field(default_factory=list)
    note: str | None = None
    #: every window that failed, in the order met (``error`` is the first of them or the
    #: asset's own error): a reanalysis goes on past a failed window, and each one is named
    window_errors: list[ErrorInfo] = field(default_factory=list)

    @property
    def failed(self) -> bool:
        return self.status == FAILED

    def to_dict(self) -> dict:
        data = asdict(self)
        data["error"] = None if self.error is None else self.error.to_dict()
        data["alerts"] = [alert.to_dict() for alert in self.alerts]
        data["window_errors"] = [error.to_dict() for error in self.window_errors]
        return data

    @classmethod
    def from_dict(cls, data: dict) -> "AssetResult":
        data = dict(data)
        data["windows"] = [WindowResult(**w) for w in data.get("windows", [])]
        data["error"] = ErrorInfo.from_dict(data.get("error"))
        data["alerts"] = [Alert.from_dict(a) for a in data.get("alerts", [])]
        data["window_errors"] = [ErrorInfo.from_dict(e) for e in data.get("window_errors", [])]
        return cls(**data)

    def reason(self) -> str:
        """One line: why it failed, or its note."""
        if self.error is not None:
            return self.error.message
        return self.note or ""


@dataclass
class RunSummary:
    """A run of a flow over the fleet (``nightly``, ``baseline`` or ``reanalyze``)."""

    flow: str
    started: str
    finished: str | None = None
    as_of: str | None = None
    assets: list[AssetResult] = field(default_factory=list)
    unmatched: list[str] = field(default_factory=list)
    config: str | None = None
    tracking_uri: str | None = None
    flow_run_id: str | None = None
    extra: dict = field(default_factory=dict)
    #: entries of the telemetry root not read: {"path", "reason"} (see flows.discovery)
    skipped: list[dict] = field(default_factory=list)

    @property
    def failed(self) -> list[AssetResult]:
        return [a for a in self.assets if a.failed]

    @property
    def alerts(self) -> list[Alert]:
        """Every asset's alerts, in asset order."""
        return [alert for a in self.assets for alert in a.alerts]

    @property
    def coverage(self) -> "Coverage":
        return Coverage.of(self.flow, self.assets)

    @property
    def exit_status(self) -> int:
        """0 when every asset was processed (or had nothing to do, or did not operate enough
        to monitor), 1 when one that should be monitored was not (failed, stale, no
        baseline, unusable baseline, no telemetry, dormant)."""
        return EXIT_OK if all(a.status in SETTLED for a in self.assets) else EXIT_FAILED

    def counts(self) -> dict[str, int]:
        out = {status: 0 for status in STATUSES}
        for a in self.assets:
            out[a.status] = out.get(a.status, 0) + 1
        return out

    def to_dict(self) -> dict:
        return {"flow": self.flow, "started": self.started, "finished": self.finished,
                "as_of": self.as_of, "config": self.config, "tracking_uri": self.tracking_uri,
                "flow_run_id": self.flow_run_id, "exit_status": self.exit_status,
                "counts": self.counts(), "coverage": self.coverage.to_dict(),
                "unmatched_assets": list(self.unmatched),
                "skipped": [dict(s) for s in self.skipped],
                "assets": [a.to_dict() for a in self.assets],
                "alerts": [alert.to_dict() for alert in self.alerts],
                **({"extra": self.extra} if self.extra else {})}

    @classmethod
    def from_dict(cls, data: dict) -> "RunSummary":
        return cls(flow=data["flow"], started=data["started"], finished=data.get("finished"),
                   as_of=data.get("as_of"),
                   assets=[AssetResult.from_dict(a) for a in data.get("assets", [])],
                   unmatched=list(data.get("unmatched_assets", [])), config=data.get("config"),
                   tracking_uri=data.get("tracking_uri"), flow_run_id=data.get("flow_run_id"),
                   extra=dict(data.get("extra", {})),
                   skipped=[dict(s) for s in data.get("skipped", [])])


@dataclass(frozen=True)
class Coverage:
    """How much of the fleet a run covered: every asset it should have monitored, by outcome.

    Attributes
    ----------
    flow : str
        ``nightly``, ``baseline`` or ``reanalyze`` (the baseline flow counts fits).
    assets : int
        Assets that should be monitored (the discovered fleet and the listed assets).
    up_to_date : int
        Monitored: processed up to date against their baseline (``ok`` or ``up to date``).
    stale, no_baseline, unusable_baseline, failed, no_telemetry, not_operating, dormant : int
        Not monitored, by reason (``not_operating``: it ran too little to monitor, which
        alone leaves the exit status 0; ``dormant``: the same for longer than ``[alerts]
        not_operating_after``, which does not).
    missed : tuple of str
        The assets not monitored, in the run's order.
    """

    flow: str
    assets: int
    up_to_date: int
    stale: int
    no_baseline: int
    unusable_baseline: int
    failed: int
    no_telemetry: int
    not_operating: int
    dormant: int
    missed: tuple[str, ...]

    @classmethod
    def of(cls, flow: str, assets: list[AssetResult]) -> "Coverage":
        def n(status: str) -> int:
            return sum(1 for a in assets if a.status == status)
        return cls(flow, len(assets), sum(1 for a in assets if a.status in MONITORED),
                   n(STALE), n(NO_BASELINE), n(UNUSABLE_BASELINE), n(FAILED), n(NO_TELEMETRY),
                   n(NOT_OPERATING), n(DORMANT),
                   tuple(a.asset_id for a in assets if a.status not in MONITORED))

    @property
    def complete(self) -> bool:
        """Whether every asset that should be monitored was."""
        return self.up_to_date == self.assets

    def to_dict(self) -> dict:
        data = asdict(self)
        data["missed"] = list(self.missed)
        data["complete"] = self.complete
        return data

    def line(self) -> str:
        """One honest line, e.g. ``8 assets: 5 monitored and up to date; not monitored: 1
        stale, 2 without baseline (T-7, T-8)``."""
        done, not_done = {"baseline": ("fitted", "not fitted"),
                          "reanalyze": ("reanalysed", "not reanalysed")}.get(
            self.flow, ("monitored and up to date", "not monitored"))
        missing = [(self.failed, "failed"), (self.stale, "stale"),
                   (self.no_baseline, "without baseline"),
                   (self.unusable_baseline, "with an unusable baseline"),
                   (self.no_telemetry, "without telemetry"),
                   (self.not_operating, "not operating"), (self.dormant, "dormant")]
        text = (f"{self.assets} asset{'' if self.assets == 1 else 's'}: "
                f"{self.up_to_date} {done}")
        parts = [f"{count} {what}" for count, what in missing if count]
        if parts:
            names = ", ".join(self.missed[:10]) + (", ..." if len(self.missed) > 10 else "")
            text += f"; {not_done}: {', '.join(parts)} ({names})"
        return text + "."


def now_iso() -> str:
    return pd.Timestamp.now(tz="UTC").isoformat(timespec="seconds")


def run_summary(state) -> dict | BaseException:
    """What a finished flow state holds: the run summary as a dict (its result, or for a run
    that left assets unmonitored, the summary its :class:`~flows.errors.AssetsNotMonitored`
    carries), or the exception that failed the run.

    Parameters
    ----------
    state : prefect.State
        From a flow called with ``return_state=True``.
    """
    data = state.result(raise_on_failure=False)
    return data.summary if isinstance(data, AssetsNotMonitored) else data


def state_summary(state) -> RunSummary:
    """The :class:`RunSummary` a finished flow state holds (see :func:`run_summary`), or raise
    the error that failed the run."""
    data = run_summary(state)
    if isinstance(data, BaseException):
        raise data
    if not isinstance(data, dict):
        raise RuntimeError(f"the flow run ended {state.name}: {state.message}")
    return RunSummary.from_dict(data)
