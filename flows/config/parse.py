"""Loading ``fleet.toml``: read the file, check every key, build a :class:`FleetConfig`.

A key left out takes its dataclass default (:mod:`flows.config.settings`).
"""
from __future__ import annotations

import dataclasses
import os
import pathlib
import re
import tomllib
import zoneinfo
from typing import Any, Mapping

import pandas as pd

from flows.config.checker import Checker
from flows.config.settings import (DEFAULT_CONFIG, DEFAULT_TELEMETRY_ROOT, DEFAULT_TRACKING_URI,
                                   FROM_ALERTS, PLOT_POLICIES, TASK_RUNNERS, AlertSettings,
                                   DaskSettings, FleetConfig, NightlySettings,
                                   NotificationSettings, ScheduleSettings, VehicleClass,
                                   resolve_tracking_uri)
from flows.errors import ConfigError
from flows.memory import parse_bytes
from graybox.estimator import GrayBoxSettings
from graybox.exceptions import ModelSpecError
from graybox.models import load_model
from graybox.models.fmu_file import PREFIX, file_model_class, fmu_path, fmu_spec, is_fmu_spec
from graybox.nonlinear_tier import FitSettings
from graybox.severity import SeverityScale
from graybox.telemetry import GridPolicy

_CLASS_NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")
_CRON_FIELD = re.compile(r"[0-9A-Za-z*/,?LW#-]+")
#: (name, lowest, highest) of the five cron fields; numbers outside are refused at load
_CRON_RANGES = (("minute", 0, 59), ("hour", 0, 23), ("day of month", 1, 31), ("month", 1, 12),
                ("day of week", 0, 7))
_ID_OR_GLOB = re.compile(r"[A-Za-z0-9_.*?\[\]!-]{1,64}")

#: method settings that counted samples, and the settings in seconds that replaced them
RENAMED_SETTINGS = {"max_ar_order": "ar_span", "max_delay": "delay_span"}


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
    check = Checker(path.name)
    base = path.parent
    check.keys("", data, ("telemetry", "mlflow", "alerts", "nightly", "schedule",
                          "notifications", "dask", "classes"))

    telemetry = check.table("telemetry", data.get("telemetry", {}))
    check.keys("telemetry", telemetry, ("root",))
    root = base / check.string("telemetry.root", telemetry.get("root", DEFAULT_TELEMETRY_ROOT))

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
    dask = _dask(check, check.table("dask", data.get("dask", {})))
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
    classes = {name: _vehicle_class(check, name, check.table(f"classes.{name}", table), base)
               for name, table in classes_table.items()}
    return FleetConfig(path=path, telemetry_root=root.resolve(), tracking_uri=uri,
                       classes=classes, alerts=alerts, nightly=nightly, schedule=schedule,
                       notifications=NotificationSettings(block), dask=dask)


def _alerts(check: Checker, table: Mapping, base: pathlib.Path) -> AlertSettings:
    default = AlertSettings()
    check.keys("alerts", table, ("false_alarm_rate", "jsonl", "major_ratio", "critical_ratio",
                                 "stale_after", "not_operating_after"))
    rate = check.number("alerts.false_alarm_rate",
                        table.get("false_alarm_rate", default.false_alarm_rate))
    if not 0 < rate < 1:
        raise check.error("alerts.false_alarm_rate",
                          f"must be in (0, 1) (false alarms per asset-night), got {rate!r}")
    jsonl = base / check.string("alerts.jsonl", table.get("jsonl", str(default.jsonl)))
    major = check.number("alerts.major_ratio", table.get("major_ratio", default.major_ratio))
    critical = check.number("alerts.critical_ratio", table.get("critical_ratio",
                                                                 default.critical_ratio))
    try:
        SeverityScale(major, critical)
    except ValueError as error:
        raise check.error("alerts", str(error)) from None
    stale = _duration_or_off(check, "alerts.stale_after",
                             table.get("stale_after", default.stale_after), "'2D', '36h'")
    calm = _duration_or_off(check, "alerts.not_operating_after",
                            table.get("not_operating_after", default.not_operating_after),
                            "'7D', '36h'")
    return AlertSettings(rate, jsonl.resolve(), major, critical, stale, calm)


def _duration_or_off(check: Checker, key: str, value, example: str) -> str | None:
    """A positive duration key that ``"off"`` (or ``"none"``) turns off: None."""
    text = check.string(key, value)
    if text.strip().lower() in ("off", "none"):
        return None
    _positive_duration(check, key, text, f"{example} or \"off\"")
    return text


