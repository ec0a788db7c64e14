"""``fleet.toml``: the fleet's configuration, loaded and checked with errors that name the key.

Every table but ``[classes.*]`` is optional; a key left out takes its default from the
settings' dataclasses. docs/configuration.md lists every key with its default and meaning,
generated from those dataclasses (``python -m flows.config.reference``)::

    [telemetry] root                       hive-partitioned Parquet (relative to this file)
    [mlflow] tracking_uri                  relative SQLite paths resolve against this file
    [alerts]                               false-alarm rate, alerts file, severities, staleness
    [nightly]                              windows, batches, plots, retries, memory, runner
    [schedule], [notifications], [dask]    the served deployment, messages, a Dask cluster
    [classes.<name>]                       one per vehicle class: model, assets, columns,
                                           parameters, settings, grid, estimate

Every error is a :class:`ConfigError` whose message starts with the file and the dotted key,
e.g. ``fleet.toml: classes.turbine.model: ...``.

Modules: :mod:`~flows.config.settings` (the dataclasses; their defaults are the defaults,
written once), :mod:`~flows.config.parse` (loading and checking),
:mod:`~flows.config.checker` (typed checks naming the key), :mod:`~flows.config.template`
(the commented ``fleet.toml`` that ``demo`` writes) and :mod:`~flows.config.reference` (the
reference tables of docs/configuration.md). Import from :mod:`flows.config`.
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
