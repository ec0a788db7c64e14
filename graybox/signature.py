"""The signature: every tier's parameters for every residual channel, with the frozen
structure they were fitted with. Small typed records with an exact JSON round trip.
"""
from __future__ import annotations

import json
from dataclasses import MISSING, asdict, dataclass, fields
from typing import Any

import numpy as np

from graybox.exceptions import ArtifactError
from graybox.linear_tier import LinearTier
from graybox.noise_tier import NoiseTier
from graybox.nonlinear_tier import NonlinearTier
from graybox.stationarize import Differencing

FORMAT_VERSION = 1
TIERS = ("linear", "nonlinear", "noise")


@dataclass(frozen=True)
class ChannelStructure:
    """What a candidate must share with its baseline for their parameters to be comparable.

    Attributes
    ----------
    period, seasonal_order, diff_order : int
        The stationarizing operator ``(1 - B)^diff_order (1 - B^period)^seasonal_order``.
    ar_order : int
        ``n`` of the linear tier.
    center, scale : float
        The stationarized residual ``y`` enters the tiers as ``(y - center) / scale``.
    tau, embedding_dim, hidden_units : int
        Delay, number of delays ``m`` and hidden units ``J`` of the Eq. 25 network.
    nn_scale : float
        The AR residual ``w`` enters the network as ``w / nn_scale``.
    nonlinear_needed : bool
        Whether the network explained held-out structure the AR tier left. When False the
        network is still fitted and monitored (so a nonlinearity that appears later moves its
        weights), but the noise tier describes the AR residual itself.
    init_seed : int
        Seed of the random starting weights. A network with nothing to explain decays to the
        all-zero saddle, where no gradient could move a candidate; candidates of such a
        baseline start from these random weights instead of the baseline's.
    """

    period: int
    seasonal_order: int
    diff_order: int
    ar_order: int
    center: float
    scale: float
    tau: int
    embedding_dim: int
    hidden_units: int
    nn_scale: float
    nonlinear_needed: bool
    init_seed: int

    @property
    def differencing(self) -> Differencing:
        return Differencing(self.period, self.seasonal_order, self.diff_order)


@dataclass(frozen=True)
class Selection:
    """Evidence behind a baseline's structure choices (absent from candidates)."""

    acf_area: float
    raw_acf_area: float
    adf_statistic: float
    candidate_period: int
    ar_criterion: str


@dataclass(frozen=True)
class ChannelSignature:
    """The three tiers of one residual channel."""

    channel: str
    structure: ChannelStructure
    linear: LinearTier
    nonlinear: NonlinearTier
    noise: NoiseTier
    n_samples: int
    selection: Selection | None = None


@dataclass(frozen=True)
class Signature:
    """Every tier's parameters for every residual channel of one asset and window.

    Attributes
    ----------
    channels : tuple of ChannelSignature
    model : dict
        The white box used: ``{"spec", "parameters", "columns"}``.
    residual_method : str
        ``"one_step"`` or ``"inverse"``.
    sample_interval : float
        Seconds between samples.
    n_samples : int
        Residual samples the fit used.
    settings : dict
        The :class:`graybox.estimator.GrayBoxSettings` it was fitted with; candidates of a
        baseline are fitted with the same settings.
    asset_id : str or None
    window_start, window_end : str or None
        ISO timestamps of the telemetry window (end exclusive).
    format_version : int
    analysis_interval : float or None
        Seconds between the residual samples the tiers saw (a whole multiple of
        ``sample_interval``, see :mod:`graybox.analysis_rate`); None for signatures stored
        before it existed, which were analysed at ``sample_interval``.
    """

    channels: tuple[ChannelSignature, ...]
    model: dict
    residual_method: str
    sample_interval: float
    n_samples: int
    settings: dict
    asset_id: str | None = None
    window_start: str | None = None
    window_end: str | None = None
    format_version: int = FORMAT_VERSION
    analysis_interval: float | None = None

    @property
    def analysis_step(self) -> float:
        """Seconds between the residual samples the tiers saw."""
        return self.sample_interval if self.analysis_interval is None else self.analysis_interval

    def channel(self, name: str) -> ChannelSignature:
        """The signature of one channel by name."""
        for channel in self.channels:
            if channel.channel == name:
                return channel
        raise KeyError(f"no channel {name!r}; channels: {[c.channel for c in self.channels]}")

    @property
    def channel_names(self) -> tuple[str, ...]:
        return tuple(c.channel for c in self.channels)

    def frozen_structure(self) -> dict:
        """Everything a candidate must share with this signature to be compared with it."""
        return {"model": self.model, "residual_method": self.residual_method,
                "sample_interval": self.sample_interval, "analysis_interval": self.analysis_step,
                "settings": self.settings,
                "channels": {c.channel: asdict(c.structure) for c in self.channels}}

    def parameter_vector(self) -> tuple[list[str], np.ndarray]:
        """All tier parameters as one flat vector with a name per entry.

        Names look like ``omega.linear.a1``, ``omega.nonlinear.W1_3``,
        ``omega.nonlinear.w_3_2`` (hidden unit 3, delay 2) and ``omega.noise.variance``.
        """
        names, values = [], []
        for channel in self.channels:
            for tier in TIERS:
                tier_names, tier_values = tier_parameters(channel, tier)
                names += [f"{channel.channel}.{tier}.{n}" for n in tier_names]
                values.append(tier_values)
        return names, np.concatenate(values) if values else np.zeros(0)

    def to_dict(self) -> dict:
        """A JSON-ready dict; :meth:`from_dict` gives back an equal signature."""
        return asdict(self)

    def to_json(self, indent: int | None = None) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_dict(cls, data: Any) -> "Signature":
        """Rebuild a signature from :meth:`to_dict`; anything malformed raises ArtifactError."""
        try:
            record = _build(cls, data)
        except ArtifactError:
            raise
        except (TypeError, ValueError, KeyError) as error:
            raise ArtifactError(f"malformed signature: {error}") from None
        if record.format_version != FORMAT_VERSION:
            raise ArtifactError(f"signature format {record.format_version} is not supported "
                                f"(this code reads {FORMAT_VERSION})")
        return record

    @classmethod
    def from_json(cls, text: str | bytes) -> "Signature":
        try:
            data = json.loads(text)
        except (json.JSONDecodeError, UnicodeDecodeError) as error:
            raise ArtifactError(f"signature is not valid JSON: {error}") from None
        return cls.from_dict(data)


