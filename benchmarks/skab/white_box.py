r"""The SKAB testbed's white box, written from its physics as a user would.

The testbed
-----------
A single-phase motor (about 230 V, 2.4 A at the healthy operating point) drives a
centrifugal pump that circulates water from a tank through pipes and two valves. The logger
writes, once a second: the motor's current and voltage, the motor body's temperature
(``Temperature``), the fluid's temperature (``Thermocouple``), the volume flow
(``Volume Flow RateRMS``), the pressure (quantised to 9 values: an indicator, left out) and
two vibration RMS values (``Accelerometer1RMS``, ``Accelerometer2RMS``).

Which channels are what
-----------------------
* Inputs (exogenous, measured): ``current`` and ``voltage``; their product is the electrical
  power :math:`P = V I` the motor draws. Nothing in the testbed's logs is a controller
  acting on the plant's state, so no input is a controlled input.
* States, all measured: ``motor_temp`` (:math:`T_m`, C), ``fluid_temp`` (:math:`T_f`, C) and
  ``flow`` (:math:`Q`, l/min).
* Outputs without dynamics: ``vibration_1`` and ``vibration_2`` (g). Vibration RMS follows
  the rotor's imbalance and the pump's hydraulic state at once, far faster than a second;
  the white box predicts a constant level for each (``vibration_*_level``), so its one-step
  residual is the channel's own sample difference and the tiers describe it alone. The
  contract allows outputs that are not states (:meth:`output` computes them), so they are
  in.

Derivation
----------
**Two thermal nodes.** The motor converts :math:`P` into shaft power and losses; a
fraction :math:`\lambda` (``loss_fraction``) heats the motor body, the rest is shaft power,
which the pump's hydraulic and friction losses turn into heat in the water (all of it ends
as heat in the circulating water in a closed loop). The motor body (heat capacity
:math:`C_m`) exchanges heat with the fluid through the pump housing (conductance
:math:`G_{mf}`) and loses heat to the room (:math:`G_{ma}`); the fluid (the tank and the
pipes, :math:`C_f`) loses heat to the room (:math:`G_{fa}`), at the room temperature
:math:`T_a` (not measured: a parameter):

.. math::

    C_m \dot T_m &= \lambda P - G_{mf} (T_m - T_f) - G_{ma} (T_m - T_a)

    C_f \dot T_f &= (1 - \lambda) P + G_{mf} (T_m - T_f) - G_{fa} (T_f - T_a)

**Flow.** At a fixed valve setting the pump delivers more water the more power it draws; at
the testbed's one healthy operating point the pump curve is taken as proportional,
:math:`Q_p(P) = k_Q P` (``flow_per_watt``). The measured flow follows it as a first-order
lag of time constant :math:`\tau_Q` (``flow_time_constant``: the water column's inertia
and the flow meter's RMS averaging):

.. math:: \tau_Q \dot Q = k_Q P - Q

Default parameters
------------------
The healthy file (``anomaly-free.csv`` without its last 572 rows) holds one operating point
for 2 h 27 min: the electrical power moves only by sensor noise (standard deviation about
122 W at 1 s, around a mean of 551 W), so a free least-squares fit of the thermal
parameters cannot separate them (bounded fits on 60-s means drive the heating gain and the
motor-fluid coupling to 0, and every node then relaxes to its own level). As a user would,
the capacities, the loss fraction and the room temperature are therefore set from the
testbed's physics, and the conductances from an energy balance at the healthy file's mean
operating point (:func:`benchmarks.skab.estimate.energy_balance_defaults`):

* ``motor_capacity`` 3000 J/K: about 6 kg of steel and copper at 500 J/(kg K);
* ``fluid_capacity`` 4.19e5 J/K: about 100 l of water in the tank and pipes;
* ``loss_fraction`` 0.3: a small single-phase motor is 60-75 % efficient;
* ``motor_fluid_conductance`` 1 W/K: the pump housing's contact, small;
* ``ambient_temp`` 22 C: a laboratory room;
* ``motor_ambient_conductance``: the motor's losses not passed to the fluid, over its excess
  temperature over the room, at the mean point (the motor body is close to steady there);
* ``fluid_ambient_conductance``: the fluid's heat input less what its measured mean warming
  stores, over its excess temperature;
* ``flow_per_watt``: the mean flow over the mean power;
* ``flow_time_constant``: a least-squares fit of the flow's 1-s changes on the lag
  :math:`(k_Q P - Q)`, on the 1-s steps of the healthy file.

The current and voltage the white box sees are their trailing 60-s means
(:func:`benchmarks.skab.data.average_inputs`): the logged 1-s readings scatter by about
20 %, which the motor's and the water's heat capacities and the pump's inertia average out
but a one-step prediction would not.

The values (printed by ``python -m benchmarks.skab.estimate``) are recorded below, rounded.
"""
from __future__ import annotations

