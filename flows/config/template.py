"""A commented ``fleet.toml`` for one vehicle class (what ``demo`` and ``simulate
--config-out`` write); its values default to the settings' dataclass defaults."""
from __future__ import annotations

import json
import re
from typing import Any, Mapping

from flows.config.settings import (AUTO_POOL_MIN_ASSETS, DEFAULT_TELEMETRY_ROOT,
                                   DEFAULT_TRACKING_URI, AlertSettings, DaskSettings,
                                   NightlySettings, ScheduleSettings)
from graybox.telemetry import GridPolicy
from graybox.telemetry.policy import format_duration


def render_config(*, telemetry_root: str = DEFAULT_TELEMETRY_ROOT,
                  tracking_uri: str = DEFAULT_TRACKING_URI,
                  class_name: str = "turbine", model: str = "graybox.models:GasTurbineShaft",
                  assets: tuple[str, ...] = ("T-*",),
                  columns: Mapping[str, str] | None = None,
                  false_alarm_rate: float = AlertSettings().false_alarm_rate,
                  batch_size: int = NightlySettings().batch_size,
                  candidate_nights: int = NightlySettings().candidate_nights,
                  plots: str = NightlySettings().plots, cron: str = ScheduleSettings().cron,
                  retry_delay_seconds: float = NightlySettings().retry_delay_seconds,
                  grid: Mapping[str, Any] | None = None) -> str:
    """A commented ``fleet.toml`` for one vehicle class (what ``demo`` writes).

    ``grid`` holds overrides of :class:`graybox.telemetry.GridPolicy` (durations as seconds
    or strings such as ``"5s"``); the class's ``grid`` line shows every limit in effect.
    """
    columns = {"omega": "shaft_speed"} if columns is None else dict(columns)
    column_text = ", ".join(f'{k} = "{v}"' for k, v in columns.items())
    asset_text = ", ".join(f'"{a}"' for a in assets)
    alerts, nightly, schedule = AlertSettings(), NightlySettings(), ScheduleSettings()
    processes, min_pool = json.dumps(nightly.processes), AUTO_POOL_MIN_ASSETS
    return f'''# fleet-health configuration (every key: docs/configuration.md)

[telemetry]
root = "{telemetry_root}"                  # <root>/asset_id=<id>/date=<YYYY-MM-DD>/*.parquet

[mlflow]
tracking_uri = "{tracking_uri}"     # relative SQLite paths resolve against this file

[alerts]
false_alarm_rate = {false_alarm_rate}             # per asset-night; sets epsilon when baselines are fitted
jsonl = "{alerts.jsonl}"               # every alert, one JSON object per line
major_ratio = {alerts.major_ratio}                    # zeta/epsilon from which an alert is "major"
critical_ratio = {alerts.critical_ratio}                 # ... and "critical" (above 1: "minor")
stale_after = "{alerts.stale_after}"                 # no telemetry for this long: a "stale" alert ("off": none)
not_operating_after = "{alerts.not_operating_after}"         # not operated for this long: "dormant", exit 1 ("off": never)

[nightly]
batch_size = {batch_size}                      # assets per Prefect task (one batched network fit)
window = "{nightly.window}"                        # the nightly window (whole UTC days)
plots = "{plots}"                    # candidate plots: "alarms", "all" or "none"
retries = {nightly.retries}                          # retries of a batch after a transient error
retry_delay_seconds = {retry_delay_seconds:g}
lookback = "{nightly.lookback}"                     # late-arriving windows before the watermark are analysed
candidate_nights = {candidate_nights}                     # each candidate fitted on the night and the N - 1 before it
task_runner = "{nightly.task_runner}"            # "dask": batches at once on the [dask] cluster
processes = {processes}                       # processes computing the candidates ("auto": one per core from {min_pool} assets)

# [dask]                                   # with task_runner = "dask" (docs/operations.md)
# address = "tcp://scheduler:8786"         # an existing cluster; or (not both) a LocalCluster per run:
# workers = 2                              # its worker processes (default: one per core)
# threads_per_worker = {DaskSettings().threads_per_worker}                   # batches at once per worker

[schedule]
cron = "{cron}"                  # nightly deployment (fleet-health serve)
timezone = "{schedule.timezone}"

[classes.{class_name}]
model = "{model}"
assets = [{asset_text}]
columns = {{ {column_text} }}
grid = {{ {_grid_text(grid)} }}
# grid: max_gap = longest time between rows filled by interpolation, stuck_after = how long a
# channel may hold one value, min_duration = least time a window must cover,
# plausible_spread = how many 1-99 % spans from the median a value may lie (0: off), and
# ranges = {{ <column> = [low, high] }} = plausible values per channel (instead)
'''


def _grid_text(overrides: Mapping[str, Any] | None) -> str:
    """The inline-table body of a GridPolicy (defaults plus ``overrides``) as durations."""
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
    if policy.plausible_spread != GridPolicy().plausible_spread:
        parts.append(f"plausible_spread = {policy.plausible_spread:g}")
    if policy.ranges:
        bounds = ", ".join(f"{_toml_key(name)} = [{low!r}, {high!r}]"
                           for name, low, high in policy.ranges)
        parts.append(f"ranges = {{ {bounds} }}")
    if policy.intermittent:
        parts.append("intermittent = true")
    if policy.running:
        bounds = ", ".join(f"{_toml_key(name)} = [{low!r}, {high!r}]"
                           for name, low, high in policy.running)
        parts.append(f"running = {{ {bounds} }}")
    return ", ".join(parts)


def _toml_key(name: str) -> str:
    return name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else json.dumps(name)
