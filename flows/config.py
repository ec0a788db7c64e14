"""``fleet.toml``: the fleet's configuration, loaded and checked with errors that name the key.

Layout (every key and its default: docs/design.md section 3.3; every table but
``[classes.*]`` is optional)::

    [telemetry]
    root = "telemetry"                     # hive-partitioned Parquet (relative to this file)

    [mlflow]
    tracking_uri = "sqlite:///mlflow.db"   # relative SQLite paths resolve against this file

    [alerts]
    false_alarm_rate = 0.01                # per asset-night; sets epsilon at baseline fitting
    jsonl = "alerts.jsonl"                 # every alert, one JSON object per line
    major_ratio = 2.0                      # zeta/epsilon from which an alert is "major"
    critical_ratio = 5.0                   # ... and "critical" (above 1: "minor")

    [nightly]
    batch_size = 64                        # assets per Prefect task (one batched network fit)
    window = "1D"                          # nightly window; must divide a day
    plots = "alarms"                       # candidates' plots: "alarms", "all" or "none"
    retries = 2                            # retries of a batch after a transient error
    retry_delay_seconds = 30
    memory_budget = "4GB"                  # peak memory of a batch: assets fitted in groups

    [schedule]
    cron = "30 2 * * *"                    # the nightly deployment's schedule
    timezone = "UTC"

    [notifications]
    block = "slack-webhook/fleet-health"   # optional Prefect notification block

    [classes.turbine]                      # one table per vehicle class
    model = "graybox.models:GasTurbineShaft"
    parameters = { inertia = 45.0 }        # overrides of the model's default_parameters
    assets = ["T-*"]                       # ids or glob patterns
    columns = { omega = "shaft_speed" }    # model variable -> telemetry column
    settings = { hidden_units = 8 }        # overrides of graybox GrayBoxSettings
    grid = { max_gap = "4min", stuck_after = "10min", min_duration = "1h" }
                                           # overrides of graybox GridPolicy: durations

Every error is a :class:`ConfigError` whose message starts with the file and the dotted key,
e.g. ``fleet.toml: classes.turbine.model: ...``.
"""
from __future__ import annotations

import dataclasses
import fnmatch
import json
import math
import os
import pathlib
import re
import tomllib
from dataclasses import dataclass, field
from typing import Any, Mapping

import pandas as pd

from flows.memory import parse_bytes

DEFAULT_CONFIG = "fleet.toml"
DEFAULT_TRACKING_URI = "sqlite:///mlflow.db"
PLOT_POLICIES = ("alarms", "all", "none")
_CLASS_NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")
_CRON_FIELD = re.compile(r"[0-9A-Za-z*/,?LW#-]+")
_ID_OR_GLOB = re.compile(r"[A-Za-z0-9_.*?\[\]!-]{1,64}")


#: peak resident size a batch task may reach (bytes): assets are fitted in groups within it
DEFAULT_MEMORY_BUDGET = 4 * 10 ** 9

#: method settings that counted samples, and the settings in seconds that replaced them
RENAMED_SETTINGS = {"max_ar_order": "ar_span", "max_delay": "delay_span"}


class ConfigError(ValueError):
    """``fleet.toml`` is missing, unreadable or wrong; the message names the file and key."""


@dataclass(frozen=True)
class VehicleClass:
    """One ``[classes.<name>]`` table.

    Attributes
    ----------
    name : str
    model : str
        ``package.module:ClassName`` of the physics model.
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
    """

    name: str
    model: str
    parameters: dict
    assets: tuple[str, ...]
    columns: dict
    settings: Any
    grid: Any

    def load_model(self):
        """The class's physics model (a :class:`graybox.models.WhiteBoxModel`)."""
        from graybox.models import load_model

        return load_model(self.model, self.parameters, self.columns)

    def matches(self, asset_id: str) -> bool:
        """Whether an asset id is one of the class's ids or matches one of its patterns."""
        return any(fnmatch.fnmatchcase(asset_id, pattern) for pattern in self.assets)

    def explicit_assets(self) -> tuple[str, ...]:
        """The entries of ``assets`` that are plain ids (no glob characters)."""
        return tuple(a for a in self.assets if not any(c in a for c in "*?[]!"))


@dataclass(frozen=True)
class AlertSettings:
    false_alarm_rate: float = 0.01
    jsonl: pathlib.Path = pathlib.Path("alerts.jsonl")
    major_ratio: float = 2.0
    critical_ratio: float = 5.0


