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
    task_runner = "sequential"             # or "dask": batches at once on a Dask cluster
    candidate_nights = 2                   # candidate fitted on the night and the N - 1 before

    [schedule]
    cron = "30 2 * * *"                    # the nightly deployment's schedule
    timezone = "UTC"

    [notifications]
    block = "slack-webhook/fleet-health"   # optional Prefect notification block

    [dask]                                 # with [nightly] task_runner = "dask":
    address = "tcp://scheduler:8786"       # an existing cluster, or (without address)
    # workers = 4                          # a LocalCluster per run: worker processes
    threads_per_worker = 1                 # (default one per core) of this many threads

    [classes.turbine]                      # one table per vehicle class
    model = "graybox.models:GasTurbineShaft"
    parameters = { inertia = 45.0 }        # overrides of the model's default_parameters
    assets = ["T-*"]                       # ids or glob patterns
    columns = { omega = "shaft_speed" }    # model variable -> telemetry column
    settings = { hidden_units = 8 }        # overrides of graybox GrayBoxSettings
    grid = { max_gap = "4min", stuck_after = "10min", min_duration = "1h" }
                                           # overrides of graybox GridPolicy: durations
    estimate = ["turbine_gain"]            # white-box parameters each baseline fits to
                                           # its asset first (default none)

Every error is a :class:`ConfigError` whose message starts with the file and the dotted key,
e.g. ``fleet.toml: classes.turbine.model: ...``.

Modules: :mod:`~flows.config.settings` (the dataclasses; their defaults are the defaults
above, written once), :mod:`~flows.config.parse` (loading and checking),
:mod:`~flows.config.checker` (typed checks naming the key) and :mod:`~flows.config.template`
(the commented ``fleet.toml`` that ``demo`` writes). Import from :mod:`flows.config`.
"""
from flows.config.checker import Checker
from flows.config.parse import RENAMED_SETTINGS, load_config, parse_config
from flows.config.settings import (DEFAULT_CONFIG, DEFAULT_MEMORY_BUDGET, DEFAULT_TELEMETRY_ROOT,
                                   DEFAULT_TRACKING_URI, PLOT_POLICIES, TASK_RUNNERS,
                                   AlertSettings, DaskSettings, FleetConfig, NightlySettings,
                                   NotificationSettings, ScheduleSettings, VehicleClass,
                                   resolve_tracking_uri)
from flows.errors import ConfigError
from flows.config.template import render_config

__all__ = ["DEFAULT_CONFIG", "DEFAULT_MEMORY_BUDGET", "DEFAULT_TELEMETRY_ROOT",
           "DEFAULT_TRACKING_URI", "PLOT_POLICIES", "RENAMED_SETTINGS", "TASK_RUNNERS",
           "AlertSettings", "Checker", "ConfigError", "DaskSettings", "FleetConfig", "NightlySettings", "NotificationSettings",
           "ScheduleSettings", "VehicleClass", "load_config", "parse_config", "render_config",
           "resolve_tracking_uri"]
