"""Issue 21 item 3: a new tier is one class and one registration, passed to the fit (no
global state): it is fitted, kept in the signature's JSON round trip and its drift computed."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pytest

from graybox import (Calibration, FitRequest, GrayBox, Signature, compute_drift, fit_baselines,
                     fit_signatures, load_model)
from graybox.simulation import FleetSpec, VehicleSpec, simulate_fleet
from graybox.tiers import TIER_KINDS, TIERS, Tier


@dataclass(frozen=True)
class MeanAbsolute:
    """The toy tier's record: the residual's mean absolute value."""

    value: float


class MeanAbsoluteTier(Tier):
    """A toy tier: the mean absolute value of a channel's residual (at the analysis rate)."""

    name = "mean_abs"
    tensor_part = "value"
    record_type = MeanAbsolute
    stage = "mean_abs"

    def fit(self, asset, settings):
        for channel in asset.channels:
            residual = np.concatenate(channel.segments)
            channel.records[self.name] = MeanAbsolute(float(np.mean(np.abs(residual))))

    def parameters(self, channel):
        return ["value"], np.array([self.record(channel).value])


KINDS = TIER_KINDS + (MeanAbsoluteTier(),)


def simulated_days(seed: int, days: int):
    """The turbine model and vehicle V-1 (of ``seed``) simulated for ``days`` days, a frame
    per day."""
    frames = simulate_fleet(FleetSpec((VehicleSpec("V-1", seed),), days=days))["V-1"]
    frames = frames.set_index("timestamp")
    model = load_model("graybox.models:GasTurbineShaft", {}, {"omega": "shaft_speed"})
    return model, [day for _, day in frames.groupby(frames.index.floor("1D"))]


@pytest.fixture(scope="module")
def fits():
    model, days = simulated_days(40, 3)
    plain = fit_signatures([FitRequest(model, days[:2], asset_id="V-1")])[0]
    baseline = fit_signatures([FitRequest(model, days[:2], asset_id="V-1")], kinds=KINDS)[0]
    candidate = fit_signatures([FitRequest(model, days[2:], baseline=baseline)],
                               kinds=KINDS)[0]
    return plain, baseline, candidate


def test_the_new_tier_is_fitted_beside_the_built_in_ones_which_it_leaves_unchanged(fits):
    plain, baseline, candidate = fits
    kind = KINDS[-1]
    for signature in (baseline, candidate):
        assert isinstance(signature, Signature), signature
        channel = signature.channel("omega")
        assert kind.present(channel) and kind.record(channel).value > 0
    # the built-in tiers are fitted exactly as without it
    without = dataclasses.replace(baseline, channels=tuple(
        dataclasses.replace(c, tiers=None) for c in baseline.channels))
    assert without.to_json() == plain.to_json()
    assert not kind.present(plain.channel("omega"))
    # registering it for one fit changed no global registry
    assert TIERS == ("linear", "nonlinear", "noise", "level") and kind not in TIER_KINDS


def test_the_new_tier_survives_the_signature_json_round_trip(fits):
    _, baseline, candidate = fits
    kind = KINDS[-1]
    for signature in (baseline, candidate):
        back = Signature.from_json(signature.to_json())
        assert back == signature
        assert kind.record(back.channel("omega")) == kind.record(signature.channel("omega"))
        names, values = back.parameter_vector(KINDS)
        assert names[-1] == "omega.mean_abs.value"
        assert values[-1] == kind.record(signature.channel("omega")).value


def test_the_new_tier_is_in_the_summary_it_is_given_to(fits):
    plain, baseline, _ = fits
    value = KINDS[-1].record(baseline.channel("omega")).value
    shown = baseline.summary(kinds=KINDS)
    assert shown.startswith(baseline.summary().removesuffix("=" * 78))
    *_, heading, line, end = shown.splitlines()
    assert (heading, line.split(), end) == ("Tier mean_abs", ["value:", f"{value:.4f}"], "=" * 78)
    assert "Tier mean_abs" not in baseline.summary() and \
        plain.summary(kinds=KINDS) == plain.summary()


def test_the_new_tier_has_its_drift(fits):
    _, baseline, candidate = fits
    kind = KINDS[-1]
    drift = compute_drift(candidate, baseline, kinds=KINDS)
    entry = drift.get("omega", "mean_abs")
    change = (kind.record(candidate.channel("omega")).value
              - kind.record(baseline.channel("omega")).value)
    assert entry.zeta == pytest.approx(change ** 2) and entry.zeta > 0
    assert entry.top_changes[0].name == "value"
    assert [e.tier for e in drift.entries] == [*TIERS, "mean_abs"]
    with pytest.raises(KeyError):  # the default kinds do not know it
        compute_drift(candidate, baseline).get("omega", "mean_abs")


def test_the_new_tier_is_calibrated_like_the_others():
    model, days = simulated_days(41, 4)
    (baseline, calibration), = fit_baselines([FitRequest(model, days[:3], asset_id="V-1")],
                                             kinds=KINDS)
    threshold = calibration.threshold("omega", "mean_abs")
    # epsilon from the same method as every tier: healthy changes of the pieces and days
    assert threshold.epsilon > threshold.mean_zeta > 0 and len(threshold.day_zetas) == 3
    assert calibration.test_alpha == pytest.approx(calibration.false_alarm_rate / 5)
    assert Calibration.from_json(calibration.to_json()) == calibration
    candidate = fit_signatures([FitRequest(model, days[3:], baseline=baseline)], kinds=KINDS)[0]
    entry = compute_drift(candidate, baseline, calibration, kinds=KINDS).get("omega", "mean_abs")
    assert entry.epsilon > 0 and entry.ratio == pytest.approx(entry.zeta / entry.epsilon)


def test_the_estimator_fits_calibrates_and_compares_the_tiers_it_is_given():
    model, days = simulated_days(41, 4)
    box = GrayBox(model, kinds=KINDS).fit(days[:3])
    assert box.kinds is KINDS  # stored as given (scikit-learn's rule)
    # the same baseline and calibration as the fleet form with the same kinds
    (baseline, calibration), = fit_baselines([FitRequest(model, days[:3])], kinds=KINDS)
    assert box.signature_.to_json() == baseline.to_json()
    assert box.calibration_ == calibration
    entry = box.drift(days[3:]).get("omega", "mean_abs")
    candidate = fit_signatures([FitRequest(model, days[3:], baseline=baseline)], kinds=KINDS)[0]
    expected = compute_drift(candidate, baseline, calibration, kinds=KINDS).get("omega", "mean_abs")
    assert entry.zeta == pytest.approx(expected.zeta) and entry.epsilon == expected.epsilon
    with pytest.raises(KeyError):  # without kinds: the built-in tiers only
        GrayBox(model).fit(days[:3]).drift(days[3:]).get("omega", "mean_abs")