@dataclass(frozen=True)
class NightlySettings:
    batch_size: int = 64
    window: str = "1D"
    plots: str = "alarms"
    retries: int = 2
    retry_delay_seconds: float = 30.0
    memory_budget: int = DEFAULT_MEMORY_BUDGET

    @property
    def window_delta(self) -> pd.Timedelta:
        return pd.Timedelta(self.window)


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
    alerts, nightly, schedule, notifications
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
        from registry import Registry

        return Registry(self.tracking_uri, workdir=self.base_dir)


# -- loading --------------------------------------------------------------------------------

def load_config(path: str | os.PathLike = DEFAULT_CONFIG) -> FleetConfig:
    """Read and check a ``fleet.toml``.

    Parameters
    ----------
    path : path-like, default ``"fleet.toml"``

    Returns
    -------
    FleetConfig

    Raises
    ------
    ConfigError
        If the file is missing or unreadable, is not TOML, or a key is unknown, missing or
        has a bad value; the message names the file and the dotted key.
    """
    path = pathlib.Path(path).expanduser()
    try:
        text = path.read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such configuration file (pass --config PATH; "
                          f"`fleet-health demo` writes an example)") from None
    except OSError as error:
        raise ConfigError(f"{path}: cannot read: {error.strerror or error}") from None
    try:
        data = tomllib.loads(text.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise ConfigError(f"{path}: not valid TOML: {error}") from None
    return parse_config(data, path.resolve())


def parse_config(data: Mapping[str, Any], path: pathlib.Path) -> FleetConfig:
    """Check a parsed ``fleet.toml`` (see :func:`load_config`)."""
    path = pathlib.Path(path)
    check = _Checker(path.name)
    base = path.parent
    check.keys("", data, ("telemetry", "mlflow", "alerts", "nightly", "schedule",
                          "notifications", "classes"))

    telemetry = check.table("telemetry", data.get("telemetry", {}))
    check.keys("telemetry", telemetry, ("root",))
    root = base / check.string("telemetry.root", telemetry.get("root", "telemetry"))

    mlflow = check.table("mlflow", data.get("mlflow", {}))
    check.keys("mlflow", mlflow, ("tracking_uri",))
    uri = check.string("mlflow.tracking_uri", mlflow.get("tracking_uri", DEFAULT_TRACKING_URI))
    try:
        uri = resolve_tracking_uri(uri, base)
    except ValueError as error:
        raise check.error("mlflow.tracking_uri", str(error)) from None

    alerts = _alerts(check, check.table("alerts", data.get("alerts", {})), base)
    nightly = _nightly(check, check.table("nightly", data.get("nightly", {})))
    schedule = _schedule(check, check.table("schedule", data.get("schedule", {})))
    notes = check.table("notifications", data.get("notifications", {}))
    check.keys("notifications", notes, ("block",))
    block = notes.get("block")
    if block is not None:
        block = check.string("notifications.block", block)
        if "/" not in block:
            raise check.error("notifications.block", f"{block!r} is not a block slug "
                                                     f"'<block-type>/<name>' "
                                                     f"(e.g. 'slack-webhook/fleet-health')")

    classes_table = check.table("classes", data.get("classes"), required=True)
    if not classes_table:
        raise check.error("classes", "define at least one vehicle class, e.g. [classes.turbine]")
    classes = {name: _vehicle_class(check, name, check.table(f"classes.{name}", table))
               for name, table in classes_table.items()}
    return FleetConfig(path=path, telemetry_root=root.resolve(), tracking_uri=uri,
                       classes=classes, alerts=alerts, nightly=nightly, schedule=schedule,
                       notifications=NotificationSettings(block))


def resolve_tracking_uri(uri: str, base: pathlib.Path) -> str:
    """Make a relative ``sqlite:///`` path absolute against ``base``; other URIs unchanged."""
    from registry.store import resolve_store

    return resolve_store(uri, base).tracking_uri


def _alerts(check: "_Checker", table: Mapping, base: pathlib.Path) -> AlertSettings:
    check.keys("alerts", table, ("false_alarm_rate", "jsonl", "major_ratio", "critical_ratio"))
    rate = check.number("alerts.false_alarm_rate", table.get("false_alarm_rate", 0.01))
    if not 0 < rate < 1:
        raise check.error("alerts.false_alarm_rate",
                          f"must be in (0, 1) (false alarms per asset-night), got {rate!r}")
    jsonl = base / check.string("alerts.jsonl", table.get("jsonl", "alerts.jsonl"))
    major = check.number("alerts.major_ratio", table.get("major_ratio", 2.0))
    critical = check.number("alerts.critical_ratio", table.get("critical_ratio", 5.0))
    if not 1 <= major <= critical:
        raise check.error("alerts", f"need 1 <= major_ratio <= critical_ratio, got "
                                    f"major_ratio={major!r}, critical_ratio={critical!r}")
    return AlertSettings(rate, jsonl.resolve(), major, critical)


def _nightly(check: "_Checker", table: Mapping) -> NightlySettings:
    check.keys("nightly", table, ("batch_size", "window", "plots", "retries",
                                  "retry_delay_seconds", "memory_budget"))
    batch = check.integer("nightly.batch_size", table.get("batch_size", 64), low=1)
    window = check.string("nightly.window", table.get("window", "1D"))
    try:
        delta = pd.Timedelta(window)
    except (ValueError, TypeError):
        raise check.error("nightly.window", f"{window!r} is not a duration such as '1D' or "
                                            f"'6h'") from None
    day = pd.Timedelta(days=1)
    if delta < pd.Timedelta(hours=1) or delta > day or (day % delta) != pd.Timedelta(0):
        raise check.error("nightly.window", f"{window!r} must divide a day and be at least "
                                            f"1 hour (e.g. '1D', '12h', '6h')")
    plots = check.string("nightly.plots", table.get("plots", "alarms"))
    if plots not in PLOT_POLICIES:
        raise check.error("nightly.plots", f"must be one of {', '.join(PLOT_POLICIES)}, "
                                           f"got {plots!r}")
    retries = check.integer("nightly.retries", table.get("retries", 2), low=0)
    delay = check.number("nightly.retry_delay_seconds", table.get("retry_delay_seconds", 30.0))
    if delay < 0:
        raise check.error("nightly.retry_delay_seconds", f"must be >= 0, got {delay!r}")
    try:
        budget = parse_bytes(table.get("memory_budget", DEFAULT_MEMORY_BUDGET))
    except ValueError as error:
        raise check.error("nightly.memory_budget", str(error)) from None
    return NightlySettings(batch, window, plots, retries, delay, budget)


def _schedule(check: "_Checker", table: Mapping) -> ScheduleSettings:
    check.keys("schedule", table, ("cron", "timezone"))
    cron = check.string("schedule.cron", table.get("cron", "30 2 * * *"))
    if len(cron.split()) != 5:
        raise check.error("schedule.cron", f"{cron!r} is not a 5-field cron expression "
                                           f"(minute hour day month weekday)")
    for part in cron.split():
        if _CRON_FIELD.fullmatch(part) is None:
            raise check.error("schedule.cron", f"{cron!r}: field {part!r} is not a cron field")
    timezone = check.string("schedule.timezone", table.get("timezone", "UTC"))
    try:
        import zoneinfo

        zoneinfo.ZoneInfo(timezone)
    except (zoneinfo.ZoneInfoNotFoundError, ValueError):
        raise check.error("schedule.timezone", f"unknown time zone {timezone!r}") from None
    return ScheduleSettings(cron, timezone)


def _vehicle_class(check: "_Checker", name: str, table: Mapping) -> VehicleClass:
    from graybox.estimator import GrayBoxSettings
    from graybox.exceptions import ModelSpecError
    from graybox.models import load_model
    from graybox.nonlinear_tier import FitSettings

    key = f"classes.{name}"
    if _CLASS_NAME.fullmatch(name) is None or name in (".", ".."):
        raise check.error(key, "a vehicle class name must match [A-Za-z0-9_.-]{1,64}")
    check.keys(key, table, ("model", "parameters", "assets", "columns", "settings", "grid"))
    if "model" not in table:
        raise check.error(f"{key}.model", "missing: name the physics model, e.g. "
                                          "\"graybox.models:GasTurbineShaft\"")
    model = check.string(f"{key}.model", table["model"])
    parameters = check.table(f"{key}.parameters", table.get("parameters", {}))
    for pname, value in parameters.items():
        check.number(f"{key}.parameters.{pname}", value)
    columns = check.table(f"{key}.columns", table.get("columns", {}))
    for cname, value in columns.items():
        check.string(f"{key}.columns.{cname}", value)
    if "assets" not in table:
        raise check.error(f"{key}.assets", "missing: list the class's asset ids or glob "
                                           "patterns, e.g. [\"T-*\"]")
    assets = table["assets"]
    if isinstance(assets, str):
        assets = [assets]
    if not isinstance(assets, list) or not assets:
        raise check.error(f"{key}.assets", f"must be a non-empty list of asset ids or glob "
                                           f"patterns, got {assets!r}")
    for i, pattern in enumerate(assets):
        if not isinstance(pattern, str) or _ID_OR_GLOB.fullmatch(pattern) is None:
            raise check.error(f"{key}.assets[{i}]", f"{pattern!r} is neither an asset id "
                                                    f"([A-Za-z0-9_.-]) nor a glob pattern of one")
    # the model must load with these parameters and columns (errors name the key)
    try:
        load_model(model, dict(parameters), dict(columns))
    except ModelSpecError as error:
        message = str(error)
        where = f"{key}.model"
        if "parameter" in message:
            where = f"{key}.parameters"
        elif "column" in message:
            where = f"{key}.columns"
        raise check.error(where, message) from None

    overrides = dict(check.table(f"{key}.settings", table.get("settings", {})))
    for old, new in RENAMED_SETTINGS.items():
        if old in overrides:
            raise check.error(f"{key}.settings.{old}", f"replaced by {new}, in seconds so that it "
                                                       f"holds at every sample rate (e.g. "
                                                       f"{new} = 200.0)")
    check.fields(f"{key}.settings", overrides, GrayBoxSettings)
    if "network" in overrides:
        network = check.table(f"{key}.settings.network", overrides["network"])
        check.fields(f"{key}.settings.network", network, FitSettings)
        overrides["network"] = check.build(f"{key}.settings.network", FitSettings, network)
    settings = check.build(f"{key}.settings",
                           lambda **values: dataclasses.replace(GrayBoxSettings(), **values),
                           overrides)

    grid = _grid(check, f"{key}.grid", check.table(f"{key}.grid", table.get("grid", {})))
    return VehicleClass(name, model, dict(parameters), tuple(assets), dict(columns), settings,
                        grid)


# GridPolicy keys counted in samples before its limits became durations
_OLD_GRID_KEYS = {
    "max_fill": ("max_gap", 'max_gap = "40s"', "the longest time between two rows that is "
                 "filled by interpolation (max_fill = 3 at 10 s samples is 40 s)"),
    "stuck_samples": ("stuck_after", 'stuck_after = "10min"', "how long a sensor may hold one "
                      "value (stuck_samples = 60 at 10 s samples is 10 minutes)"),
    "min_samples": ("min_duration", 'min_duration = "1h"', "the least time a window must "
                    "cover (min_samples = 500 at 10 s samples is about 83 minutes)"),
}


def _grid(check: "_Checker", key: str, table: Mapping):
    """The ``grid`` table of a vehicle class as a GridPolicy; old sample-count keys refused."""
    from graybox.telemetry import GridPolicy

    for name, (new, example, meaning) in _OLD_GRID_KEYS.items():
        if name in table:
            raise check.error(f"{key}.{name}", f"counted samples and is replaced by the "
                                               f"duration {new!r}, {meaning}; write e.g. "
                                               f"grid = {{ {example} }}")
    check.fields(key, table, GridPolicy)
    for name, value in table.items():  # name the key of the first bad value
        check.build(f"{key}.{name}", GridPolicy, {name: value})
    return check.build(key, GridPolicy, table)


class _Checker:
    """Type checks whose errors name the file and the dotted key."""

    def __init__(self, file_name: str):
        self.file_name = file_name

    def error(self, key: str, message: str) -> ConfigError:
        return ConfigError(f"{self.file_name}: {key}: {message}" if key
                           else f"{self.file_name}: {message}")

    def keys(self, key: str, table: Mapping, known) -> None:
        for name in table:
            if name not in known:
                where = f"{key}.{name}" if key else name
                raise self.error(where, f"unknown key; expected one of {', '.join(known)}")

    def fields(self, key: str, table: Mapping, record) -> None:
        """Refuse a name that is not a field of the dataclass ``record``."""
        known = sorted(f.name for f in dataclasses.fields(record))
        for name in table:
            if name not in known:
                raise self.error(f"{key}.{name}", f"unknown setting; known: {', '.join(known)}")

    def build(self, key: str, make, values: Mapping):
        """``make(**values)``, its TypeError or ValueError reported at ``key``."""
        try:
            return make(**values)
        except (TypeError, ValueError) as error:
            raise self.error(key, str(error)) from None

    def table(self, key: str, value, required: bool = False) -> dict:
        if value is None:
            if required:
                raise self.error(key, "missing table")
            return {}
        if not isinstance(value, dict):
            raise self.error(key, f"must be a table, got {type(value).__name__} {value!r}")
        return value

    def string(self, key: str, value) -> str:
        if not isinstance(value, str) or not value.strip():
            raise self.error(key, f"must be a non-empty string, got {value!r}")
        return value

    def number(self, key: str, value) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value):
            raise self.error(key, f"must be a finite number, got {value!r}")
        return float(value)

    def integer(self, key: str, value, low: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise self.error(key, f"must be an integer >= {low}, got {value!r}")
        return int(value)


# -- writing (the demo, `simulate --write-config`) -------------------------------------------

def render_config(*, telemetry_root: str = "telemetry", tracking_uri: str = "sqlite:///mlflow.db",
                  class_name: str = "turbine", model: str = "graybox.models:GasTurbineShaft",
                  assets: tuple[str, ...] = ("T-*",),
                  columns: Mapping[str, str] | None = None,
                  false_alarm_rate: float = 0.01, batch_size: int = 64,
                  plots: str = "alarms", cron: str = "30 2 * * *",
                  retry_delay_seconds: float = 30.0,
                  grid: Mapping[str, Any] | None = None) -> str:
    """A commented ``fleet.toml`` for one vehicle class (what ``demo`` writes).

    ``grid`` holds overrides of :class:`graybox.telemetry.GridPolicy` (durations as seconds
    or strings such as ``"5s"``); the class's ``grid`` line shows every limit in effect.
    """
    columns = {"omega": "shaft_speed"} if columns is None else dict(columns)
    column_text = ", ".join(f'{k} = "{v}"' for k, v in columns.items())
    asset_text = ", ".join(f'"{a}"' for a in assets)
    return f'''# fleet-health configuration (see README "Configuration reference")

[telemetry]
root = "{telemetry_root}"                  # <root>/asset_id=<id>/date=<YYYY-MM-DD>/*.parquet

[mlflow]
tracking_uri = "{tracking_uri}"     # relative SQLite paths resolve against this file

[alerts]
false_alarm_rate = {false_alarm_rate}             # per asset-night; sets epsilon when baselines are fitted
jsonl = "alerts.jsonl"               # every alert, one JSON object per line
major_ratio = 2.0                    # zeta/epsilon from which an alert is "major"
critical_ratio = 5.0                 # ... and "critical" (above 1: "minor")

[nightly]
batch_size = {batch_size}                      # assets per Prefect task (one batched network fit)
window = "1D"                        # the nightly window (whole UTC days)
plots = "{plots}"                    # candidate plots: "alarms", "all" or "none"
retries = 2                          # retries of a batch after a transient error
retry_delay_seconds = {retry_delay_seconds:g}

[schedule]
cron = "{cron}"                  # nightly deployment (fleet-health serve)
timezone = "UTC"

[classes.{class_name}]
model = "{model}"
assets = [{asset_text}]
columns = {{ {column_text} }}
grid = {{ {_grid_text(grid)} }}
# grid: max_gap = longest time between rows filled by interpolation, stuck_after = how long a
# channel may hold one value, min_duration = least time a window must cover
'''


def _grid_text(overrides: Mapping[str, Any] | None) -> str:
    """The inline-table body of a GridPolicy (defaults plus ``overrides``) as durations."""
    from graybox.telemetry import GridPolicy
    from graybox.telemetry.policy import format_duration

    policy = GridPolicy(**dict(overrides or {}))
    parts = []
    if policy.sample_interval is not None:
        parts.append(f'sample_interval = "{format_duration(policy.sample_interval)}"')
    parts.append(f'max_gap = "{format_duration(policy.max_gap)}"')
    if isinstance(policy.stuck_after, tuple):
        limits = ", ".join(f'{_toml_key(name)} = "{format_duration(limit)}"'
                           for name, limit in policy.stuck_after)
        parts.append(f"stuck_after = {{ {limits} }}")
    else:
        parts.append(f'stuck_after = "{format_duration(policy.stuck_after)}"')
    parts.append(f'min_duration = "{format_duration(policy.min_duration)}"')
    return ", ".join(parts)


def _toml_key(name: str) -> str:
    return name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else json.dumps(name)
