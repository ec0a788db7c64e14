"""Signature.summary() and Drift.summary(): known lines of hand-made records."""
import dataclasses

import pytest

from graybox.drift import Drift, ParameterChange, TierDrift
from graybox.level_tier import LevelTier
from graybox.parameter_estimate import ParameterEstimate
from graybox.signature import Signature
from graybox.summary import WIDTH, differencing_text, format_number

from conftest import make_channel, make_signature


def summary_lines(record) -> list[str]:
    return record.summary().splitlines()


def signature_with_level_and_tuning() -> Signature:
    level = LevelTier(0.0125, (0.1, -0.2), (1.0, 2.0), 0.05, 12, 900)
    channel = dataclasses.replace(make_channel(a=(0.5, -0.2)), level=level)
    tuning = ParameterEstimate(("gamma",), (0.0612,), (0.001,), ((1e-6,),), (0.06,), ("omega",),
                               (0.2,), 12, 5000, 800.0, True)
    return make_signature(channels=(channel,), tuning=tuning)


@pytest.mark.parametrize("value, text", [
    (0.5, "0.5000"), (-0.2, "-0.2000"), (0.0, "0.0000"), (1.234e-5, "1.234e-05"),
    (12345.6, "1.235e+04"), (None, "-"), (float("inf"), "inf"), (float("nan"), "nan")])
def test_numbers_are_written_as_statsmodels_writes_them(value, text):
    assert format_number(value) == text


@pytest.mark.parametrize("orders, text", [
    ((0, 0, 0), "none"), ((0, 0, 1), "(1 - B)"), ((0, 0, 2), "(1 - B)^2"),
    ((24, 1, 1), "(1 - B) (1 - B^24)"), ((7, 2, 0), "(1 - B^7)^2")])
def test_differencing_is_written_as_its_operator(orders, text):
    assert differencing_text(*orders) == text


def test_signature_summary_header_names_asset_window_model_and_intervals():
    lines = summary_lines(signature_with_level_and_tuning())
    assert lines[0].strip() == "Gray-box signature"
    for line in ["Asset:                  T-001",
                 "Window start:           2026-01-01T00:00:00+00:00",
                 "Window end:             2026-01-02T00:00:00+00:00",
                 "Model:                  graybox.models.gas_turbine:LangevinShaft",
                 "Model parameters:       gamma=0.0600",
                 "Residual:               one_step",
                 "Sample interval:        10 s",
                 "Analysis interval:      10 s",
                 "Samples:                1000",
                 "Tuning:                 gamma; converged; 5000 k-step errors"]:
        assert line in lines


def test_signature_summary_lists_tuned_parameters_with_standard_errors():
    lines = summary_lines(signature_with_level_and_tuning())
    # 0.0612 / 0.001 = 61.2 standard errors; 0.0612 -+ 1.96 * 0.001
    assert "  gamma       0.0612     0.0010     61.200      0.000     0.0592     0.0632" in lines


def test_signature_summary_shows_structure_and_ar_coefficients_with_standard_errors():
    lines = summary_lines(signature_with_level_and_tuning())
    assert "Channel omega   (1000 samples)" in lines
    for line in ["  Differencing:         (1 - B)", "  AR order:             2",
                 "  Embedding:            tau 1, dimension 3, 2 hidden units",
                 "  Network needed:       no", "Linear tier: AR(2), Yule-Walker",
                 "  Innovation variance:  1.0000"]:
        assert line in lines
    header = lines.index("Linear tier: AR(2), Yule-Walker") + 3
    assert lines[header].split() == ["coef", "std", "err", "z", "P>|z|", "[0.025", "0.975]"]
    # a1 = 0.5 with standard error 0.01: z = 50, interval 0.5 -+ 1.96 * 0.01
    assert lines[header + 1:header + 3] == [
        "  a1       0.5000     0.0100     50.000      0.000     0.4804     0.5196",
        "  a2      -0.2000     0.0100    -20.000      0.000    -0.2196    -0.1804"]


def test_signature_summary_shows_noise_moments_ljung_box_and_level_tier():
    lines = summary_lines(signature_with_level_and_tuning())
    for line in ["  Variance:             1.0000",
                 "  Ljung-Box Q(20):      20.0000   p 0.400   white at 1 %",
                 "Level tier", "  Level:                0.0125",
                 "  Residual std:         0.0500", "  Horizon:              12 samples",
                 "  Slopes:               0.1000, -0.2000"]:
        assert line in lines


def test_signature_without_level_tier_or_tuning_has_neither_section():
    lines = summary_lines(make_signature())
    assert "Level tier" not in lines
    assert not any(line.startswith(("Tuning", "Tuned")) for line in lines)


def test_signature_summary_fits_its_width_and_survives_the_json_round_trip():
    signature = signature_with_level_and_tuning()
    text = signature.summary()
    assert max(len(line) for line in text.splitlines()) <= WIDTH
    assert Signature.from_json(signature.to_json()).summary() == text


def drift() -> Drift:
    top = (ParameterChange("a1", 0.5, 0.6, 0.01),)
    return Drift((TierDrift("omega", "linear", 0.12, 0.05, top),
                  TierDrift("omega", "nonlinear", 0.01, 0.05, (), parameter_zeta=0.3),
                  TierDrift("omega", "noise", 0.002, None, ()),
                  TierDrift("omega", "level", 0.02, 0.04, (), outside=1.5)), 1000)


def test_drift_summary_marks_the_exceeded_tier():
    lines = summary_lines(drift())
    assert lines[0].strip() == "Gray-box drift"
    assert "Alarms:                 omega linear" in lines
    assert "omega    linear          0.1200     0.0500     2.4000        YES" in lines
    assert "omega    nonlinear       0.0100     0.0500     0.2000         no" in lines
    # no threshold: neither epsilon, ratio nor a verdict
    assert "omega    noise           0.0020          -          -          -" in lines


def test_drift_summary_notes_the_weights_zeta_and_extrapolation_and_lists_top_changes():
    lines = summary_lines(drift())
    assert "  omega nonlinear: zeta on the weights (Eq. 28) 0.3000" in lines
    assert "  omega level: outside the baseline's operating range (1.5000 x its reach), change discounted" in lines
    top = lines.index("Top changes")
    assert lines[top + 1].split() == ["channel", "tier", "parameter", "baseline", "candidate",
                                      "contribution"]
    assert lines[top + 2] == "omega    linear  a1              0.5000     0.6000       0.0100"


def test_drift_summary_without_alarms_says_none_and_survives_the_dict_round_trip():
    quiet = Drift((TierDrift("omega", "linear", 0.01, 0.05, ()),), 500)
    assert "Alarms:                 none" in summary_lines(quiet)
    assert Drift.from_dict(drift().to_dict()).summary() == drift().summary()
