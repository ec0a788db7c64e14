"""Ready-made simulation scenarios: the demo fleet, and deliberately wrong white boxes."""
from __future__ import annotations

import numpy as np

from graybox.models.gas_turbine import GasTurbineShaft, LangevinShaft
from graybox.simulation.checks import finite, integer
from graybox.simulation.faults import Fault
from graybox.simulation.specs import FleetSpec, VehicleSpec

_LOSS_PARAMETERS = ("turbine_slope", "compressor_linear", "compressor_quadratic")


def demo_fleet(n_vehicles: int = 8, days: int = 10, seed: int = 0) -> FleetSpec:
    """A small fleet with a few faulty vehicles, for demos and tests.

    Vehicles ``T-001``, ``T-002``, ...; ``min(3, n_vehicles // 2)`` of them, chosen at random,
    get one fault each: ``friction`` 0.5, ``nonlinear`` 0.3 and ``noise`` 1.0 (in this order),
    with onsets between 60 % and 70 % of ``days`` (days 6-7 of 10). Every vehicle's plant
    parameters are spread by up to +-3 % around the :class:`GasTurbineShaft` defaults.

    Parameters
    ----------
    n_vehicles : int, default 8
    days : int, default 10
    seed : int, default 0

    Returns
    -------
    FleetSpec
    """
    integer(n_vehicles, "n_vehicles", 1)
    integer(days, "days", 1)
    rng = np.random.default_rng(np.random.SeedSequence(integer(seed, "seed", 0)))
    seeds = rng.choice(2 ** 31 - 1, size=n_vehicles, replace=False)
    kinds = (("friction", 0.5), ("nonlinear", 0.3), ("noise", 1.0))[:min(3, n_vehicles // 2)]
    faulty = rng.choice(n_vehicles, size=len(kinds), replace=False)
    faults = {int(i): (Fault(kind, round(float(rng.uniform(0.6, 0.7)) * days, 2), magnitude),)
              for i, (kind, magnitude) in zip(faulty, kinds)}
    defaults = GasTurbineShaft.default_parameters
    vehicles = []
    for i in range(n_vehicles):
        spread = rng.uniform(0.97, 1.03, size=len(defaults))
        parameters = {name: float(value * round(float(f), 4))
                      for (name, value), f in zip(defaults.items(), spread)}
        vehicles.append(VehicleSpec(f"T-{i + 1:03d}", seed=int(seeds[i]),
                                    faults=faults.get(i, ()), plant_parameters=parameters))
    return FleetSpec(tuple(vehicles), days=days)


def white_box_parameters(model_error: float, model: str = "turbine") -> dict[str, float]:
    """Parameters of a deliberately wrong white box, for studies of model error.

    Parameters
    ----------
    model_error : float
        Relative error; ``0.2`` means 20 % off.
    model : {"turbine", "langevin"}
        ``"turbine"``: :class:`GasTurbineShaft` defaults with ``turbine_slope``,
        ``compressor_linear`` and ``compressor_quadratic`` times ``1 + model_error``.
        ``"langevin"``: :class:`LangevinShaft` defaults with ``gamma`` and ``fuel_gain`` times
        ``1 + model_error``.

    Returns
    -------
    dict of str to float
    """
    factor = 1.0 + finite(model_error, "model_error")
    if model == "turbine":
        parameters, scaled = dict(GasTurbineShaft.default_parameters), _LOSS_PARAMETERS
    elif model == "langevin":
        parameters, scaled = dict(LangevinShaft.default_parameters), ("gamma", "fuel_gain")
    else:
        raise ValueError(f"model must be 'turbine' or 'langevin', got {model!r}")
    for name in scaled:
        parameters[name] *= factor
    return parameters
