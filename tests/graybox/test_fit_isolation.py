"""Issue 13, item 11 (b): inside a batched fit, one asset's error is its own."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from graybox.exceptions import GrayBoxError
from graybox.signature_fit import FitRequest, _prepare, fit_signatures
from graybox.signature_fit import _fit_batched as _fit_networks_isolated
from graybox.models import load_model
from graybox.telemetry import GridPolicy, read_window


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    from flows.demo import simulated_fleet, write_simulation

    root = tmp_path_factory.mktemp("isolation") / "telemetry"
    write_simulation(simulated_fleet(2, 4, seed=7, sample_interval=30.0, faults=[]), root)
    model = load_model("graybox.models:GasTurbineShaft", {}, {"omega": "shaft_speed"})

    def window(asset, day, policy=GridPolicy()):
        start = pd.Timestamp("2026-01-01", tz="UTC") + pd.Timedelta(days=day)
        return read_window(root, asset, model.required_columns, start,
                           start + pd.Timedelta(days=1), policy=policy,
                           inputs=model.input_columns)

    baselines = fit_signatures([FitRequest(model, [window(a, d) for d in range(3)], asset_id=a)
                                for a in ("T-001", "T-002")])
    return model, window, baselines


def _candidates(model, window, baselines):
    return [FitRequest(model, [window(a, 3)], baseline=b, asset_id=a)
            for a, b in zip(("T-001", "T-002"), baselines)]


def test_fault_huge_sample_fails_only_its_request(fleet):
    """A 1e10 sample (the range check off) used to raise a raw ValueError out of the whole
    batch; now it is T-002's GrayBoxError, named, and T-001 gets its signature."""
    model, window, baselines = fleet
    bad = window("T-002", 3, GridPolicy(plausible_spread=0))
    bad.frame.iloc[500, bad.frame.columns.get_loc("shaft_speed")] = 1e10
    requests = _candidates(model, window, baselines)
    alone = fit_signatures(requests[:1])[0]
    results = fit_signatures([requests[0], FitRequest(model, [bad], baseline=baselines[1],
                                                      asset_id="T-002")])
    assert isinstance(results[1], GrayBoxError) and "asset 'T-002'" in str(results[1])
    assert results[0] == alone


def test_fault_error_inside_the_batched_network_fit_fails_only_its_request(fleet):
    """An exception raised by the batched network computation is found by fitting each
    request alone: only the culprit fails, the other's networks equal its fit alone."""
    model, window, baselines = fleet
    requests = _candidates(model, window, baselines)
    settings = baselines[0].settings
    alone = _prepare(requests[0], settings)
    assert _fit_networks_isolated([alone], settings, 32) == {}
    good, culprit = (_prepare(r, settings) for r in requests)
    culprit.channels[0].w_segments = [np.ones((5, 2))]   # a malformed series: the batch raises
    failed = _fit_networks_isolated([good, culprit], settings, 32)
    assert list(failed) == [id(culprit)]
    assert "asset 'T-002'" in str(failed[id(culprit)])
    assert good.channels[0].nonlinear == alone.channels[0].nonlinear


def test_fault_non_finite_network_is_an_error_not_a_nan_signature(fleet):
    model, window, baselines = fleet
    requests = _candidates(model, window, baselines)
    settings = baselines[0].settings
    good, culprit = (_prepare(r, settings) for r in requests)
    culprit.channels[0].w_segments[0][10] = np.nan
    failed = _fit_networks_isolated([good, culprit], settings, 32)
    assert list(failed) == [id(culprit)]
    assert "non-finite" in str(failed[id(culprit)])
