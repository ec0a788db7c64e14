r"""Fleet simulator: gas-turbine vehicles with daily load cycles, a random moment and faults.

The true plant of every vehicle is :class:`~graybox.models.gas_turbine.GasTurbineShaft`
(Eq. 5 of the paper) driven by a random moment ``Gamma(t) = M_r(t) / J``:

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
earlier per-sample design, bit for bit.

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
"""
from __future__ import annotations

import json
import math
import pathlib
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from graybox.exceptions import GrayBoxError
from graybox.models.gas_turbine import GasTurbineShaft, LangevinShaft
from graybox.telemetry import validate_asset_id, write_telemetry

__all__ = ["FAULT_KINDS", "MOMENT_STEP", "Fault", "VehicleSpec", "FleetSpec",
           "simulate_fleet", "simulate_fleet_with_truth", "write_fleet", "demo_fleet",
           "simulate_langevin", "white_box_parameters", "moment_ar_coefficients",
           "moment_steps_ratio"]

FAULT_KINDS = ("friction", "nonlinear", "noise", "bias", "heavy_tails")

SECONDS_PER_DAY = 86_400.0
MOMENT_STEP = 10.0              # s, the physical clock of the random moment and the fuel wander
FUEL_MEAN = 1.0                 # mu0, kg/s
LOAD_AMPLITUDE = 0.25           # relative amplitude of the daily load cycle
WANDER_TIME = 7_200.0           # s, time constant of the OU wander of the fuel rate
WANDER_STD = 0.03               # relative std of the OU wander
FUEL_SENSOR_NOISE = 1e-4        # kg/s
MOMENT_POLE_RADIUS = 0.9
MOMENT_POLE_ANGLE = 2 * math.pi / 8
WARMUP_SECONDS = 1_500.0        # warm-up of each time chunk (25 decay times at gamma = 0.06)
CHUNK_SAMPLES = 512             # integration steps per time chunk (the warm-up is extra)
SPLICE_TOLERANCE = 1e-9         # rad/s, largest accepted mismatch where chunks meet
TRUTH_FILE = "fleet_truth.json"

_BURN_IN = 1_000                # AR(2) moment steps discarded so Gamma starts stationary
_N_STREAMS = 8                  # independent random streams per vehicle, in this order:
_PHASE, _WANDER, _SHOCK, _SENSOR, _TAILS, _FUEL, _JITTER, _DROP = range(_N_STREAMS)
_LOSS_PARAMETERS = ("turbine_slope", "compressor_linear", "compressor_quadratic")


def moment_ar_coefficients() -> tuple[float, float]:
    """AR(2) coefficients ``(a1, a2)`` of the random moment: poles ``0.9 exp(+-i pi/4)``."""
    a1 = 2 * MOMENT_POLE_RADIUS * math.cos(MOMENT_POLE_ANGLE)
    a2 = -MOMENT_POLE_RADIUS ** 2
    return a1, a2


def _moment_innovation_scale(moment_std: float) -> float:
    """``sigma_u`` such that the AR(2) with unit-variance innovations has std ``moment_std``."""
    a1, a2 = moment_ar_coefficients()
    variance = (1 - a2) / ((1 + a2) * ((1 - a2) ** 2 - a1 ** 2))
    return moment_std / math.sqrt(variance)


def _finite(value, what: str) -> float:
    if isinstance(value, bool):
        raise ValueError(f"{what} must be a number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{what} must be finite, got {value!r}")
    return number


