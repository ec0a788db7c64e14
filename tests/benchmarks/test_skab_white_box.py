"""The SKAB testbed's white box on the healthy file (issue 20, item 2).

Reads the GPL-3.0 data from ``../shared/datasets/skab`` beside the repository (never copied
into it); skipped when that folder is absent.
"""
from __future__ import annotations

import pathlib

import numpy as np
import pytest

import graybox as gb
from benchmarks.skab.data import (HEALTHY_OVERLAP_ROWS, dataset_dir, healthy_frame,
                                  read_healthy, step_counts)
from benchmarks.skab.white_box import SKAB_COLUMNS, SkabPump
from graybox.residual import residual_frame

REPO_ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = dataset_dir(REPO_ROOT)
pytestmark = pytest.mark.skipif(not (DATA / "data" / "anomaly-free").is_dir(),
                                reason=f"SKAB data (GPL-3.0, not in the repository) absent "
                                       f"at {DATA}")
HEALTHY_ROWS = 9405


@pytest.fixture(scope="module")
def frame():
    return healthy_frame(DATA)


@pytest.fixture(scope="module")
def model():
    columns = {variable: variable for variable in SKAB_COLUMNS.values()}
    return gb.load_model(SkabPump.spec(), columns=columns)


def test_healthy_file_loses_its_overlap_with_other_5():
    raw = read_healthy(DATA)
    assert len(raw) == HEALTHY_ROWS - HEALTHY_OVERLAP_ROWS == 8833
    # Moscow time 16:06:47 is the last kept row; 16:06:48 starts other/5.csv
    assert str(raw["timestamp"].iloc[-1]) == "2020-02-08 13:06:47+00:00"
    assert step_counts(raw) == {1.0: 8304, 2.0: 528}


def test_grid_fills_the_two_second_steps(frame):
    assert len(frame) == 8304 + 2 * 528 + 1
    assert set(SKAB_COLUMNS.values()) <= set(frame.columns)


def test_white_box_explains_each_state_better_than_differences(model, frame):
    residual = residual_frame(model, frame)
    differences = frame[list(model.outputs)].diff().iloc[1:]
    rms = np.sqrt((residual ** 2).mean())
    plain = np.sqrt((differences ** 2).mean())
    for state in model.states:
        assert rms[state] < plain[state], (state, rms[state], plain[state])
    for channel in ("vibration_1", "vibration_2"):  # no dynamics: its own difference
        assert rms[channel] == pytest.approx(plain[channel])


def test_baseline_signature_fits_with_the_defaults(model, frame):
    signatures = gb.fit_signatures([gb.FitRequest(model, [frame])])
    (signature,) = signatures
    assert {channel.channel for channel in signature.channels} == set(model.outputs)
    assert signature.analysis_step >= 1.0


def test_the_recorded_defaults_are_what_the_estimate_gives_on_the_healthy_file(frame):
    # benchmarks/skab/estimate.py (python -m benchmarks.skab.estimate): the white box's
    # data-dependent defaults are its printout, rounded as recorded in the class
    from benchmarks.skab.estimate import energy_balance_defaults

    estimates = energy_balance_defaults(frame)
    assert set(estimates) == {"motor_ambient_conductance", "fluid_ambient_conductance",
                              "flow_per_watt", "flow_time_constant", "vibration_1_level",
                              "vibration_2_level"}
    for name, value in estimates.items():
        assert SkabPump.default_parameters[name] == pytest.approx(value, rel=5e-3), name
