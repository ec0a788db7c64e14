"""What to simulate: a vehicle (seed, faults, plant, noise levels) and a fleet (its time grid)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import pandas as pd

from graybox.models.gas_turbine import GasTurbineShaft
from graybox.simulation.checks import finite, integer, unknown_keys
from graybox.simulation.clock import SECONDS_PER_DAY, moment_steps_ratio
from graybox.simulation.faults import Fault
from graybox.telemetry import validate_asset_id
from graybox.timestamps import utc


@dataclass(frozen=True)
class VehicleSpec:
    """One simulated vehicle.

    Parameters
    ----------
    asset_id : str
        Valid asset id (``[A-Za-z0-9_.-]{1,64}``).
    seed : int
        Seed (>= 0) of every random stream of the vehicle.
    faults : tuple of Fault, default ()
    plant_parameters : mapping of str to float, optional
        Overrides of :class:`GasTurbineShaft` defaults for the true plant (for example a
        vehicle-to-vehicle spread).
    sensor_noise : float, default 0.3
        Std (rad/s) of the healthy shaft-speed sensor noise.
    moment_std : float, default 0.2
        Std (rad/s^2) of the healthy random moment ``Gamma``.

    Raises
    ------
    ValueError, InvalidAssetIdError, ModelSpecError
        On an invalid field, asset id or plant parameter.
    """

    asset_id: str
    seed: int
    faults: tuple[Fault, ...] = ()
    plant_parameters: Mapping[str, float] | None = None
    sensor_noise: float = 0.3
    moment_std: float = 0.2

    def __post_init__(self):
        validate_asset_id(self.asset_id)
        integer(self.seed, "VehicleSpec.seed", 0)
        faults = tuple(self.faults)
        if not all(isinstance(f, Fault) for f in faults):
            raise ValueError(f"VehicleSpec.faults must hold Fault instances, got {faults!r}")
        object.__setattr__(self, "faults", faults)
        if self.plant_parameters is not None:
            # a private copy keeps the frozen spec immune to later changes of the caller's dict
            parameters = {str(k): float(v) for k, v in dict(self.plant_parameters).items()}
            GasTurbineShaft(parameters)  # validates names and stability (ModelSpecError)
            object.__setattr__(self, "plant_parameters", parameters)
        for name in ("sensor_noise", "moment_std"):
            value = finite(getattr(self, name), f"VehicleSpec.{name}")
            if value < 0:
                raise ValueError(f"VehicleSpec.{name} must be >= 0, got {value}")
            object.__setattr__(self, name, value)

    def __hash__(self):
        parameters = None if self.plant_parameters is None else tuple(
            sorted(self.plant_parameters.items()))
        return hash((self.asset_id, self.seed, self.faults, parameters, self.sensor_noise,
                     self.moment_std))

    def plant(self) -> GasTurbineShaft:
        """The vehicle's true plant."""
        return GasTurbineShaft(self.plant_parameters)

    def to_dict(self) -> dict:
        """JSON-friendly dict; :meth:`from_dict` rebuilds an equal spec."""
        return {"asset_id": self.asset_id, "seed": self.seed,
                "faults": [f.to_dict() for f in self.faults],
                "plant_parameters": (None if self.plant_parameters is None
                                     else dict(self.plant_parameters)),
                "sensor_noise": self.sensor_noise, "moment_std": self.moment_std}

    @classmethod
    def from_dict(cls, d: Mapping) -> "VehicleSpec":
        """Inverse of :meth:`to_dict`."""
        unknown_keys(d, ("asset_id", "seed", "faults", "plant_parameters", "sensor_noise",
                          "moment_std"), "VehicleSpec")
        d = dict(d)
        d["faults"] = tuple(Fault.from_dict(f) for f in d.get("faults", ()))
        return cls(**d)