def _positive_duration(check: Checker, key: str, text: str, example: str,
                       allow_zero: bool = False) -> pd.Timedelta:
    """A duration key such as "2D" (a bare number is refused: pandas reads it as ns)."""
    try:
        if not any(c.isalpha() for c in text):
            raise ValueError
        delta = pd.Timedelta(text)
    except (ValueError, TypeError):
        raise check.error(key, f"{text!r} is not a duration such as {example}") from None
    if delta is pd.NaT or delta < pd.Timedelta(0) or (delta == pd.Timedelta(0)
                                                       and not allow_zero):
        raise check.error(key, f"{text!r} must be a {'non-negative' if allow_zero else 'positive'}"
                               f" duration such as {example}")
    return delta


def _nightly(check: Checker, table: Mapping) -> NightlySettings:
    check.keys("nightly", table, ("batch_size", "window", "plots", "retries",
                                  "retry_delay_seconds", "memory_budget", "lookback",
                                  "task_runner", "candidate_nights", "processes"))
    default = NightlySettings()
    batch = check.integer("nightly.batch_size", table.get("batch_size", default.batch_size),
                          low=1)
    window = check.string("nightly.window", table.get("window", default.window))
    try:
        delta = pd.Timedelta(window)
    except (ValueError, TypeError):
        raise check.error("nightly.window", f"{window!r} is not a duration such as '1D' or "
                                            f"'6h'") from None
    day = pd.Timedelta(days=1)
    if delta < pd.Timedelta(minutes=1) or delta > day or (day % delta) != pd.Timedelta(0):
        raise check.error("nightly.window", f"{window!r} must divide a day and be at least "
                                            f"1 minute (e.g. '1D', '6h', '10min')")
    plots = check.string("nightly.plots", table.get("plots", default.plots))
    if plots not in PLOT_POLICIES:
        raise check.error("nightly.plots", f"must be one of {', '.join(PLOT_POLICIES)}, "
                                           f"got {plots!r}")
    retries = check.integer("nightly.retries", table.get("retries", default.retries),
                            low=0)
    delay = check.number("nightly.retry_delay_seconds",
                         table.get("retry_delay_seconds", default.retry_delay_seconds))
    if delay < 0:
        raise check.error("nightly.retry_delay_seconds", f"must be >= 0, got {delay!r}")
    try:
        budget = parse_bytes(table.get("memory_budget", default.memory_budget))
    except ValueError as error:
        raise check.error("nightly.memory_budget", str(error)) from None
    lookback = check.string("nightly.lookback", table.get("lookback", default.lookback))
    _positive_duration(check, "nightly.lookback", lookback, "'7D' (or '0D': no look-back)",
                       allow_zero=True)
    runner = check.string("nightly.task_runner", table.get("task_runner", default.task_runner))
    if runner not in TASK_RUNNERS:
        raise check.error("nightly.task_runner", f"must be one of {', '.join(TASK_RUNNERS)}, "
                                                 f"got {runner!r}")
    nights = check.integer("nightly.candidate_nights",
                           table.get("candidate_nights", default.candidate_nights), low=1)
    processes = table.get("processes", default.processes)
    if processes != "auto":
        processes = check.integer("nightly.processes", processes, low=1)
    return NightlySettings(batch, window, plots, retries, delay, budget, lookback,
                           task_runner=runner, candidate_nights=nights, processes=processes)


def _dask(check: Checker, table: Mapping) -> DaskSettings:
    default = DaskSettings()
    check.keys("dask", table, ("address", "workers", "threads_per_worker"))
    address = table.get("address", default.address)
    if address is not None:
        address = check.string("dask.address", address)
        if "://" not in address:
            raise check.error("dask.address", f"{address!r} is not a scheduler address such as "
                                              f"'tcp://scheduler.example:8786'")
    workers = table.get("workers", default.workers)
    if workers is not None:
        workers = check.integer("dask.workers", workers, low=1)
    threads = check.integer("dask.threads_per_worker",
                            table.get("threads_per_worker", default.threads_per_worker), low=1)
    for key in ("workers", "threads_per_worker"):
        if address is not None and key in table:
            raise check.error(f"dask.{key}", "a cluster at dask.address has its own workers; "
                                             f"give either address or {key}")
    return DaskSettings(address, workers, threads)


def _schedule(check: Checker, table: Mapping) -> ScheduleSettings:
    default = ScheduleSettings()
    check.keys("schedule", table, ("cron", "timezone"))
    cron = check.string("schedule.cron", table.get("cron", default.cron))
    if len(cron.split()) != 5:
        raise check.error("schedule.cron", f"{cron!r} is not a 5-field cron expression "
                                           f"(minute hour day month weekday)")
    for part, (name, low, high) in zip(cron.split(), _CRON_RANGES):
        if _CRON_FIELD.fullmatch(part) is None:
            raise check.error("schedule.cron", f"{cron!r}: field {part!r} is not a cron field")
        for number in re.split(r"[^0-9]+", part.split("/")[0]):
            if number and not low <= int(number) <= high:
                raise check.error("schedule.cron", f"{cron!r}: {name} {number} is outside "
                                                   f"{low}-{high}")
    timezone = check.string("schedule.timezone", table.get("timezone", default.timezone))
    try:
        zoneinfo.ZoneInfo(timezone)
    except (zoneinfo.ZoneInfoNotFoundError, ValueError):
        raise check.error("schedule.timezone", f"unknown time zone {timezone!r}") from None
    return ScheduleSettings(cron, timezone)


