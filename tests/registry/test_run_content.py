"""What a candidate's MLflow run shows of a level change discounted outside the baseline's
operating range: the ``outside`` metric, the drift document and the version description; and
what a baseline's version description says of the conditions its nights are judged against."""
from __future__ import annotations

import dataclasses

import pytest

from graybox.drift import compute_drift
from graybox.level_tier import LevelTier
from graybox.operating_conditions import OperatingConditions
from graybox.parameter_estimate import ParameterEstimate
from registry.write.run_content import describe, drift_document, drift_from_document, fit_metrics
from registry.write.submission import FitSubmission, ResolvedFit
from tests.graybox.conftest import make_channel, make_signature


def _signature(level: float, operating_point: tuple[float, ...], reach: float | None = None):
    record = LevelTier(level, (0.1, -0.2), (100.0, 1.0), 0.05, 12, 8000, operating_point, reach)
    return make_signature((dataclasses.replace(make_channel(), level=record),))


def test_a_night_outside_the_baselines_range_says_so_in_its_run():
    baseline = _signature(0.40, (100.0, 1.0), reach=0.5)
    # its input's correction |-0.2 * (16 - 1)| = 3.0 is six times the reach
    candidate = _signature(0.55, (100.0, 16.0))
    drift = compute_drift(candidate, baseline)
    metrics = fit_metrics(candidate, None, drift)
    assert metrics["outside.omega.level"] == pytest.approx(6.0)
    # the level change (0.15 / 0.05 = 3.0 residual spreads) divided by 6 squared
    assert metrics["zeta.omega.level"] == pytest.approx((3.0 / 6.0 ** 2) ** 2)
    document = drift_document(drift, baseline_version=1)
    entry = next(e for e in document["entries"] if e["tier"] == "level")
    assert entry["outside"] == pytest.approx(6.0)
    assert drift_from_document(document) == drift
    submission = FitSubmission("T-001", "pump", candidate, role="candidate", drift=drift,
                               plots=False)
    text = describe(ResolvedFit(submission, "2026-01-01T00:00:00+00:00",
                                "2026-01-02T00:00:00+00:00", "hash", "key"), 1)
    assert "Outside the baseline's operating range, changes discounted: omega level x6.0" \
        in text
    # a night driven beyond the baseline's input conditions names the input that left
    conditions = dataclasses.replace(drift, conditions="load mean 16 (baseline days 0.5 to 1.5)")
    submission = dataclasses.replace(submission, drift=conditions)
    text = describe(ResolvedFit(submission, "2026-01-01T00:00:00+00:00",
                                "2026-01-02T00:00:00+00:00", "hash", "key"), 1)
    assert "farthest: load mean 16 (baseline days 0.5 to 1.5) (a longer or more varied " \
           "baseline covers it)" in text
    assert drift_from_document(drift_document(conditions, 1)) == conditions
    # inside the range nothing is said
    inside = compute_drift(_signature(0.55, (130.0, 1.5)), baseline)
    assert not any(name.startswith("outside.") for name in fit_metrics(candidate, None, inside))


def test_a_baseline_version_names_the_conditions_of_its_days():
    # three days at 5, 8 and 10 C outdoors, each day's eight pieces scattering +-0.5 around
    # its mean: the days differ beyond chance in their mean, not in their spread
    pieces = [tuple((m + d,) for d in (0.5, -0.5) * 4) for m in (5.0, 8.0, 10.0)]
    conditions = OperatingConditions(("outdoor",), ((5.0,), (8.0,), (10.0,)),
                                     ((1.0,),) * 3, tuple(pieces),
                                     tuple(((1.0,),) * 8 for _ in range(3)))
    baseline = dataclasses.replace(_signature(0.40, (100.0, 1.0)), conditions=conditions)
    submission = FitSubmission("T-001", "pump", baseline, role="baseline", plots=False)
    text = describe(ResolvedFit(submission, "2026-01-01T00:00:00+00:00",
                                "2026-01-04T00:00:00+00:00", "hash", "key"), None)
    assert text.endswith("Its days' conditions, which its nights are judged against (a night "
                         "beyond them by extrapolation): outdoor mean 5 to 10.")
    # a plant driven alike every day has none to name
    alike = dataclasses.replace(submission, signature=_signature(0.40, (100.0, 1.0)))
    assert "conditions" not in describe(ResolvedFit(alike, "2026-01-01T00:00:00+00:00",
                                                    "2026-01-04T00:00:00+00:00", "hash",
                                                    "key"), None)


def test_a_tuned_baseline_shows_each_estimate_with_its_interval_in_its_run():
    tuning = ParameterEstimate(("inertia",), (51.0,), (0.5,), ((0.25,),), (60.0,), ("omega",),
                               (1.2,), 12, 8000, 2000.0, True)
    baseline = dataclasses.replace(_signature(0.40, (100.0, 1.0), reach=0.5), tuning=tuning)
    metrics = fit_metrics(baseline, None, None)
    assert metrics["tuning.inertia"] == 51.0
    assert metrics["tuning.inertia.initial"] == 60.0
    assert metrics["tuning.inertia.standard_error"] == 0.5
    assert (metrics["tuning.inertia.low"], metrics["tuning.inertia.high"]) == pytest.approx(
        (51.0 - 1.96 * 0.5, 51.0 + 1.96 * 0.5), abs=1e-3)
    assert not any(name.startswith("tuning.")
                   for name in fit_metrics(_signature(0.40, (100.0, 1.0)), None, None))
