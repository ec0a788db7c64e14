"""The hypothesis each fault kind of four plant-zoo families should produce, how its estimate
reads as the fault's magnitude, and the white-box parameters tuned on the baseline days.

Declared in the benchmark (the families describe their faults in words,
:mod:`benchmarks.zoo.families`); a fault kind without a single physical counterpart in the
family's coarse white box expects nothing and its first answer is reported.

``pendulum_crane`` (small-angle pendulum ``L theta'' + c theta' + g theta = -a``): damping up
by ``m`` -> ``parameter damping`` (``estimate / baseline - 1``); rope longer by ``m`` ->
``parameter length`` (same); the angle sensor ``m`` rad high -> ``theta sensor bias``
(the estimate); the rate sensor's noise times ``1 + m`` -> ``omega noise level`` (no size:
the noise hypothesis sees the one-step innovations' spread, of which the sensor noise is a
share).
Tuned: ``damping`` and ``length`` (the white box's damping is 10-20 % off and its length
nominal; ``g`` is fixed, so both are identifiable).

``hydraulic_level`` (two tanks with linear flow laws): pipe conductance down by ``m`` ->
``parameter g12`` (``1 - estimate / baseline``); the flow meter ``m`` high -> ``q sensor
gain`` (the estimate); the tank-2 level sensor's noise times ``1 + m`` -> ``h2 noise level``;
a leak from tank 1 has no parameter of its own (it reads like a flow meter reading high, or a
larger ``g12``): nothing expected. Tuned: ``g12``, ``g_demand``, ``q_max`` (the flow is
measured, so the linear laws' scale is fixed).

Two held-out (blind) families, declared from their docstrings' physics, untuned (the white
box as its user wrote it, 10-20 % off: a user of a new plant starts there):

``heat_pump`` (water and house nodes; heat = COP(outdoor) x power, COP linear in the
outdoor temperature): refrigerant undercharge (heat down by ``m``, COP by ``m / 2``) ->
``parameter cop_at_0`` (``2 (1 - estimate / baseline)``: the heat per unit of power falls
by about ``m / 2``); the 4-way valve's leak (heat down by ``m`` at the same power) ->
``parameter cop_at_0`` (``1 - estimate / baseline``); the outdoor fan's air flow down ->
``parameter cop_at_0`` (a colder evaporator: less heat per unit of power; no size, the
white box has no fan); the supply sensor drifting low -> ``supply sensor bias`` (no size: a
drift, not a step); the circulation flow down by ``m`` -> ``parameter flow``
(``1 - estimate / baseline``).

``heat_substation`` (the exchanger as two nodes exchanging ``ua``; the secondary loop's
flow ``secondary_flow``): fouling (``ua`` down by ``m``) -> ``parameter ua`` (``1 -
estimate / baseline``); the worn pump (circulation flow down by ``m``) -> ``parameter
secondary_flow`` (same); the secondary supply sensor's noise up -> ``secondary_supply noise
level``; valve stiction (no dead band in the white box) and the heat meter's supply-sensor
bias (an input of the white box: the plant does not respond to it) expect nothing.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable


def _relative_up(estimate: float, baseline: float) -> float:
    return estimate / baseline - 1.0 if baseline else math.nan


def _relative_down(estimate: float, baseline: float) -> float:
    return 1.0 - estimate / baseline if baseline else math.nan


def _itself(estimate: float, baseline: float) -> float:
    return estimate


def _twice_relative_down(estimate: float, baseline: float) -> float:
    return 2.0 * (1.0 - estimate / baseline) if baseline else math.nan


def _unknown(estimate: float, baseline: float) -> float:
    return math.nan


@dataclass(frozen=True)
class FamilyExpectation:
    """A family's expected hypotheses (fault kind -> (kind, target) and the estimate's
    implied magnitude) and its tuned parameters."""

    expected: dict
    implied: dict
    tuned: tuple

    def hypothesis(self, fault: str) -> tuple[str, str] | None:
        return self.expected.get(fault)

    def magnitude(self, fault: str) -> Callable[[float, float], float]:
        return self.implied.get(fault, _unknown)


ZOO = {
    "pendulum_crane": FamilyExpectation(
        expected={"damping": ("parameter", "damping"), "rope": ("parameter", "length"),
                  "angle_bias": ("bias", "theta"), "rate_noise": ("noise", "omega")},
        implied={"damping": _relative_up, "rope": _relative_up, "angle_bias": _itself},
        tuned=("damping", "length")),
    "hydraulic_level": FamilyExpectation(
        expected={"clogging": ("parameter", "g12"), "meter_gain": ("gain", "q"),
                  "level_noise": ("noise", "h2")},
        implied={"clogging": _relative_down, "meter_gain": _itself},
        tuned=("g12", "g_demand", "q_max")),
    "heat_pump": FamilyExpectation(
        expected={"refrigerant_undercharge": ("parameter", "cop_at_0"),
                  "fan_degradation": ("parameter", "cop_at_0"),
                  "valve_leak": ("parameter", "cop_at_0"),
                  "supply_sensor_drift": ("bias", "supply"),
                  "pump_flow_loss": ("parameter", "flow")},
        implied={"refrigerant_undercharge": _twice_relative_down, "valve_leak": _relative_down,
                 "pump_flow_loss": _relative_down},
        tuned=()),
    "heat_substation": FamilyExpectation(
        expected={"exchanger_fouling": ("parameter", "ua"),
                  "pump_wear": ("parameter", "secondary_flow"),
                  "sensor_noise": ("noise", "secondary_supply")},
        implied={"exchanger_fouling": _relative_down, "pump_wear": _relative_down},
        tuned=()),
}
