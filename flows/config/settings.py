"""The settings of ``fleet.toml`` as frozen dataclasses; their field defaults are the
configuration's defaults (the parser and the rendered template read them from here)."""
from __future__ import annotations

import dataclasses
import fnmatch
import os
import pathlib
from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from graybox.calibration import DEFAULT_FALSE_ALARM_RATE
from graybox.models import load_model
from graybox.severity import SeverityScale
from registry import resolve_store
from flows.errors import ConfigError

DEFAULT_CONFIG = "fleet.toml"
DEFAULT_TELEMETRY_ROOT = "telemetry"
DEFAULT_TRACKING_URI = "sqlite:///mlflow.db"
PLOT_POLICIES = ("alarms", "all", "none")
#: how a flow runs its batch tasks: one after another in its process, or on a Dask cluster
TASK_RUNNERS = ("sequential", "dask")
#: ``[nightly] processes = "auto"`` takes at most this many cores
MAX_AUTO_PROCESSES = 4
#: ``[nightly] processes = "auto"`` starts a pool for a run of at least this many assets: two
#: full chunks (:data:`flows.pooled_execute.MAX_CHUNK`); below it the pool's start (its
#: forkserver's imports, about 3 s of CPU) costs about what its second core gains
AUTO_POOL_MIN_ASSETS = 64

#: peak resident size a batch task may reach (bytes): assets are fitted in groups within it
DEFAULT_MEMORY_BUDGET = 4 * 10 ** 9


#: a class's ``not_operating_after`` that takes the fleet's, ``[alerts] not_operating_after``
FROM_ALERTS = "alerts"


@dataclass(frozen=True)
class VehicleClass:
    """One ``[classes.<name>]`` table.

    Attributes
    ----------
    name : str
    model : str
        ``package.module:ClassName`` of the physics model, or ``fmu:`` and the absolute path
        of an FMU file (fleet.toml's relative path resolved against its directory).
    parameters : dict
        Overrides of the model's ``default_parameters``.
    assets : tuple of str
        Asset ids or glob patterns (``fnmatch``).
    columns : dict
        Model variable -> telemetry column.
    settings : GrayBoxSettings
        The method's settings for new baselines of this class (candidates always use their
        baseline's own settings).
    grid : GridPolicy
        How telemetry is checked and put on a grid.
    estimate : tuple of str
        White-box parameters each new baseline fits to its asset's healthy windows first
        (``graybox.FitRequest.estimate``); default none.
    not_operating_after : str or None
        How long the class's assets may not operate before they are ``dormant`` (a duration,
        None: never); :data:`FROM_ALERTS`, the default: ``[alerts] not_operating_after``.
    """

    name: str
    model: str
    parameters: dict
    assets: tuple[str, ...]
    columns: dict
    settings: Any
    grid: Any
    estimate: tuple[str, ...] = ()
    not_operating_after: str | None = FROM_ALERTS

    def load_model(self):
        """The class's physics model (a :class:`graybox.models.WhiteBoxModel`)."""
        return load_model(self.model, self.parameters, self.columns)

    def matches(self, asset_id: str) -> bool:
        """Whether an asset id is one of the class's ids or matches one of its patterns."""
        return any(fnmatch.fnmatchcase(asset_id, pattern) for pattern in self.assets)

    def explicit_assets(self) -> tuple[str, ...]:
        """The entries of ``assets`` that are plain ids (no glob characters)."""
        return tuple(a for a in self.assets if not any(c in a for c in "*?[]!"))


@dataclass(frozen=True)
class AlertSettings:
    false_alarm_rate: float = DEFAULT_FALSE_ALARM_RATE
    jsonl: pathlib.Path = pathlib.Path("alerts.jsonl")
    major_ratio: float = SeverityScale.major_ratio
    critical_ratio: float = SeverityScale.critical_ratio
    #: an asset whose newest telemetry is older than as-of minus this is stale (None: off)
    stale_after: str | None = "2D"
    #: an asset not operating (every new night too calm to monitor) whose last operating
    #: night ended more than this before as-of is dormant (None: off)
    not_operating_after: str | None = "7D"

    @property
    def scale(self) -> SeverityScale:
        """The alerts' severity scale (``major_ratio``, ``critical_ratio``)."""
        return SeverityScale(self.major_ratio, self.critical_ratio)

    @property
    def stale_after_delta(self) -> pd.Timedelta | None:
        return None if self.stale_after is None else pd.Timedelta(self.stale_after)

    @property
    def not_operating_after_delta(self) -> pd.Timedelta | None:
        return (None if self.not_operating_after is None
                else pd.Timedelta(self.not_operating_after))