def _vehicle_class(check: Checker, name: str, table: Mapping,
                   base: pathlib.Path) -> VehicleClass:
    key = f"classes.{name}"
    if _CLASS_NAME.fullmatch(name) is None or name in (".", ".."):
        raise check.error(key, "a vehicle class name must match [A-Za-z0-9_.-]{1,64}")
    check.keys(key, table, ("model", "parameters", "assets", "columns", "settings", "grid",
                            "estimate", "not_operating_after"))
    if "model" not in table:
        raise check.error(f"{key}.model", "missing: name the physics model, e.g. "
                                          "\"graybox.models:GasTurbineShaft\", or an FMU "
                                          "file, \"fmu:models/plant.fmu\"")
    model = check.string(f"{key}.model", table["model"])
    if is_fmu_spec(model):
        model = _fmu_file(check, f"{key}.model", model, base)
    parameters = check.table(f"{key}.parameters", table.get("parameters", {}))
    for pname, value in parameters.items():
        if not isinstance(value, Mapping):   # a table is checked by the model below
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
    estimate = _estimate(check, f"{key}.estimate", table.get("estimate", []),
                         load_model(model, dict(parameters), dict(columns)))

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
    calm = table.get("not_operating_after", FROM_ALERTS)
    if calm != FROM_ALERTS:
        calm = _duration_or_off(check, f"{key}.not_operating_after", calm,
                                "'30D', '36h', \"alerts\" (the [alerts] value)")
    return VehicleClass(name, model, dict(parameters), tuple(assets), dict(columns), settings,
                        grid, estimate, calm)


def _fmu_file(check: Checker, key: str, model: str, base: pathlib.Path) -> str:
    """``model = "fmu:<path>"``: the spec with the path absolute (a relative one is read
    from fleet.toml's directory), once the file is found to be an FMU this process can use
    (errors name the file and what to do)."""
    try:
        spec = fmu_spec(model, base)
        path = fmu_path(spec)
        if not path.exists():
            written = model[len(PREFIX):].strip()
            relative = "" if os.path.isabs(os.path.expanduser(written)) else \
                f" ({written!r} is read from the directory of {check.file_name})"
            raise ModelSpecError(f"FMU {path}: no such file{relative}")
        file_model_class(spec)
    except ModelSpecError as error:
        raise check.error(key, str(error)) from None
    return spec


def _estimate(check: Checker, key: str, names, model) -> tuple[str, ...]:
    """The parameters a class's baselines tune to their asset: number parameters of its
    white box, each once."""
    if isinstance(names, str):
        names = [names]
    if not isinstance(names, list):
        raise check.error(key, f"must be a list of the white box's parameter names, got "
                               f"{names!r}")
    known = [name for name, value in model.parameters.items() if isinstance(value, (int, float))]
    for i, name in enumerate(names):
        if name not in known:
            raise check.error(f"{key}[{i}]", f"{name!r} is not a number parameter of "
                                             f"{model.spec()}; they are: {', '.join(known)}")
    if len(set(names)) != len(names):
        raise check.error(key, f"names a parameter twice: {names}")
    return tuple(names)


# GridPolicy keys counted in samples before its limits became durations
_OLD_GRID_KEYS = {
    "max_fill": ("max_gap", 'max_gap = "40s"', "the longest time between two rows that is "
                 "filled by interpolation (max_fill = 3 at 10 s samples is 40 s)"),
    "stuck_samples": ("stuck_after", 'stuck_after = "10min"', "how long a sensor may hold one "
                      "value (stuck_samples = 60 at 10 s samples is 10 minutes)"),
    "min_samples": ("min_duration", 'min_duration = "1h"', "the least time a window must "
                    "cover (min_samples = 500 at 10 s samples is about 83 minutes)"),
}


def _grid(check: Checker, key: str, table: Mapping):
    """The ``grid`` table of a vehicle class as a GridPolicy; old sample-count keys refused."""
    for name, (new, example, meaning) in _OLD_GRID_KEYS.items():
        if name in table:
            raise check.error(f"{key}.{name}", f"counted samples and is replaced by the "
                                               f"duration {new!r}, {meaning}; write e.g. "
                                               f"grid = {{ {example} }}")
    check.fields(key, table, GridPolicy)
    for name, value in table.items():  # name the key of the first bad value
        check.build(f"{key}.{name}", GridPolicy, {name: value})
    return check.build(key, GridPolicy, table)