import numpy as np

from graybox.exceptions import ModelSpecError
from graybox.models.base import WhiteBoxModel

#: SKAB's column names -> the white box's variable names (``columns=`` of the model takes the
#: inverse: variable -> column).
SKAB_COLUMNS = {
    "Temperature": "motor_temp",
    "Thermocouple": "fluid_temp",
    "Volume Flow RateRMS": "flow",
    "Accelerometer1RMS": "vibration_1",
    "Accelerometer2RMS": "vibration_2",
    "Current": "current",
    "Voltage": "voltage",
}


class SkabPump(WhiteBoxModel):
    """The SKAB water-circulation testbed: two thermal nodes, the flow as a first-order lag
    toward a pump curve, vibration RMS as two channels without dynamics.

    Temperatures in C, flow in l/min, current in A, voltage in V, capacities in J/K,
    conductances in W/K, vibration in g. The derivation is the module's docstring.
    """

    states = ("motor_temp", "fluid_temp", "flow")
    inputs = ("current", "voltage")
    outputs = ("motor_temp", "fluid_temp", "flow", "vibration_1", "vibration_2")
    default_parameters = {
        "motor_capacity": 3000.0,            # C_m, J/K
        "fluid_capacity": 4.19e5,            # C_f, J/K (about 100 l of water)
        "loss_fraction": 0.3,                # lambda: share of P heating the motor body
        "motor_fluid_conductance": 1.0,      # G_mf, W/K
        "motor_ambient_conductance": 1.53,   # G_ma, W/K (energy balance, healthy file)
        "fluid_ambient_conductance": 52.5,   # G_fa, W/K (energy balance, healthy file)
        "ambient_temp": 22.0,                # T_a, C
        "flow_per_watt": 0.228,              # k_Q, l/min per W (mean flow / mean power)
        "flow_time_constant": 235.0,         # tau_Q, s (least squares on 1-s steps)
        "vibration_1_level": 0.212,          # g, the healthy file's mean
        "vibration_2_level": 0.268,          # g, the healthy file's mean
    }

    def check_parameters(self) -> None:
        p = self.parameters
        positive = ("motor_capacity", "fluid_capacity", "flow_time_constant", "flow_per_watt")
        non_negative = ("motor_fluid_conductance", "motor_ambient_conductance",
                        "fluid_ambient_conductance")
        bad = [n for n in positive if p[n] <= 0] + [n for n in non_negative if p[n] < 0]
        if not 0 <= p["loss_fraction"] <= 1:
            bad.append("loss_fraction")
        if bad:
            raise ModelSpecError(f"{type(self).__name__}: parameter(s) {', '.join(bad)} out of "
                                 f"their physical range (capacities, time constant and pump "
                                 f"gain > 0, conductances >= 0, loss fraction in [0, 1])")

    def electrical_power(self, u: np.ndarray) -> np.ndarray:
        """``P = V I`` in W, from the inputs ``(current, voltage)``."""
        return u[..., 0] * u[..., 1]

    def derivatives(self, x, u):
        p = self.parameters
        motor, fluid, flow = x[..., 0], x[..., 1], x[..., 2]
        power = self.electrical_power(u)
        to_fluid = p["motor_fluid_conductance"] * (motor - fluid)
        d_motor = (p["loss_fraction"] * power - to_fluid
                   - p["motor_ambient_conductance"] * (motor - p["ambient_temp"])
                   ) / p["motor_capacity"]
        d_fluid = ((1 - p["loss_fraction"]) * power + to_fluid
                   - p["fluid_ambient_conductance"] * (fluid - p["ambient_temp"])
                   ) / p["fluid_capacity"]
        d_flow = (p["flow_per_watt"] * power - flow) / p["flow_time_constant"]
        return np.stack([d_motor, d_fluid, d_flow], axis=-1)

    def output(self, x, u):
        p = self.parameters
        level = np.ones_like(x[..., 0])
        return np.stack([x[..., 0], x[..., 1], x[..., 2], p["vibration_1_level"] * level,
                         p["vibration_2_level"] * level], axis=-1)
