import numpy as np
import pytest

from graybox import (FitRequest, GrayBox, GrayBoxError, GrayBoxSettings, InsufficientDataError,
                     Signature, TelemetryError, compute_drift, decompose, fit_signatures,
                     fit_baselines, load_model)
from graybox.simulation import FleetSpec, VehicleSpec, simulate_fleet


def day_frames(frame):
    frame = frame.set_index("timestamp")
    return [day for _, day in frame.groupby(frame.index.floor("1D"))]


@pytest.fixture(scope="module")
def fleet():
    spec = FleetSpec((VehicleSpec("A", 1), VehicleSpec("B", 2)), days=5, sample_interval=30.0)
    return {k: day_frames(v) for k, v in simulate_fleet(spec).items()}


@pytest.fixture(scope="module")
def model():
    return load_model("graybox.models:GasTurbineShaft", columns={"omega": "shaft_speed"})


@pytest.fixture(scope="module")
def baseline(fleet, model):
    return GrayBox(model, random_state=3).fit(fleet["A"][:4])


def test_baseline_has_structure_tiers_and_calibration(baseline):
    sig, calibration = baseline.signature_, baseline.calibration_
    channel = sig.channel("omega")
    assert channel.selection is not None and channel.linear.order == channel.structure.ar_order
    assert channel.linear.is_stationary
    assert channel.nonlinear.heldout_gain is not None
    assert calibration.n_windows == 4 * GrayBoxSettings().calibration_splits
    assert {t.tier for t in calibration.thresholds} == {"linear", "nonlinear", "noise", "level"}
    assert Signature.from_json(sig.to_json()) == sig
    assert sig.window_start.startswith("2026-01-01") and sig.window_end.startswith("2026-01-05")


def test_fitting_is_reproducible(fleet, model, baseline):
    again = GrayBox(model, random_state=3).fit(fleet["A"][:4])
    assert again.signature_ == baseline.signature_
    assert again.calibration_ == baseline.calibration_


def test_candidate_uses_the_frozen_structure_and_settings(fleet, model, baseline):
    candidate = GrayBox(model, baseline=baseline.signature_).fit(fleet["A"][4]).signature_
    assert candidate.frozen_structure() == baseline.signature_.frozen_structure()
    assert candidate.channel("omega").selection is None
    drift = compute_drift(candidate, baseline.signature_, baseline.calibration_)
    assert {(e.channel, e.tier) for e in drift.entries} == {
        ("omega", "linear"), ("omega", "nonlinear"), ("omega", "noise"), ("omega", "level")}
    with pytest.raises(GrayBoxError, match="baseline's settings"):
        GrayBox(model, baseline=baseline.signature_,
                settings=GrayBoxSettings(hidden_units=4)).fit(fleet["A"][4])
    mixed = fit_signatures([FitRequest(model, [fleet["A"][4]], baseline=baseline.signature_)],
                           settings=GrayBoxSettings(hidden_units=4))[0]
    assert mixed.settings == baseline.signature_.settings   # a candidate follows its baseline


def test_batched_candidates_equal_candidates_fitted_alone(fleet, model, baseline):
    requests = [FitRequest(model, [day], baseline=baseline.signature_) for day in fleet["B"]]
    together = fit_signatures(requests)
    alone = [fit_signatures([request])[0] for request in requests]
    assert together == alone


def test_one_bad_asset_does_not_stop_the_batch(fleet, model, baseline):
    broken = fleet["B"][4].drop(columns=["fuel_rate"])
    good = FitRequest(model, [fleet["B"][4]], baseline=baseline.signature_, asset_id="B")
    bad = FitRequest(model, [broken], baseline=baseline.signature_, asset_id="C")
    results = fit_signatures([bad, good])
    assert isinstance(results[0], TelemetryError) and "fuel_rate" in str(results[0])
    assert isinstance(results[1], Signature) and results[1].asset_id == "B"


def test_calibration_needs_three_windows(fleet, model):
    with pytest.raises(InsufficientDataError, match="at least 3 healthy windows"):
        GrayBox(model).fit(fleet["A"][:2])
    uncalibrated = GrayBox(model, calibrate=False).fit(fleet["A"][:2])
    assert uncalibrated.calibration_ is None


def test_decompose_reassembles_the_tiers(fleet, model, baseline):
    sig = baseline.signature_
    parts = decompose(sig, model, fleet["A"][0])[0]
    structure = sig.channel("omega").structure
    assert len(parts.stationary) == len(parts.residual) - structure.differencing.lost
    # the AR tier's forecast is sum_i a_i z(t - i), computed here independently
    z, a = parts.stationary.to_numpy(), np.asarray(sig.channel("omega").linear.coefficients)
    n = len(a)
    expected = [a @ z[t - n: t][::-1] for t in range(n, len(z))]
    np.testing.assert_allclose(parts.ar_prediction.to_numpy(), expected, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(parts.ar_residual.to_numpy(), z[n:] - np.asarray(expected),
                               rtol=1e-10, atol=1e-12)
    assert parts.noise.index.equals(parts.network_prediction.index)


def test_a_baseline_does_not_depend_on_the_assets_fitted_with_it(fleet, model):
    """Batches, memory groups and Dask workers split a fleet differently; a baseline and its
    calibration must come out the same whichever assets share its fit."""
    alone = fit_baselines([FitRequest(model, fleet["A"][:4], asset_id="A")])[0]
    together = fit_baselines([FitRequest(model, fleet["B"][:4], asset_id="B"),
                              FitRequest(model, fleet["A"][:4], asset_id="A")])[1]
    assert together == alone
    assert all(len(t.day_zetas) == 4 for t in alone[1].thresholds)


def test_windows_at_different_steps_name_the_grid_setting_that_aligns_them(fleet, model):
    days = fleet["A"][:3]
    slower = [days[0], days[1].iloc[::2], days[2]]     # one day logged every 60 s
    result = fit_signatures([FitRequest(model, slower, asset_id="A")])[0]
    assert isinstance(result, GrayBoxError)
    assert "windows have different sample intervals: [30.0, 60.0] s" in str(result)
    assert 'grid = { sample_interval = "30s" }' in str(result)
