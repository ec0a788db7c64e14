"""The flow tests' fleet.toml (a module of its own: ``conftest`` names several modules)."""
from __future__ import annotations

import pathlib

#: the simulated gas turbines (``T-*``) of the flow tests
TURBINES = '''[classes.turbine]
model = "graybox.models:GasTurbineShaft"
assets = ["T-*"]
columns = { omega = "shaft_speed" }'''


def config_text(telemetry: pathlib.Path, db: pathlib.Path, plots: str = "none",
                retries: int = 2, batch_size: int = 64, extra: str = "",
                classes: str = TURBINES) -> str:
    """A fleet.toml of ``classes`` (their tables) whose telemetry is ``telemetry`` and
    whose store is the SQLite file ``db``; ``extra`` is added at the end."""
    return f'''
[telemetry]
root = "{telemetry}"
[mlflow]
tracking_uri = "sqlite:///{db}"
[alerts]
false_alarm_rate = 0.01
jsonl = "alerts.jsonl"
[nightly]
batch_size = {batch_size}
plots = "{plots}"
retries = {retries}
retry_delay_seconds = 0
{classes}
{extra}
'''


def write_config(path: pathlib.Path, telemetry: pathlib.Path, db: pathlib.Path,
                 plots: str = "none", retries: int = 2, batch_size: int = 64,
                 extra: str = "") -> pathlib.Path:
    """:func:`config_text` of the turbines, written at ``path``."""
    path.write_text(config_text(telemetry, db, plots, retries, batch_size, extra))
    return path
