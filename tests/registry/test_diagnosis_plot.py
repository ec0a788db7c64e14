"""The plot of an alarmed window's diagnosis: its residual and what the best hypotheses explain
and leave, drawn from the diagnosis' evidence and logged as ``plots/diagnosis.png`` with the
candidate run; absent when there is nothing true to draw (a failed diagnosis, one without its
fits, plots off)."""
from __future__ import annotations

import numpy as np
import pytest

from graybox.diagnosis import Diagnosis, Hypothesis
from graybox.diagnosis_evidence import ChannelResidual, DiagnosisEvidence, HypothesisFit
from graybox.alert_diagnosis import DiagnosisFailure

N = 3000            # k-step errors of the window: drawn thinned to PLOT_POINTS
SIGMA = 0.1
BIAS = Hypothesis("omega sensor bias", "bias", "omega", 0.0, 0.5, (0.45, 0.55), 900.0, 460.0)
INERTIA = Hypothesis("parameter inertia", "parameter", "inertia", 50.0, 45.0, (44.0, 46.0),
                     300.0, 160.0)
NOISE = Hypothesis("omega noise level", "noise", "omega", 1.0, 1.3, (1.2, 1.4), 40.0, 25.0)


def _evidence(*hypotheses: Hypothesis) -> DiagnosisEvidence:
    """The omega sensor reads 0.5 high; the torque channel is healthy. The bias leaves white
    noise, the inertia half the offset, the noise hypothesis all of it."""
    rng = np.random.default_rng(3)
    times = np.datetime64("2026-01-05T00:00:00") + np.arange(N) * np.timedelta64(10, "s")
    omega = 0.5 + SIGMA * rng.standard_normal(N)
    torque = SIGMA * rng.standard_normal(N)
    leaves = {"bias": (omega - 0.5, torque), "parameter": (omega - 0.25, torque),
              "noise": (omega, torque)}
    return DiagnosisEvidence(
        (ChannelResidual("omega", times, omega, SIGMA),
         ChannelResidual("torque", times, torque, SIGMA)),
        tuple(HypothesisFit(h, leaves[h.kind]) for h in hypotheses))


def _diagnosis(*hypotheses: Hypothesis, evidence: bool = True) -> Diagnosis:
    return Diagnosis(hypotheses, True, 0.0, ("omega", "torque"), 2 * N, 800.0,
                     _evidence(*hypotheses) if evidence else None)


def _legend(axis) -> list[str]:
    return [text.get_text() for text in axis.get_legend().get_texts()]


def test_the_figure_draws_the_residual_and_each_hypothesis_fit_thinned():
    from registry.write.plots import PLOT_POINTS, diagnosis_figure

    figure = diagnosis_figure(_diagnosis(BIAS, INERTIA, NOISE), "T-01 2026-01-05")
    # a parameter moves every channel: both are drawn, each with the fits and what they leave
    assert len(figure.axes) == 4
    fits, leaves = figure.axes[0], figure.axes[1]
    assert _legend(fits) == ["residual r(t)", "1. omega sensor bias 0 -> 0.5 (interval 0.45 "
                             "to 0.55)", "2. parameter inertia 50 -> 45 (-10%; interval 44 to "
                             "46)", "3. omega noise level 1 -> 1.3 (interval 1.2 to 1.4) (one-step "
                             "innovations' spread)"]
    residual, bias, inertia = fits.lines[:3]
    assert len(residual.get_xdata()) == N // 2 <= PLOT_POINTS
    # the bias explains the whole offset, the inertia half of it; the noise, read on the
    # one-step innovations, is listed with no line of its own
    assert np.mean(bias.get_ydata()) == pytest.approx(0.5)
    assert np.mean(inertia.get_ydata()) == pytest.approx(0.25)
    assert len(fits.lines[3].get_xdata()) == 0
    legend = _legend(leaves)
    assert legend[0] == "baseline +-2 sd"
    assert legend[1].startswith("1. leaves rms 1.0") and legend[2].startswith("2. leaves rms 2.")
    assert "omega sensor bias 0 -> 0.5" in figure.get_suptitle()
    assert figure.get_suptitle().startswith("T-01 2026-01-05: ")


def test_sensor_hypotheses_draw_only_their_channel():
    from registry.write.plots import diagnosis_figure

    figure = diagnosis_figure(_diagnosis(BIAS, NOISE))
    assert len(figure.axes) == 2 and figure.axes[0].get_title().startswith("omega:")


def test_a_diagnosis_without_its_fits_is_not_drawn():
    from registry.write.plots import diagnosis_figure

    with pytest.raises(ValueError, match="no evidence"):
        diagnosis_figure(_diagnosis(BIAS, evidence=False))


def _plots(registry, record) -> set[str]:
    return {a.path for a in registry.backend.client.list_artifacts(record.run_id, "plots")}


def test_the_candidate_run_of_a_diagnosed_alarm_holds_the_plot(rec, registry, tmp_path):
    rec.baseline()
    registry.promote("T-01", 1, reason="initial")
    record = rec.candidate(night=5, alarmed=True, plots=True,
                           diagnosis=_diagnosis(BIAS, INERTIA, NOISE))
    assert "plots/diagnosis.png" in _plots(registry, record)
    path = registry.backend.client.download_artifacts(record.run_id, "plots/diagnosis.png",
                                                      str(tmp_path))
    with open(path, "rb") as handle:
        assert handle.read(8) == b"\x89PNG\r\n\x1a\n"


def test_a_fresh_diagnosis_of_a_biased_night_is_drawn_on_its_candidate_run(rec, registry,
                                                                           fits):
    from graybox.diagnosis import diagnose

    night = fits.night.assign(omega=fits.night["omega"] + 0.5)
    found = diagnose(fits.baseline, [night], fits.model)
    # in the Langevin shaft a speed bias, the reference speed and the reference fuel shift the
    # equilibrium alike: the three tie first (their order is the fits' rounding)
    first = found.hypotheses[:3]
    assert {h.hypothesis for h in first} == {"omega sensor bias", "parameter omega_ref",
                                             "parameter fuel_ref"}
    assert first[2].score == pytest.approx(first[0].score, abs=0.01)
    assert found.hypotheses[3].score < first[0].score and len(found.evidence.fits) == 3
    record = rec.candidate(night=5, alarmed=True, plots=True, diagnosis=found)
    assert "plots/diagnosis.png" in _plots(registry, record)


@pytest.mark.parametrize("diagnosis", [DiagnosisFailure("GrayBoxError: out of time"),
                                       _diagnosis(BIAS, evidence=False)],
                         ids=["failed", "without its fits"])
def test_no_diagnosis_plot_without_fits_to_draw(rec, registry, diagnosis):
    record = rec.candidate(night=6, alarmed=True, plots=True, diagnosis=diagnosis)
    plots = _plots(registry, record)
    assert "plots/zeta_trend.png" in plots and "plots/diagnosis.png" not in plots


def test_no_diagnosis_plot_when_plots_are_off(rec, registry):
    record = rec.candidate(night=7, alarmed=True, diagnosis=_diagnosis(BIAS))
    assert _plots(registry, record) == set()