def _integer(value, what: str, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ValueError(f"{what} must be an integer >= {low}, got {value!r}")
    return int(value)


def moment_steps_ratio(sample_interval: float) -> tuple[int, int]:
    """How a sampling interval meets the moment clock of :data:`MOMENT_STEP` seconds.

    Parameters
    ----------
    sample_interval : float
        Seconds between samples: ``MOMENT_STEP / p`` or ``MOMENT_STEP * q`` for integers
        ``p, q >= 1`` (1, 2, 2.5, 5, 10, 20, 30, 60 s, ...).

    Returns
    -------
    per_step : int
        Samples per moment step (``p``; 1 from 10 s up).
    stride : int
        Moment steps per sample (``q``; 1 up to 10 s).

    Raises
    ------
    ValueError
        For any other interval.
    """
    dt = _finite(sample_interval, "sample_interval")
    if 0 < dt <= MOMENT_STEP:
        per_step = round(MOMENT_STEP / dt)
        if abs(per_step * dt - MOMENT_STEP) <= 1e-9 * MOMENT_STEP:
            return per_step, 1
    elif dt > MOMENT_STEP:
        stride = round(dt / MOMENT_STEP)
        if abs(stride * MOMENT_STEP - dt) <= 1e-9 * dt:
            return 1, stride
    raise ValueError(
        f"sample_interval must divide the {MOMENT_STEP:g}-s moment step (10 / an integer: 1, 2, "
        f"2.5, 5, 10 s, ...) or be a multiple of it (20, 30, 60 s, ...), got {sample_interval!r}")


def _unknown_keys(d: Mapping, known, what: str) -> None:
    extra = set(d) - set(known)
    if extra:
        raise ValueError(f"{what}: unknown key(s) {sorted(extra)}; known: {sorted(known)}")


# ---------------------------------------------------------------------------------------------
# specs
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Fault:
    """An incipient fault injected into one vehicle.

    Parameters
    ----------
    kind : {"friction", "nonlinear", "noise", "bias", "heavy_tails"}
        ``"friction"``: the damping rate around the moving equilibrium changes by the relative
        amount ``magnitude`` (0.3 = +30 %); the equilibrium does not move. ``"nonlinear"``:
        blade flutter, ``kappa = magnitude`` in the moment's innovations
        ``u_k = e_k + kappa He3(e_{k-1})``. ``"noise"``: sensor noise std times
        ``1 + magnitude``. ``"heavy_tails"``: Student-t sensor noise with
        ``df = max(2.1, 2 + 4 / magnitude)`` and the same std. ``"bias"``: a step of
        ``magnitude`` rad/s on the measured shaft speed. Several faults of one kind add up.
    onset_day : float
        Days after the fleet start when the fault starts to act.
    magnitude : float
        Size of the fault (see ``kind``). ``friction`` needs ``> -1``, ``noise`` ``>= -1``,
        ``heavy_tails`` ``> 0``.
    ramp_days : float, default 0.0
        ``0``: full magnitude at onset; otherwise the magnitude grows linearly from 0 at onset
        to full after ``ramp_days``. The plant's faults (``friction``, ``nonlinear``) take
        the level at the start of each 10-s moment step, the sensor's at each sample.

    Raises
    ------
    ValueError
        If the kind is unknown or a field is out of range.
    """

    kind: str
    onset_day: float
    magnitude: float
    ramp_days: float = 0.0

    def __post_init__(self):
        if self.kind not in FAULT_KINDS:
            raise ValueError(f"fault kind must be one of {FAULT_KINDS}, got {self.kind!r}")
        onset = _finite(self.onset_day, "Fault.onset_day")
        magnitude = _finite(self.magnitude, "Fault.magnitude")
        ramp = _finite(self.ramp_days, "Fault.ramp_days")
        if onset < 0 or ramp < 0:
            raise ValueError(f"Fault.onset_day and ramp_days must be >= 0, got {onset}, {ramp}")
        low = {"friction": (-1.0, False), "noise": (-1.0, True), "heavy_tails": (0.0, False)}
        if self.kind in low:
            bound, inclusive = low[self.kind]
            if magnitude < bound or (magnitude == bound and not inclusive):
                relation = ">=" if inclusive else ">"
                raise ValueError(f"a {self.kind!r} fault needs magnitude {relation} {bound}, "
                                 f"got {magnitude}")
        object.__setattr__(self, "onset_day", onset)
        object.__setattr__(self, "magnitude", magnitude)
        object.__setattr__(self, "ramp_days", ramp)

    def level(self, days: np.ndarray) -> np.ndarray:
        """Magnitude acting at ``days`` after the fleet start (0 before onset)."""
        days = np.asarray(days, dtype=float)
        if self.ramp_days > 0:
            fraction = np.clip((days - self.onset_day) / self.ramp_days, 0.0, 1.0)
        else:
            fraction = (days >= self.onset_day).astype(float)
        return self.magnitude * fraction

    def to_dict(self) -> dict:
        """JSON-friendly dict; :meth:`from_dict` rebuilds an equal fault."""
        return {"kind": self.kind, "onset_day": self.onset_day, "magnitude": self.magnitude,
                "ramp_days": self.ramp_days}

    @classmethod
    def from_dict(cls, d: Mapping) -> "Fault":
        """Inverse of :meth:`to_dict`."""
        _unknown_keys(d, ("kind", "onset_day", "magnitude", "ramp_days"), "Fault")
        return cls(**d)


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
        _integer(self.seed, "VehicleSpec.seed", 0)
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
            value = _finite(getattr(self, name), f"VehicleSpec.{name}")
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
        _unknown_keys(d, ("asset_id", "seed", "faults", "plant_parameters", "sensor_noise",
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
        _integer(self.days, "FleetSpec.days", 1)
        _integer(self.substeps, "FleetSpec.substeps", 1)
        interval = _finite(self.sample_interval, "FleetSpec.sample_interval")
        if interval <= 0:
            raise ValueError(f"FleetSpec.sample_interval must be > 0, got {interval}")
        try:
            moment_steps_ratio(interval)
        except ValueError as error:
            raise ValueError(f"FleetSpec.{error}") from None
        object.__setattr__(self, "sample_interval", interval)
        jitter = _finite(self.jitter, "FleetSpec.jitter")
        drop = _finite(self.drop_fraction, "FleetSpec.drop_fraction")
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
        return stamp.tz_localize("UTC") if stamp.tzinfo is None else stamp.tz_convert("UTC")

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
        _unknown_keys(d, ("vehicles", "days", "start", "sample_interval", "substeps", "jitter",
                          "drop_fraction"), "FleetSpec")
        d = dict(d)
        d["vehicles"] = tuple(VehicleSpec.from_dict(v) for v in d["vehicles"])
        return cls(**d)


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
    factor = 1.0 + _finite(model_error, "model_error")
    if model == "turbine":
        parameters, scaled = dict(GasTurbineShaft.default_parameters), _LOSS_PARAMETERS
    elif model == "langevin":
        parameters, scaled = dict(LangevinShaft.default_parameters), ("gamma", "fuel_gain")
    else:
        raise ValueError(f"model must be 'turbine' or 'langevin', got {model!r}")
    for name in scaled:
        parameters[name] *= factor
    return parameters


# ---------------------------------------------------------------------------------------------
# random inputs of one vehicle
# ---------------------------------------------------------------------------------------------
def _hermite3(x: np.ndarray) -> np.ndarray:
    return x * (x * x - 3.0)


def _fault_level(faults: tuple[Fault, ...], kind: str, days: np.ndarray) -> np.ndarray:
    total = np.zeros_like(days)
    for fault in faults:
        if fault.kind == kind:
            total = total + fault.level(days)
    return total


@dataclass(frozen=True)
class _Clock:
    """The three time grids of a simulation.

    Output samples ``k dt``, ``k < n``; integration instants ``j h``, ``j < n_int``, with
    ``h = min(dt, MOMENT_STEP)`` (sample ``k`` is instant ``k stride``); moment steps
    ``i MOMENT_STEP``, ``i < n_moment`` (integration step ``j`` lies in step ``j // per_step``).
    ``n_moment`` is the number of 10-s samples of the fleet's days, whatever ``dt``.
    """

    n: int
    dt: float
    h: float
    per_step: int
    stride: int
    n_int: int
    n_moment: int

    @classmethod
    def of(cls, spec: FleetSpec) -> "_Clock":
        n, dt = spec.n_samples, spec.sample_interval
        per_step, stride = moment_steps_ratio(dt)
        n_moment = int(math.ceil(spec.days * SECONDS_PER_DAY / MOMENT_STEP - 1e-9))
        return cls(n=n, dt=dt, h=min(dt, MOMENT_STEP), per_step=per_step, stride=stride,
                   n_int=(n - 1) * stride + 1, n_moment=n_moment)

    def step_of_sample(self) -> np.ndarray:
        """The moment step each output sample starts in."""
        return np.arange(self.n) * self.stride // self.per_step


@dataclass
class _Draws:
    """Everything random about one vehicle, on the grids of its :class:`_Clock`."""

    # on the integration grid
    fuel: np.ndarray          # mu at the integration instants
    moment: np.ndarray        # Gamma, held over [t_j, t_j+1)
    friction: np.ndarray      # friction magnitude (of the moment step), held over [t_j, t_j+1)
    # on the moment clock
    moment_steps: np.ndarray  # Gamma_i
    innovation: np.ndarray    # u_i
    shock: np.ndarray         # e_i
    # on the output grid
    sensor: np.ndarray        # shaft-speed sensor noise (noise and heavy-tail faults included)
    bias: np.ndarray          # shaft-speed bias (rad/s)
    fuel_sensor: np.ndarray   # fuel-rate sensor noise
    jitter: np.ndarray        # timestamp offsets (s)
    keep: np.ndarray          # samples not dropped


def _fuel_rate(rngs, clock: _Clock) -> np.ndarray:
    """``mu`` at the integration instants: the daily cycle, plus the wander drawn at the
    moment-step instants and linear between them."""
    phase = rngs[_PHASE].uniform(0.0, 2 * math.pi)
    rho = math.exp(-MOMENT_STEP / WANDER_TIME)
    # one knot past the last moment step, for instants inside that step; the normals are
    # drawn in sequence, so the other knots do not depend on it
    xi = rngs[_WANDER].standard_normal(clock.n_moment + 2)
    knots = lfilter([WANDER_STD * math.sqrt(1 - rho ** 2)], [1.0, -rho], xi[1:],
                    zi=[rho * WANDER_STD * xi[0]])[0]  # starts in the stationary law
    if clock.per_step == 1:
        wander = knots[:clock.n_int]
    else:
        step, within = np.divmod(np.arange(clock.n_int), clock.per_step)
        wander = knots[step] + (knots[step + 1] - knots[step]) * (within / clock.per_step)
    t = np.arange(clock.n_int) * clock.h
    return FUEL_MEAN * (1 + LOAD_AMPLITUDE * np.sin(2 * math.pi * t / SECONDS_PER_DAY + phase)
                        + wander)


def _moment(rngs, vehicle: VehicleSpec, clock: _Clock):
    """``(Gamma_i, u_i, e_i)`` over the moment steps."""
    days = np.arange(clock.n_moment) * MOMENT_STEP / SECONDS_PER_DAY
    shock = rngs[_SHOCK].standard_normal(clock.n_moment + _BURN_IN)
    kappa = np.concatenate([np.zeros(_BURN_IN), _fault_level(vehicle.faults, "nonlinear", days)])
    innovation = shock.copy()
    flutter = np.flatnonzero(kappa[1:]) + 1
    innovation[flutter] += kappa[flutter] * _hermite3(shock[flutter - 1])
    a1, a2 = moment_ar_coefficients()
    moment = lfilter([_moment_innovation_scale(vehicle.moment_std)], [1.0, -a1, -a2], innovation)
    return moment[_BURN_IN:], innovation[_BURN_IN:], shock[_BURN_IN:]


def _draw(vehicle: VehicleSpec, spec: FleetSpec) -> _Draws:
    clock = _Clock.of(spec)
    n, dt = clock.n, clock.dt
    seeds = np.random.SeedSequence(vehicle.seed).spawn(_N_STREAMS)
    rngs = [np.random.default_rng(s) for s in seeds]
    days = np.arange(n) * dt / SECONDS_PER_DAY
    faults = vehicle.faults

    fuel = _fuel_rate(rngs, clock)
    moment_steps, innovation, shock = _moment(rngs, vehicle, clock)
    # held over the moment steps like Gamma, so that a ramp is the same plant at every rate
    friction_steps = _fault_level(faults, "friction",
                                  np.arange(clock.n_moment) * MOMENT_STEP / SECONDS_PER_DAY)
    moment, friction = (np.repeat(x, clock.per_step)[:clock.n_int]
                        for x in (moment_steps, friction_steps))

    z = rngs[_SENSOR].standard_normal(n)
    tails = _fault_level(faults, "heavy_tails", days)
    heavy = tails > 0
    if heavy.any():
        # Student-t as z / sqrt(V / df), rescaled by sqrt((df - 2) / df) to unit variance
        df = np.maximum(2.1, 2.0 + 4.0 / tails[heavy])
        z[heavy] *= np.sqrt((df - 2.0) / rngs[_TAILS].chisquare(df))
    sensor = vehicle.sensor_noise * (1.0 + _fault_level(faults, "noise", days)) * z

    fuel_sensor = FUEL_SENSOR_NOISE * rngs[_FUEL].standard_normal(n)
    jitter = np.zeros(n)
    if spec.jitter > 0:
        limit = 0.4 * dt
        jitter = np.clip(rngs[_JITTER].normal(0.0, spec.jitter, n), -limit, limit)
        # the measured span stays inside [start, end of the last sample]
        jitter[0], jitter[-1] = max(jitter[0], 0.0), min(jitter[-1], 0.0)
    keep = np.ones(n, dtype=bool)
    if spec.drop_fraction > 0:
        dropped = rngs[_DROP].random(n) < spec.drop_fraction
        dropped[0] = dropped[-1] = False
        for k in np.flatnonzero(dropped[2:]) + 2:
            if dropped[k - 1] and dropped[k - 2]:
                dropped[k] = False
        keep = ~dropped
    return _Draws(fuel=fuel, moment=moment, friction=friction, moment_steps=moment_steps,
                  innovation=innovation, shock=shock, sensor=sensor,
                  bias=_fault_level(faults, "bias", days), fuel_sensor=fuel_sensor,
                  jitter=jitter, keep=keep)


# ---------------------------------------------------------------------------------------------
# the plant, vectorised over vehicles
# ---------------------------------------------------------------------------------------------
class _Plant:
    """The true plants' parameters as arrays over vehicles (last axis).

    The drift is written ``f = A - omega (B + D omega)`` with ``A = a mu / J + Gamma +
    m gamma0 omega_eq`` and ``B = (b + c) / J + m gamma0`` (``m`` the friction magnitude).
    """

    def __init__(self, models: list[GasTurbineShaft]):
        def column(name):
            return np.array([m.parameters[name] for m in models], dtype=float)

        self.inertia = column("inertia")
        self.gain = column("turbine_gain")
        self.slope = column("turbine_slope") + column("compressor_linear")
        self.quadratic = column("compressor_quadratic")
        self.gain_j = self.gain / self.inertia
        self.slope_j = self.slope / self.inertia
        self.quadratic_j = self.quadratic / self.inertia

    def subset(self, which) -> "_Plant":
        """The plants of the vehicles selected by ``which`` (index or mask)."""
        sub = _Plant.__new__(_Plant)
        sub.__dict__ = {name: value[which] for name, value in self.__dict__.items()}
        return sub

    def equilibrium(self, fuel):
        # the root of M1 = M2 in the form without cancellation (also right for d = 0)
        drive = self.gain * fuel
        return 2 * drive / (self.slope + np.sqrt(self.slope ** 2 + 4 * self.quadratic * drive))

    def coefficients(self, fuel, moment, friction, with_friction: bool):
        a = self.gain_j * fuel + moment
        if not with_friction:
            return a, self.slope_j
        omega_eq = self.equilibrium(fuel)
        gamma0 = (self.slope + 2 * self.quadratic * omega_eq) / self.inertia
        return a + friction * gamma0 * omega_eq, self.slope_j + friction * gamma0

    def drift(self, omega, a, b):
        return a - omega * (b + self.quadratic_j * omega)


def _rk4_sample(plant: _Plant, omega, fuel0, fuel1, moment, friction, dt, substeps,
                with_friction):
    """Advance ``omega`` over one integration step: RK4, ``substeps`` steps, fuel linear."""
    fractions = np.arange(2 * substeps + 1) / (2 * substeps)
    shape = (-1,) + (1,) * np.ndim(omega)
    fuel = fuel0 + (fuel1 - fuel0) * fractions.reshape(shape)
    a, b = plant.coefficients(fuel, moment, friction, with_friction)
    b = np.broadcast_to(b, a.shape)
    d = plant.quadratic_j
    h = dt / substeps
    half, sixth = 0.5 * h, h / 6.0
    for s in range(substeps):
        j = 2 * s
        k1 = a[j] - omega * (b[j] + d * omega)
        x = omega + half * k1
        k2 = a[j + 1] - x * (b[j + 1] + d * x)
        x = omega + half * k2
        k3 = a[j + 1] - x * (b[j + 1] + d * x)
        x = omega + h * k3
        k4 = a[j + 2] - x * (b[j + 2] + d * x)
        omega = omega + sixth * (k1 + 2.0 * (k2 + k3) + k4)
    return omega


def _chunk_layout(n: int, dt: float, serial: bool) -> tuple[int, int, int, int]:
    """``(n_chunks, chunk, warmup, steps)``: chunk i integrates intervals ``i*chunk ...``."""
    warmup = int(math.ceil(WARMUP_SECONDS / dt))
    chunk = max(CHUNK_SAMPLES, 2 * warmup)
    if serial or n - 1 <= warmup + chunk:
        return 1, n - 1, 0, n - 1
    return int(math.ceil((n - 1 - warmup) / chunk)), chunk, warmup, warmup + chunk


def _integrate(plant: _Plant, omega0, fuel, moment, friction, dt, substeps, serial=False):
    """Shaft speed at the integration instants, shape ``(n, n_vehicles)``, and the splice
    mismatch."""
    n, n_vehicles = fuel.shape
    n_chunks, chunk, warmup, steps = _chunk_layout(n, dt, serial)
    padded = (n_chunks - 1) * chunk + steps + 1

    def pad(a):
        return np.concatenate([a, np.repeat(a[-1:], padded - n, axis=0)])

    fuel, moment, friction = pad(fuel), pad(moment), pad(friction)
    with_friction = bool(np.any(friction != 0))
    omega = np.empty((padded, n_vehicles))
    omega[0] = omega0
    state = np.empty((n_chunks, n_vehicles))
    state[0] = omega0
    state[1:] = plant.equilibrium(fuel[chunk:(n_chunks - 1) * chunk + 1:chunk])
    last = (n_chunks - 1) * chunk  # offset of the last chunk
    mismatch = np.zeros(n_vehicles)
    for r in range(steps):
        state = _rk4_sample(plant, state, fuel[r:r + last + 1:chunk],
                            fuel[r + 1:r + last + 2:chunk], moment[r:r + last + 1:chunk],
                            friction[r:r + last + 1:chunk], dt, substeps, with_friction)
        s = r + 1
        if s < warmup:
            omega[s] = state[0]          # later chunks are still warming up
        elif s < steps or n_chunks == 1:
            omega[s:s + last + 1:chunk] = state
        else:
            # chunk i ends where chunk i+1 took over after its warm-up: they must agree
            taken = omega[chunk + warmup:last + warmup + 1:chunk]
            mismatch = np.max(np.abs(state[:-1] - taken), axis=0, initial=0.0)
            mismatch[~np.isfinite(state[:-1]).all(axis=0)] = np.inf
    return omega[:n], mismatch


def _integrate_fleet(plant: _Plant, omega0, fuel, moment, friction, dt, substeps):
    has_friction = np.any(friction != 0, axis=0)
    groups = [g for g in (~has_friction, has_friction) if g.any()]
    omega = None if len(groups) == 1 else np.empty_like(fuel)
    # vehicles without a friction fault skip its (costly) terms; the terms would add exact
    # zeros, so the grouping does not change any vehicle's numbers
    for group in groups:
        if omega is None:
            sub, args = plant, (omega0, fuel, moment, friction)
        else:
            sub, args = plant.subset(group), (omega0[group], fuel[:, group], moment[:, group],
                                              friction[:, group])
        result, mismatch = _integrate(sub, *args, dt, substeps)
        weak = ~(mismatch <= SPLICE_TOLERANCE)
        if weak.any():
            # weakly damped plant: the warm-up did not forget its start; integrate serially
            result[:, weak], _ = _integrate(sub.subset(weak), *(a[..., weak] for a in args),
                                            dt, substeps, serial=True)
        if omega is None:
            omega = result
        else:
            omega[:, group] = result
    if not np.isfinite(omega).all():
        raise GrayBoxError("the simulated shaft speed is not finite (unstable plant parameters?)")
    return omega


# ---------------------------------------------------------------------------------------------
# the fleet
# ---------------------------------------------------------------------------------------------
def _measure(plant: _Plant, omega, draws: _Draws, clock: _Clock):
    """Shaft speed and fuel rate at the (jittered) sampling instants, before sensor noise.

    ``omega`` is on the integration grid; so is the interpolation inside a step.
    """
    if not draws.jitter.any():
        return omega[::clock.stride], draws.fuel[::clock.stride]
    h = clock.h
    tau = np.arange(clock.n, dtype=float) * clock.stride + draws.jitter / h  # in steps
    q = np.clip(np.floor(tau).astype(int), 0, clock.n_int - 2)
    theta = tau - q
    fuel0, fuel1 = draws.fuel[q], draws.fuel[q + 1]
    moment, friction = draws.moment[q], draws.friction[q]
    with_friction = bool(np.any(friction != 0))
    w0, w1 = omega[q], omega[q + 1]
    a0, b0 = plant.coefficients(fuel0, moment, friction, with_friction)
    a1, b1 = plant.coefficients(fuel1, moment, friction, with_friction)
    f0, f1 = plant.drift(w0, a0, b0) * h, plant.drift(w1, a1, b1) * h
    # cubic Hermite inside the step, with the drift of that step at both ends
    t2, t3 = theta ** 2, theta ** 3
    speed = ((2 * t3 - 3 * t2 + 1) * w0 + (t3 - 2 * t2 + theta) * f0
             + (-2 * t3 + 3 * t2) * w1 + (t3 - t2) * f1)
    return speed, fuel0 + (fuel1 - fuel0) * theta


def simulate_fleet_with_truth(spec: FleetSpec) -> tuple[dict[str, pd.DataFrame],
                                                         dict[str, pd.DataFrame]]:
    """Simulate a fleet; return its telemetry and the hidden truth behind it.

    Parameters
    ----------
    spec : FleetSpec

    Returns
    -------
    telemetry : dict of str to DataFrame
        As :func:`simulate_fleet`.
    truth : dict of str to DataFrame
        Per asset, on the uniform grid (no jitter, no drops): ``timestamp``, ``omega`` (true
        shaft speed), ``fuel_rate`` (true ``mu``), ``moment`` (``Gamma_i`` of the 10-s moment
        step that ``timestamp`` lies in, held over that step), ``innovation`` (``u_i``) and
        ``shock`` (``e_i``) of that step, ``sensor_noise`` (shaft-speed sensor noise, bias
        excluded) and ``bias``. At 10 s a sample is a moment step.

    Notes
    -----
    The moment clock's streams (``Gamma``, flutter, fuel wander) and the fuel phase are
    shared by every sampling interval, so ``omega``, ``fuel_rate`` and ``moment`` of one
    vehicle agree across rates at the common instants (``omega`` up to integration error);
    ``sensor_noise``, the fuel-sensor noise, jitter and drops are drawn per sample.
    """
    return _simulate(spec, with_truth=True)


def _simulate(spec: FleetSpec, with_truth: bool):
    if not spec.vehicles:
        return {}, {}
    clock = _Clock.of(spec)
    draws = [_draw(v, spec) for v in spec.vehicles]
    models = [v.plant() for v in spec.vehicles]
    plant = _Plant(models)

    def stack(name):
        return np.stack([getattr(d, name) for d in draws], axis=1)

    omega0 = np.array([float(m.equilibrium_speed(d.fuel[0])) for m, d in zip(models, draws)])
    omega = _integrate_fleet(plant, omega0, stack("fuel"), stack("moment"), stack("friction"),
                             clock.h, spec.substeps)
    start = spec.start_timestamp
    grid_ns = np.round(np.arange(clock.n) * clock.dt * 1e9).astype(np.int64)
    grid = start + pd.to_timedelta(grid_ns, unit="ns")
    step = clock.step_of_sample()
    telemetry, truth = {}, {}
    for i, (vehicle, d) in enumerate(zip(spec.vehicles, draws)):
        speed, fuel = _measure(plant.subset(i), omega[:, i], d, clock)
        stamps = grid if not d.jitter.any() else start + pd.to_timedelta(
            grid_ns + np.round(d.jitter * 1e9).astype(np.int64), unit="ns")
        keep = slice(None) if d.keep.all() else d.keep
        telemetry[vehicle.asset_id] = pd.DataFrame({
            "timestamp": stamps[keep], "shaft_speed": (speed + d.sensor + d.bias)[keep],
            "fuel_rate": (fuel + d.fuel_sensor)[keep]})
        if with_truth:
            truth[vehicle.asset_id] = pd.DataFrame({
                "timestamp": grid, "omega": omega[::clock.stride, i],
                "fuel_rate": d.fuel[::clock.stride], "moment": d.moment_steps[step],
                "innovation": d.innovation[step], "shock": d.shock[step],
                "sensor_noise": d.sensor, "bias": d.bias})
    return telemetry, truth


def simulate_fleet(spec: FleetSpec) -> dict[str, pd.DataFrame]:
    """Simulate the telemetry of a fleet.

    Parameters
    ----------
    spec : FleetSpec

    Returns
    -------
    dict of str to DataFrame
        Asset id -> frame with columns ``timestamp`` (UTC), ``shaft_speed`` (rad/s) and
        ``fuel_rate`` (kg/s), in time order.

    Examples
    --------
    >>> frames = simulate_fleet(FleetSpec((VehicleSpec("T-001", seed=1),), days=1))
    >>> len(frames["T-001"])
    8640
    """
    return _simulate(spec, with_truth=False)[0]


def write_fleet(spec: FleetSpec, root) -> dict[str, pd.DataFrame]:
    """Simulate a fleet and write it in the telemetry layout, with its truth.

    Writes ``<root>/asset_id=<id>/date=<YYYY-MM-DD>/part-0.parquet`` through
    :func:`graybox.telemetry.write_telemetry` and ``<root>/fleet_truth.json``
    (``spec.to_dict()``: the faults, seeds and plant parameters).

    Parameters
    ----------
    spec : FleetSpec
    root : str or path-like
        Telemetry root (created if needed).

    Returns
    -------
    dict of str to DataFrame
        The frames written, as :func:`simulate_fleet`.
    """
    root = pathlib.Path(root)
    frames = simulate_fleet(spec)
    root.mkdir(parents=True, exist_ok=True)
    for asset_id, frame in frames.items():
        write_telemetry(root, asset_id, frame)
    (root / TRUTH_FILE).write_text(json.dumps(spec.to_dict(), indent=2) + "\n")
    return frames


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
    _integer(n_vehicles, "n_vehicles", 1)
    _integer(days, "days", 1)
    rng = np.random.default_rng(np.random.SeedSequence(_integer(seed, "seed", 0)))
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


# ---------------------------------------------------------------------------------------------
# the Langevin equation (Eq. 8)
# ---------------------------------------------------------------------------------------------
def simulate_langevin(n: int, dt: float, gamma: float, force: np.ndarray | Callable | None,
                      omega0: float = 0.0, substeps: int = 20, seed=None) -> np.ndarray:
    """Integrate Eq. 8, ``domega/dt = -gamma omega + Gamma(t)``, with a given force.

    Classical RK4 with ``substeps`` steps per sample. Because the equation is linear, one RK4
    step is an affine map ``omega -> R omega + c_j``; it is applied as that recurrence, which is
    the same RK4 without a Python loop.

    Parameters
    ----------
    n : int
        Number of grid samples (>= 1); the grid is ``t_k = k dt``.
    dt : float
        Sample interval.
    gamma : float
        Damping rate.
    force : ndarray of shape (n,), callable or None
        ``Gamma`` at the grid instants (interpolated linearly between them), or a callable of
        an ndarray of times returning ``Gamma`` there (a scalar is broadcast), or ``None`` for a
        standard Gaussian force at the grid instants drawn from ``seed``.
    omega0 : float, default 0.0
        ``omega(0)``.
    substeps : int, default 20
    seed : int, Generator or None
        Only used when ``force`` is None.

    Returns
    -------
    ndarray of shape (n,)
        ``omega`` at the grid instants.
    """
    n = _integer(n, "n", 1)
    substeps = _integer(substeps, "substeps", 1)
    dt, gamma = _finite(dt, "dt"), _finite(gamma, "gamma")
    times = np.arange(2 * substeps * (n - 1) + 1) * (dt / (2 * substeps))
    if force is None:
        force = np.random.default_rng(seed).standard_normal(n)
    if callable(force):
        values = np.broadcast_to(np.asarray(force(times), dtype=float), times.shape)
    else:
        force = np.asarray(force, dtype=float)
        if force.shape != (n,):
            raise ValueError(f"force must have shape ({n},), got {force.shape}")
        values = np.interp(times, np.arange(n) * dt, force)
    h = dt / substeps

    def step(omega, fa, fm, fb):
        k1 = -gamma * omega + fa
        k2 = -gamma * (omega + 0.5 * h * k1) + fm
        k3 = -gamma * (omega + 0.5 * h * k2) + fm
        k4 = -gamma * (omega + h * k3) + fb
        return omega + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)

    amplification = step(1.0, 0.0, 0.0, 0.0)
    offsets = step(0.0, values[0:-1:2], values[1::2], values[2::2])
    fine = lfilter([1.0], [1.0, -amplification], offsets, zi=[amplification * omega0])[0]
    return np.concatenate([[float(omega0)], fine[substeps - 1::substeps]])


if __name__ == "__main__":
    # sanity print: the demo fleet's faults and telemetry summary
    _spec = demo_fleet()
    for _vehicle, (_asset, _frame) in zip(_spec.vehicles, simulate_fleet(_spec).items()):
        print(f"{_asset}: {len(_frame)} rows, shaft_speed {_frame.shaft_speed.mean():8.2f} "
              f"+- {_frame.shaft_speed.std():6.2f} rad/s, fuel_rate {_frame.fuel_rate.mean():.3f} "
              f"kg/s, faults: {[f.to_dict() for f in _vehicle.faults] or 'none'}")
