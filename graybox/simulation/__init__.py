r"""The fleet simulator: gas-turbine vehicles with daily load cycles, a random moment and faults.

The true plant of every vehicle is :class:`~graybox.models.gas_turbine.GasTurbineShaft`
(Eq. 5 of the paper), integrated with the model's own ``derivatives`` (the vehicles' models
stacked into one, see :meth:`~graybox.models.base.WhiteBoxModel.stacked`), plus what the
model lacks: a random moment ``Gamma(t) = M_r(t) / J`` and the faults:

.. math:: \dot\omega = [M_1(\omega, \mu) - M_2(\omega)] / J + \Gamma(t)
          + \text{(fault terms)}

The sign is chosen so that the residual of the white box (Eqs. 2-3, 13) is ``+Gamma``-like.

The simulated physical process does not depend on the sampling interval ``dt``:

- ``Gamma`` lives on a fixed physical clock of :data:`MOMENT_STEP` (10 s): it is constant
  over each moment step ``[i 10 s, (i + 1) 10 s)`` and is an AR(2) "torsional" process over
  those steps with poles at radius 0.9 and angle ``2 pi / 8``, innovations
  ``u_i = e_i + kappa He3(e_{i-1})`` (``kappa = 0`` when healthy).
- Fuel rate ``mu(t) = mu0 (1 + A sin(2 pi t / 1 day + phase) + w(t))``, ``w`` a slow
  Ornstein-Uhlenbeck wander drawn at the moment-step instants (exact in law) and linear
  between them; the fuel sensor adds a tiny white noise.
- The plant is integrated with RK4, ``substeps`` steps per integration step, ``mu`` linear
  inside a step, started at the equilibrium speed. The integration step is ``dt`` when
  ``dt`` divides 10 s (1, 2, 5 s, ...), each sample seeing the ``Gamma`` of the moment step
  it lies in, and 10 s when ``dt`` is a multiple of 10 s (30, 60 s, ...), every
  ``dt / 10``-th state being a sample. Other intervals are refused.
- Measured shaft speed = ``omega`` + sensor noise + bias, the noise white per sample.
- The plant's fault levels (friction, flutter) are held over each moment step like
  ``Gamma``; the sensor's (noise, heavy tails, bias) are taken at each sample.

So the random streams of the moment clock (the wander, the shocks ``e_i`` and therefore
``Gamma`` and the flutter) and the fuel phase are shared by every ``dt``: the true shaft
speed of one vehicle at 1 s, 10 s and 60 s agrees at the common instants up to integration
error. The per-sample streams (sensor noise, its heavy tails, fuel-sensor noise, jitter,
drops) are drawn per sample and differ between rates. At 10 s the output is the one of the
earlier per-sample design to a relative 1e-12 (pinned in
``tests/graybox/test_simulator_reference.py``).

Faults (:class:`Fault`) act from their onset on; every random stream of a vehicle is drawn
from its own seed independently of its faults, so a faulty vehicle and a healthy vehicle
with the same seed share everything up to the fault's onset (a counterfactual pair).

All vehicles of a fleet are integrated together in one time loop. The loop is also
vectorised over time: the time axis is cut into chunks that are integrated side by side,
each chunk after the first starting a warm-up of :data:`WARMUP_SECONDS` earlier from the
equilibrium speed. The shaft is strongly damped (``gamma ~ 0.06`` 1/s), so the warm-up
forgets its start to rounding level; the splice of every chunk is checked against the
previous chunk, and a vehicle whose splices differ by more than :data:`SPLICE_TOLERANCE`
(a very weakly damped plant) is integrated serially instead. The chunk layout depends only
on the time grid, so a vehicle's data do not depend on the other vehicles of the fleet.

Modules: :mod:`~graybox.simulation.faults` (what can go wrong),
:mod:`~graybox.simulation.specs` (vehicles and fleets), :mod:`~graybox.simulation.clock`
(time grids), :mod:`~graybox.simulation.draws` (random inputs),
:mod:`~graybox.simulation.plant` (integration), :mod:`~graybox.simulation.fleet` (the
simulate and write functions), :mod:`~graybox.simulation.scenarios` (demo fleet, wrong white
boxes) and :mod:`~graybox.simulation.langevin` (Eq. 8); this package exports their public
names. ``python -m graybox.simulation`` prints a summary of the demo fleet.
"""
from graybox.simulation.clock import MOMENT_STEP, SECONDS_PER_DAY, moment_steps_ratio
from graybox.simulation.draws import moment_ar_coefficients
from graybox.simulation.faults import FAULT_KINDS, Fault
from graybox.simulation.fleet import (TRUTH_FILE, simulate_fleet, simulate_fleet_with_truth,
                                      write_fleet)
from graybox.simulation.langevin import simulate_langevin
from graybox.simulation.scenarios import demo_fleet, white_box_parameters
from graybox.simulation.specs import FleetSpec, VehicleSpec

__all__ = ["FAULT_KINDS", "MOMENT_STEP", "SECONDS_PER_DAY", "TRUTH_FILE", "Fault",
           "VehicleSpec", "FleetSpec", "simulate_fleet", "simulate_fleet_with_truth",
           "write_fleet", "demo_fleet", "simulate_langevin", "white_box_parameters",
           "moment_ar_coefficients", "moment_steps_ratio"]