@dataclass(frozen=True)
class NightlySettings:
    batch_size: int = 64
    window: str = "1D"
    plots: str = "alarms"
    retries: int = 2
    retry_delay_seconds: float = 30.0
    memory_budget: int = DEFAULT_MEMORY_BUDGET
    #: how far before the watermark a run looks for late-arriving windows ("0D": not at all)
    lookback: str = "7D"
    task_runner: str = "sequential"
    #: nightly windows each candidate is fitted on: the night and the N - 1 before it
    candidate_nights: int = 2
    #: processes computing a night's candidates beside the flow's (``"auto"``: one per core,
    #: at most :data:`MAX_AUTO_PROCESSES`, for a run of :data:`AUTO_POOL_MIN_ASSETS` assets
    #: or more; 1: all in the flow's own process)
    processes: int | str = "auto"

    @property
    def window_delta(self) -> pd.Timedelta:
        return pd.Timedelta(self.window)

    @property
    def lookback_delta(self) -> pd.Timedelta:
        return pd.Timedelta(self.lookback)

    def process_count(self, cores: int | None = None, assets: int | None = None) -> int:
        """The processes of ``processes``: an integer as it is, ``"auto"`` the usable
        cores (``cores``, default this process's CPU affinity) up to
        :data:`MAX_AUTO_PROCESSES`; 1 (the flow's own process only) on one core or for a
        run of fewer than :data:`AUTO_POOL_MIN_ASSETS` ``assets`` (None: not known)."""
        if self.processes != "auto":
            return int(self.processes)
        if assets is not None and assets < AUTO_POOL_MIN_ASSETS:
            return 1
        if cores is None:
            cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") \
                else (os.cpu_count() or 1)
        return max(1, min(cores, MAX_AUTO_PROCESSES))


@dataclass(frozen=True)
class DaskSettings:
    """``[dask]``: where batch tasks run when ``[nightly] task_runner = "dask"``.

    Attributes
    ----------
    address : str or None
        An existing scheduler (``"tcp://host:8786"``); None starts a ``LocalCluster`` for
        the run.
    workers : int or None
        Worker processes of that LocalCluster (None: one per core).
    threads_per_worker : int
        Threads per worker process: batches running at once in one process.
    """

    address: str | None = None
    workers: int | None = None
    threads_per_worker: int = 1


@dataclass(frozen=True)
class ScheduleSettings:
    cron: str = "30 2 * * *"
    timezone: str = "UTC"


@dataclass(frozen=True)
class NotificationSettings:
    block: str | None = None


@dataclass(frozen=True)
class FleetConfig:
    """The whole ``fleet.toml``, with paths resolved against the file's directory.

    Attributes
    ----------
    path : pathlib.Path
        The file (absolute).
    telemetry_root : pathlib.Path
    tracking_uri : str
        Absolute for SQLite stores.
    classes : dict of str to VehicleClass
        In file order.
    alerts, nightly, schedule, notifications, dask
        The optional tables, with defaults.
    """

    path: pathlib.Path
    telemetry_root: pathlib.Path
    tracking_uri: str
    classes: dict[str, VehicleClass]
    alerts: AlertSettings = field(default_factory=AlertSettings)
    nightly: NightlySettings = field(default_factory=NightlySettings)
    schedule: ScheduleSettings = field(default_factory=ScheduleSettings)
    notifications: NotificationSettings = field(default_factory=NotificationSettings)
    dask: DaskSettings = field(default_factory=DaskSettings)

    @property
    def base_dir(self) -> pathlib.Path:
        return self.path.parent

    def with_tracking_uri(self, tracking_uri: str | None) -> "FleetConfig":
        """A copy using another tracking URI (``--tracking-uri``); None keeps this one."""
        if not tracking_uri:
            return self
        return dataclasses.replace(self, tracking_uri=resolve_tracking_uri(tracking_uri,
                                                                           pathlib.Path.cwd()))

    def class_of(self, asset_id: str) -> VehicleClass | None:
        """The vehicle class whose ``assets`` match the id (None if none does).

        Raises
        ------
        ConfigError
            If two classes claim the asset.
        """
        found = [c for c in self.classes.values() if c.matches(asset_id)]
        if len(found) > 1:
            raise ConfigError(f"{self.path.name}: classes: asset {asset_id!r} matches more than "
                              f"one vehicle class ({', '.join(c.name for c in found)}); make the "
                              f"'assets' patterns disjoint")
        return found[0] if found else None

    def registry(self):
        """A :class:`registry.Registry` on this configuration's store."""
        # mlflow loads on first use: a bad configuration or --help must not import it
        from registry import Registry

        return Registry(self.tracking_uri, workdir=self.base_dir)


def resolve_tracking_uri(uri: str, base: pathlib.Path) -> str:
    """Make a relative ``sqlite:///`` path absolute against ``base``; other URIs unchanged."""
    return resolve_store(uri, base).tracking_uri
