"""The flow tests' fleet.toml (a module of its own: ``conftest`` names several modules)."""
from __future__ import annotations

import pathlib


def write_config(path: pathlib.Path, telemetry: pathlib.Path, db: pathlib.Path,
                 plots: str = "none", retries: int = 2, batch_size: int = 64,
                 extra: str = "") -> pathlib.Path:
    path.write_text(f'''
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
[classes.turbine]
model = "graybox.models:GasTurbineShaft"
assets = ["T-*"]
columns = {{ omega = "shaft_speed" }}
{extra}
''')
    return path
