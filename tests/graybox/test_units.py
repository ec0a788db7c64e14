"""Known answer: a channel's units do not move a verdict. The same plant logged in degrees
Celsius and in another unit (a factor and an offset, as kelvin or millikelvin against
Celsius, kPa against Pa and a gauge's zero) gives the same drift ratios on every tier, for a
healthy night and a faulty one: no tolerance, floor or step size in the method is an
absolute number in a channel's units."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import graybox as gb
from graybox.models.base import WhiteBoxModel

DT = 30.0
PER_DAY = int(86400 / DT)
BASELINE_DAYS = 4


class HeatedTank(WhiteBoxModel):
    """A tank's temperature: losses to the ambient and a heater's power (in kW, whatever the
    temperature's unit: ``unit`` is the temperature unit's size in degrees)."""

    states = ("temp",)
    inputs = ("ambient", "heater")
    default_parameters = {"loss": 0.002, "gain": 0.001, "unit": 1.0}

    def derivatives(self, x, u):
        p = self.parameters
        return p["loss"] * (u[..., :1] - x) + p["gain"] / p["unit"] * u[..., 1:2]


def _days(factor: float, offset: float, heater_fault: float) -> list[pd.DataFrame]:
    """Four baseline days and two nights of one tank (the white box 10 % off), its heater's
    gain up by ``heater_fault`` from the fifth day's noon; temperatures in ``factor`` x
    degrees + ``offset``."""
    rng = np.random.default_rng(7)
    days = BASELINE_DAYS + 2
    t = np.arange(days * PER_DAY) * DT
    ambient = 10 + 5 * np.sin(2 * np.pi * t / 86400) + np.cumsum(rng.normal(0, 0.02, len(t)))
    heater = np.clip(50 + 30 * np.sin(2 * np.pi * t / 3600) + rng.normal(0, 5, len(t)), 0, None)
    onset = int((BASELINE_DAYS + 0.5) * PER_DAY)
    gain = np.where(np.arange(len(t)) >= onset, 0.0011 * heater_fault, 0.0011)
    temp = np.empty(len(t))
    temp[0] = 20.0
    steps = rng.normal(0, 0.02, len(t))
    for i in range(1, len(t)):
        temp[i] = temp[i - 1] + DT * (0.0022 * (ambient[i - 1] - temp[i - 1])
                                      + gain[i - 1] * heater[i - 1]) + steps[i]
    temp = temp + rng.normal(0, 0.05, len(t))
    index = pd.date_range("2026-01-05", periods=len(t), freq=f"{int(DT)}s", tz="UTC")
    frame = pd.DataFrame({"temp": temp * factor + offset, "ambient": ambient * factor + offset,
                          "heater": heater}, index=index)
    return [frame.iloc[d * PER_DAY:(d + 1) * PER_DAY] for d in range(days)]


def _ratios(factor: float, offset: float, heater_fault: float) -> dict[str, float]:
    model = HeatedTank({"unit": 1.0 / factor})
    days = _days(factor, offset, heater_fault)
    [(baseline, calibration)] = gb.fit_baselines(
        [gb.FitRequest(model, days[:BASELINE_DAYS], asset_id="T-1", seed=0)])
    [candidate] = gb.fit_signatures(
        [gb.FitRequest(model, days[BASELINE_DAYS:], baseline=baseline, asset_id="T-1")])
    drift = gb.compute_drift(baseline, candidate, calibration)
    return {e.tier: e.ratio for e in drift.entries}


@pytest.mark.parametrize("heater_fault", [1.0, 1.2], ids=["healthy", "heater gain +20 %"])
def test_the_drift_ratios_do_not_depend_on_the_channels_units(heater_fault):
    celsius = _ratios(1.0, 0.0, heater_fault)
    # millikelvin: a factor of 1,000 and an offset of 273,150
    millikelvin = _ratios(1000.0, 273150.0, heater_fault)
    assert set(celsius) == {"level", "linear", "nonlinear", "noise"}
    assert millikelvin == pytest.approx(celsius, rel=1e-6)
    alarmed = celsius["level"] > 1.0
    assert alarmed == (heater_fault != 1.0)
