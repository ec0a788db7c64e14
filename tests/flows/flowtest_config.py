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
                classes: str = TURBINES, candidate_nights: int = 1,
                processes: int | str = 1) -> str:
    """A fleet.toml of ``classes`` (their tables) whose telemetry is ``telemetry`` and
    whose store is the SQLite file ``db``; ``extra`` is added at the end.

    One-night candidates unless ``candidate_nights`` says otherwise: the flow tests' known
    answers are per night (windows, alerts, watermarks); the default of two nights has its own
    tests (test_candidate_nights.py, and test_demo.py runs the rendered default).

    The flow's own process computes everything (``processes = 1``) unless ``processes``
    says otherwise: tests that patch a stage patch it in this process
    (test_pooled_execute.py runs the same nights with a compute pool)."""
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
candidate_nights = {candidate_nights}
processes = {processes if processes != "auto" else '"auto"'}
{classes}
{extra}
'''


def write_config(path: pathlib.Path, telemetry: pathlib.Path, db: pathlib.Path,
                 plots: str = "none", retries: int = 2, batch_size: int = 64,
                 extra: str = "", candidate_nights: int = 1,
                 processes: int | str = 1) -> pathlib.Path:
    """:func:`config_text` of the turbines, written at ``path``."""
    path.write_text(config_text(telemetry, db, plots, retries, batch_size, extra,
                                candidate_nights=candidate_nights, processes=processes))
    return path
