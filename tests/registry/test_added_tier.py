"""Issue 21 item 3: a tier added through ``kinds=`` (no global registration) is recorded like
the built-in four: its metrics are in the MLflow run by name, its bundle loads back with it, and
its zetas are in the asset's history."""
from __future__ import annotations

import pandas as pd
import pytest

from graybox import FitRequest, GrayBox, compute_drift, fit_signatures
from graybox.tiers import TIER_KINDS, TIERS
from registry.write.plots import zeta_trend_figure
from tests.graybox.test_new_tier import MeanAbsoluteTier, simulated_days

KINDS = TIER_KINDS + (MeanAbsoluteTier(),)


@pytest.fixture(scope="module")
def added():
    model, days = simulated_days(41, 4)
    box = GrayBox(model, kinds=KINDS).fit(days[:3])
    candidate = fit_signatures([FitRequest(model, days[3:], baseline=box.signature_)],
                               kinds=KINDS)[0]
    drift = compute_drift(candidate, box.signature_, box.calibration_, kinds=KINDS)
    return box, candidate, drift, days


def test_an_added_tier_is_stored_shown_in_its_runs_and_read_back(registry, added):
    box, candidate, drift, days = added
    start, end = days[0].index[0], days[2].index[-1] + pd.Timedelta(seconds=1)
    baseline_record = registry.record_fit(
        "V-1", "turbine", box.signature_, role="baseline", calibration=box.calibration_,
        window_start=start, window_end=end, data_hash="baseline", plots=False)
    night_record = registry.record_fit(
        "V-1", "turbine", candidate, role="candidate", drift=drift, window_start=end,
        window_end=end + pd.Timedelta(days=1), data_hash="night", plots=False)
    client = registry.backend.client
    threshold = box.calibration_.threshold("omega", "mean_abs")
    baseline_metrics = client.get_run(baseline_record.run_id).data.metrics
    assert baseline_metrics["epsilon.omega.mean_abs"] == pytest.approx(threshold.epsilon)
    assert baseline_metrics["healthy_zeta.omega.mean_abs"] == pytest.approx(threshold.mean_zeta)
    entry = drift.get("omega", "mean_abs")
    night_metrics = client.get_run(night_record.run_id).data.metrics
    assert night_metrics["zeta.omega.mean_abs"] == pytest.approx(entry.zeta)
    assert night_metrics["epsilon.omega.mean_abs"] == pytest.approx(entry.epsilon)
    assert night_metrics["ratio.omega.mean_abs"] == pytest.approx(entry.ratio)
    # the built-in tiers' metric names are as before
    for tier in TIERS:
        assert f"zeta.omega.{tier}" in night_metrics
        assert f"epsilon.omega.{tier}" in baseline_metrics
    # read back: the bundle (signature, calibration, weights) with the added tier
    loaded = registry.load_version("V-1", baseline_record.version)
    kind = KINDS[-1]
    assert kind.record(loaded.signature.channel("omega")) == \
        kind.record(box.signature_.channel("omega"))
    assert loaded.calibration == box.calibration_
    history = registry.zeta_history("V-1")
    row = history[history["tier"] == "mean_abs"].iloc[0]
    assert row["zeta"] == pytest.approx(entry.zeta)
    assert row["epsilon"] == pytest.approx(entry.epsilon)
    # built-in tiers first in their order, the added tier after them
    assert list(history["tier"]) == [*TIERS, "mean_abs"]
    # and the zeta trend plots it beside them
    titles = [axis.get_title() for axis in zeta_trend_figure(history).axes]
    assert titles == [f"omega: {tier} tier" for tier in (*TIERS, "mean_abs")]
