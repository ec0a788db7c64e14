"""The project's classic detectors (:mod:`benchmarks.detection.classic`) on SKAB's windows.

Each works on the one-step residual of the testbed's white box, tuned to the experiment's
baseline rows the way the gray box's baseline tunes it (:data:`benchmarks.skab.run.ESTIMATE`,
:func:`graybox.parameter_estimation.estimate_parameters` at the 1-s analysis interval), and
is calibrated per channel on the baseline's windows as "days" (leave one out, Monte-Carlo
thresholds), as in the detection benchmark. The batch and rolling lengths scale with the
window: 15-s batches (18 per window's kept samples; the calibration's AR models of the batch
series reach 12 lags), a 60-s rolling window, the GLR's change at least 4 batches before the
window's end. A window alarms for a detector when any channel's
statistic passes its threshold; each channel's threshold is set at ``alpha / channels`` so
that the window's rate stays near ``alpha`` (1 %, the gray box's target).

Only whole windows are used: each window's rows go on the 1-s grid (the product's grid) and
its first :data:`SAMPLES` residual samples are kept, so every "day" has the same length, as the
calibration needs. A baseline of fewer than 3 whole windows leaves the experiment unanalysed
by these detectors (its windows count neither way).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from benchmarks.detection.classic import DETECTORS, ClassicSettings, calibrate, night_statistics
from benchmarks.skab.data import SKAB_GRID, to_one_second_grid
from benchmarks.skab.white_box import SKAB_COLUMNS, SkabPump
from graybox.exceptions import GrayBoxError
from graybox.models.base import load_model
from graybox.parameter_estimation import estimate_parameters
from graybox.residual import residual_frame
from graybox.telemetry import GridPolicy

SETTINGS = ClassicSettings(batch_seconds=15.0, rolling_seconds=60.0, glr_min_batches=4,
                           simulated_nights=2000)
#: residual samples kept per window (a whole 5-minute window has 299 after its first sample)
SAMPLES = 280
ALPHA = 0.01
#: the product's SKAB grid with the benchmark's 4-minute floor (benchmarks.skab.run)
GRID = GridPolicy(sample_interval=SKAB_GRID.sample_interval, max_gap=SKAB_GRID.max_gap,
                  min_duration=240.0, intermittent=True)
CLASSIC = tuple(f"classic_{name}" for name in DETECTORS)
#: whole baseline windows the calibration needs (benchmarks.detection.classic.calibrate)
MIN_DAYS = 3


def _model(parameters=None):
    columns = {variable: variable for variable in SKAB_COLUMNS.values()}
    return load_model(SkabPump.spec(), parameters=parameters, columns=columns)


def window_grids(rows: pd.DataFrame, window: pd.Timedelta) -> dict[pd.Timestamp, pd.DataFrame]:
    """Each window's rows (timestamp and channels) on the 1-s grid, where it is whole."""
    channels = ["timestamp", *SKAB_COLUMNS.values()]
    grids = {}
    for start, part in rows[channels].groupby(rows["timestamp"].dt.floor(window)):
        try:
            frame = to_one_second_grid(part.reset_index(drop=True), policy=GRID).frame
        except GrayBoxError:
            continue
        if len(frame) > SAMPLES and frame.notna().all().all():
            grids[start] = frame
    return grids


def tuned_model(training: dict[pd.Timestamp, pd.DataFrame]):
    """The white box with :data:`benchmarks.skab.run.ESTIMATE` fitted to the baseline
    windows."""
    from benchmarks.skab.run import ESTIMATE

    estimate = estimate_parameters(_model(), list(training.values()), ESTIMATE,
                                   analysis_interval=1.0)
    return _model(dict(zip(estimate.names, estimate.values)))


def residuals(model, grids: dict[pd.Timestamp, pd.DataFrame]) -> dict[pd.Timestamp, pd.DataFrame]:
    return {start: residual_frame(model, frame).iloc[:SAMPLES] for start, frame in grids.items()}


def classic_alarms(training_rows: pd.DataFrame, test_rows: pd.DataFrame,
                   window: pd.Timedelta) -> dict[str, pd.Series]:
    """Per classic detector, ``alarm`` per whole test window."""
    training = window_grids(training_rows, window)
    if len(training) < MIN_DAYS:
        # the calibration's leave-one-out needs 3 days: nothing is analysed (not "no alarm")
        return {name: pd.Series([], dtype=object) for name in CLASSIC}
    model = tuned_model(training)
    days = residuals(model, training)
    tests = residuals(model, window_grids(test_rows, window))
    channels = list(model.outputs)
    alpha = ALPHA / len(channels)
    alarms = {name: {start: False for start in tests} for name in CLASSIC}
    for channel in channels:
        calibration = calibrate([r[channel].to_numpy() for r in days.values()], 1.0, SETTINGS,
                                alpha=alpha)
        for start, r in tests.items():
            values = night_statistics(r[channel].to_numpy(), calibration, 1.0, SETTINGS)
            for name in DETECTORS:
                if values[name] > calibration.thresholds[name]:
                    alarms[f"classic_{name}"][start] = True
    return {name: pd.Series(found, dtype=object) for name, found in alarms.items()}