@dataclass(frozen=True)
class FleetSpec:
    """A simulated fleet: its vehicles and the time grid.

    Parameters
    ----------
    vehicles : tuple of VehicleSpec
        Distinct asset ids.
    days : int, default 10
    start : str, default "2026-01-01"
        Start instant, anything :class:`pandas.Timestamp` parses; naive means UTC.
    sample_interval : float, default 10.0
        Seconds between samples: one that divides the 10-s moment step (1, 2, 5, 10 s, ...)
        or a multiple of it (30, 60 s, ...), see :func:`moment_steps_ratio`.
    substeps : int, default 4
        RK4 steps per integration step: per sample up to 10 s, per 10-s moment step above.
    jitter : float, default 0.0
        Std in seconds of the timestamp jitter (uneven sampling), clipped to
        ``+-0.4 sample_interval``; the measured values are those at the jittered instants.
    drop_fraction : float, default 0.0
        Fraction of samples dropped at random, in ``[0, 0.5]``; never more than 2 consecutive.

    Raises
    ------
    ValueError
        On an invalid field or repeated asset id.
    """

    vehicles: tuple[VehicleSpec, ...]
    days: int = 10
    start: str = "2026-01-01"
    sample_interval: float = 10.0
    substeps: int = 4
    jitter: float = 0.0
    drop_fraction: float = 0.0

    def __post_init__(self):
        vehicles = tuple(self.vehicles)
        if not all(isinstance(v, VehicleSpec) for v in vehicles):
            raise ValueError("FleetSpec.vehicles must hold VehicleSpec instances")
        ids = [v.asset_id for v in vehicles]
        repeated = sorted({i for i in ids if ids.count(i) > 1})
        if repeated:
            raise ValueError(f"FleetSpec: repeated asset id(s) {repeated}")
        object.__setattr__(self, "vehicles", vehicles)
        integer(self.days, "FleetSpec.days", 1)
        integer(self.substeps, "FleetSpec.substeps", 1)
        interval = finite(self.sample_interval, "FleetSpec.sample_interval")
        if interval <= 0:
            raise ValueError(f"FleetSpec.sample_interval must be > 0, got {interval}")
        try:
            moment_steps_ratio(interval)
        except ValueError as error:
            raise ValueError(f"FleetSpec.{error}") from None
        object.__setattr__(self, "sample_interval", interval)
        jitter = finite(self.jitter, "FleetSpec.jitter")
        drop = finite(self.drop_fraction, "FleetSpec.drop_fraction")
        if jitter < 0:
            raise ValueError(f"FleetSpec.jitter must be >= 0, got {jitter}")
        if not 0 <= drop <= 0.5:
            raise ValueError(f"FleetSpec.drop_fraction must be in [0, 0.5], got {drop}")
        object.__setattr__(self, "jitter", jitter)
        object.__setattr__(self, "drop_fraction", drop)
        if not isinstance(self.start, str):  # a Timestamp or datetime: keep the spec JSON-friendly
            try:
                object.__setattr__(self, "start", pd.Timestamp(self.start).isoformat())
            except (ValueError, TypeError):
                pass  # reported below
        try:
            self.start_timestamp
        except (ValueError, TypeError) as error:
            raise ValueError(
                f"FleetSpec.start {self.start!r} is not a timestamp: {error}") from None
        if self.n_samples < 2:
            raise ValueError("FleetSpec: the time grid needs at least 2 samples")

    @property
    def start_timestamp(self) -> pd.Timestamp:
        """``start`` as a UTC timestamp."""
        stamp = pd.Timestamp(self.start)
        if stamp is pd.NaT:
            raise ValueError("NaT")
        return utc(stamp)

    @property
    def n_samples(self) -> int:
        """Samples per vehicle before drops: every grid instant in ``[start, start + days)``."""
        return int(math.ceil(self.days * SECONDS_PER_DAY / self.sample_interval - 1e-9))

    def to_dict(self) -> dict:
        """JSON-friendly dict; :meth:`from_dict` rebuilds an equal spec."""
        return {"vehicles": [v.to_dict() for v in self.vehicles], "days": self.days,
                "start": self.start, "sample_interval": self.sample_interval,
                "substeps": self.substeps, "jitter": self.jitter,
                "drop_fraction": self.drop_fraction}

    @classmethod
    def from_dict(cls, d: Mapping) -> "FleetSpec":
        """Inverse of :meth:`to_dict`."""
        unknown_keys(d, ("vehicles", "days", "start", "sample_interval", "substeps", "jitter",
                          "drop_fraction"), "FleetSpec")
        d = dict(d)
        d["vehicles"] = tuple(VehicleSpec.from_dict(v) for v in d["vehicles"])
        return cls(**d)