def tier_parameters(channel: ChannelSignature, tier: str) -> tuple[list[str], np.ndarray]:
    """Names and values of one tier's parameters (the quantities zeta compares)."""
    if tier == "linear":
        coefficients = channel.linear.coefficients
        return [f"a{i}" for i in range(1, len(coefficients) + 1)], np.asarray(coefficients, float)
    if tier == "nonlinear":
        w, W = channel.nonlinear.weight_arrays()
        names = [f"W1_{j}" for j in range(1, len(W) + 1)]
        names += [f"w_{j}_{k}" for j in range(1, w.shape[0] + 1) for k in range(1, w.shape[1] + 1)]
        return names, np.concatenate([W, w.ravel()])
    if tier == "noise":
        return ["mean", "variance", "skewness", "excess_kurtosis"], np.asarray(channel.noise.moments)
    raise ValueError(f"unknown tier {tier!r}; tiers: {TIERS}")


_NESTED = {
    Signature: {"channels": ("tuple", ChannelSignature)},
    ChannelSignature: {"structure": ("record", ChannelStructure), "linear": ("record", LinearTier),
                       "nonlinear": ("record", NonlinearTier), "noise": ("record", NoiseTier),
                       "selection": ("optional", Selection)},
    LinearTier: {"coefficients": ("floats", None), "standard_errors": ("floats", None)},
    NonlinearTier: {"input_weights": ("matrix", None), "output_weights": ("floats", None)},
}
_SCALARS = {int: int, float: float, str: str, bool: bool}


def _build(cls, data):
    if not isinstance(data, dict):
        raise ArtifactError(f"{cls.__name__}: expected an object, got {type(data).__name__}")
    names = {f.name for f in fields(cls)}
    required = {f.name for f in fields(cls)
                if f.default is MISSING and f.default_factory is MISSING}
    unknown, missing = set(data) - names, required - set(data)
    if unknown:
        raise ArtifactError(f"{cls.__name__}: unknown field(s) {sorted(unknown)}")
    if missing:
        raise ArtifactError(f"{cls.__name__}: missing field(s) {sorted(missing)}")
    nested = _NESTED.get(cls, {})
    values = {}
    for f in fields(cls):
        if f.name not in data:
            continue
        value = data[f.name]
        kind, inner = nested.get(f.name, (None, None))
        if kind == "tuple":
            value = tuple(_build(inner, item) for item in value)
        elif kind == "record":
            value = _build(inner, value)
        elif kind == "optional":
            value = None if value is None else _build(inner, value)
        elif kind == "floats":
            value = tuple(float(v) for v in value)
        elif kind == "matrix":
            value = tuple(tuple(float(v) for v in row) for row in value)
        else:
            value = _scalar(cls, f, value)
        values[f.name] = value
    return cls(**values)


def _scalar(cls, f, value):
    annotation = str(f.type)
    if value is None:
        if "None" in annotation:
            return None
        raise ArtifactError(f"{cls.__name__}.{f.name} must not be null")
    if annotation.startswith("dict"):
        if not isinstance(value, dict):
            raise ArtifactError(f"{cls.__name__}.{f.name} must be an object")
        return value
    for name, kind in (("bool", bool), ("int", int), ("float", float), ("str", str)):
        if annotation.startswith(name):
            if kind is bool and not isinstance(value, bool):
                raise ArtifactError(f"{cls.__name__}.{f.name} must be true or false")
            if kind is int and (isinstance(value, bool) or not isinstance(value, int)):
                raise ArtifactError(f"{cls.__name__}.{f.name} must be an integer")
            if kind is float and (isinstance(value, bool) or not isinstance(value, (int, float))):
                raise ArtifactError(f"{cls.__name__}.{f.name} must be a number")
            if kind is str and not isinstance(value, str):
                raise ArtifactError(f"{cls.__name__}.{f.name} must be a string")
            return kind(value)
    return value
