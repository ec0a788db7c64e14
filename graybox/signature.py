"""The signature: every tier's parameters for every residual channel, with the frozen
structure they were fitted with. Small typed records with an exact JSON round trip.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, ClassVar, Sequence

import numpy as np

from graybox import record_json
from graybox.channel_structure import ChannelStructure, Selection  # noqa: F401 - re-exported
from graybox.exceptions import ArtifactError
from graybox.frozen_map import FrozenMap
from graybox.integration import Integration
from graybox.level_tier import LevelTier
from graybox.linear_tier import LinearTier
from graybox.models.spec import ModelSpec
from graybox.parameter_estimate import ParameterEstimate
from graybox.noise_tier import NoiseTier
from graybox.nonlinear_tier import NonlinearTier
from graybox.operating_conditions import OperatingConditions
from graybox.settings import GrayBoxSettings
from graybox.summary import signature_summary
from graybox.tiers import TIER_KINDS, TIERS, Tier, tier_kind  # noqa: F401 - TIERS re-exported

FORMAT_VERSION = 1


@dataclass(frozen=True)
class ChannelSignature:
    """The tiers of one residual channel.

    ``level`` (:mod:`graybox.level_tier`) is None in signatures stored before the level tier
    existed; that tier is then absent and its drift not computed.

    ``tiers`` holds the records of tiers beyond the four the format was written with (a tier
    kind whose :attr:`~graybox.tiers.base.Tier.field` is None), by tier name, as their JSON
    dicts (:meth:`graybox.tiers.base.Tier.record` reads one back); None without such tiers.
    """

    channel: str
    structure: ChannelStructure
    linear: LinearTier
    nonlinear: NonlinearTier
    noise: NoiseTier
    n_samples: int
    selection: Selection | None = None
    level: LevelTier | None = None
    tiers: FrozenMap[str, Any] | None = None

    #: written only when present, so signatures without the tiers read and write as before
    omitted_when_none: ClassVar[frozenset[str]] = frozenset({"level", "tiers"})

    def tier_names(self) -> tuple[str, ...]:
        """The names of the tiers this channel holds, read from its records: the built-in
        tiers present (in :data:`TIERS` order), then the added ones kept in ``tiers``.

        Returns
        -------
        tuple of str
        """
        built_in = tuple(kind.name for kind in TIER_KINDS if kind.present(self))
        return built_in + tuple(name for name in (self.tiers or {}) if name not in built_in)


@dataclass(frozen=True)
class HiddenStart:
    """A segment's fitted initial hidden state (:mod:`graybox.state_estimation`).

    Attributes
    ----------
    start : str
        ISO timestamp of the segment's first sample.
    values : FrozenMap of str to float
        Hidden state name -> value.
    """

    start: str
    values: FrozenMap[str, float]

    def __post_init__(self):
        if not isinstance(self.values, FrozenMap):
            object.__setattr__(self, "values", FrozenMap(self.values))


@dataclass(frozen=True)
class Signature:
    """Every tier's parameters for every residual channel of one asset and window.

    Attributes
    ----------
    channels : tuple of ChannelSignature
    model : ModelSpec
        The white box used (``model.load()`` rebuilds it).
    residual_method : str
        ``"one_step"`` or ``"inverse"``.
    sample_interval : float
        Seconds between samples.
    n_samples : int
        Residual samples the fit used.
    settings : GrayBoxSettings
        The settings it was fitted with; candidates of a baseline are fitted with the same
        settings.
    asset_id : str or None
    window_start, window_end : str or None
        ISO timestamps of the telemetry window (end exclusive).
    format_version : int
    analysis_interval : float or None
        Seconds between the residual samples the tiers saw (a whole multiple of
        ``sample_interval``, see :mod:`graybox.analysis_rate`); None for signatures stored
        before it existed, which were analysed at ``sample_interval``.
    integration : Integration or None
        How the white box was integrated over a sample (:mod:`graybox.integration`); None
        for signatures stored before it was chosen (RK4, 2 sub-steps).
    hidden_starts : tuple of HiddenStart or None
        Each segment's fitted initial hidden state; None for a model without hidden states.
    tuning : ParameterEstimate or None
        A baseline whose white box was tuned to its asset: the estimated parameters with
        their standard errors (``model`` holds the tuned values; its candidates use them).
        None otherwise.
    conditions : OperatingConditions or None
        Per telemetry window, the exogenous inputs' means and spreads
        (:mod:`graybox.operating_conditions`); None for a model without exogenous inputs and
        for signatures stored before the record.
    left_out : tuple of str or None
        A baseline's windows (their first timestamps, ISO) left out because they held too
        little operation to fit (:func:`graybox.calibration.fit_baselines`); None where none
        was.
    holds : FrozenMap of str to float or None
        A baseline's channels that held one value for a while with nothing in the plant to
        explain it (a coarse reading of a steady plant): channel -> the longest such hold in
        its windows, seconds (``TelemetryWindow.holds``). Its candidates may hold a value
        longer before they read as stuck (:meth:`graybox.GridPolicy.with_holds`). None where
        no channel held (a reading at full precision) or for a candidate.
    """

    channels: tuple[ChannelSignature, ...]
    model: ModelSpec
    residual_method: str
    sample_interval: float
    n_samples: int
    settings: GrayBoxSettings
    asset_id: str | None = None
    window_start: str | None = None
    window_end: str | None = None
    format_version: int = FORMAT_VERSION
    analysis_interval: float | None = None
    integration: Integration | None = None
    hidden_starts: tuple[HiddenStart, ...] | None = None
    tuning: ParameterEstimate | None = None
    conditions: OperatingConditions | None = None
    left_out: tuple[str, ...] | None = None
    holds: FrozenMap[str, float] | None = None

    #: written only when present, so signatures stored before them read and write as before
    omitted_when_none: ClassVar[frozenset[str]] = frozenset({"integration", "hidden_starts",
                                                             "tuning", "conditions",
                                                             "left_out", "holds"})

    def __post_init__(self):
        if self.holds is not None and not isinstance(self.holds, FrozenMap):
            object.__setattr__(self, "holds", FrozenMap(self.holds))

    @property
    def integration_used(self) -> Integration:
        """The integrator of the residual (RK4 with 2 sub-steps for older signatures)."""
        return self.integration or Integration()

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

    def summary(self, kinds: Sequence[Tier] = TIER_KINDS) -> str:
        """A readable plain-text table of the signature, as statsmodels' ``summary()``.

        Parameters
        ----------
        kinds : sequence of Tier, default TIER_KINDS
            The tiers shown, each as its kind writes it (a tier added through ``kinds=``
            is shown when given here).

        Returns
        -------
        str
            A header (asset, window, model, sample and analysis intervals, samples, tuning
            with its standard errors), then per channel its structure (differencing, AR
            order, embedding, whether the network is needed), the linear tier's coefficients
            with standard errors, the network's fit, the noise tier's moments and Ljung-Box
            test, and the level tier (level, residual std, horizon).

        Examples
        --------
        >>> print(baseline.signature_.summary())                          # doctest: +SKIP
        """
        return signature_summary(self, kinds)

    def frozen_structure(self) -> dict:
        """Everything a candidate must share with this signature to be compared with it."""
        return {"model": self.model.to_dict(), "residual_method": self.residual_method,
                "sample_interval": self.sample_interval, "analysis_interval": self.analysis_step,
                "settings": self.settings.to_dict(), "integration": asdict(self.integration_used),
                "channels": {c.channel: asdict(c.structure) for c in self.channels}}

    def parameter_vector(self, kinds: Sequence[Tier] = TIER_KINDS
                         ) -> tuple[list[str], np.ndarray]:
        """All tier parameters (of ``kinds``) as one flat vector with a name per entry.

        Names look like ``omega.linear.a1``, ``omega.nonlinear.W1_3``,
        ``omega.nonlinear.w_3_2`` (hidden unit 3, delay 2), ``omega.noise.variance`` and
        ``omega.level.level`` (absent from signatures without the level tier).
        """
        names, values = [], []
        for channel in self.channels:
            for kind in kinds:
                if not kind.present(channel):
                    continue
                tier_names, tier_values = kind.parameters(channel)
                names += [f"{channel.channel}.{kind.name}.{n}" for n in tier_names]
                values.append(tier_values)
        return names, np.concatenate(values) if values else np.zeros(0)

    def to_dict(self) -> dict:
        """A JSON-ready dict; :meth:`from_dict` gives back an equal signature."""
        return record_json.to_dict(self)

    def to_json(self, indent: int | None = None) -> str:
        return record_json.to_json(self, indent)

    @classmethod
    def from_dict(cls, data: Any) -> "Signature":
        """Rebuild a signature from :meth:`to_dict`; anything malformed raises ArtifactError."""
        version = data.get("format_version", FORMAT_VERSION) if isinstance(data, dict) else None
        if version is not None and version != FORMAT_VERSION:
            raise ArtifactError(f"signature format {version!r} is not supported "
                                f"(this code reads {FORMAT_VERSION})")
        signature = record_json.from_dict(cls, data)
        check_consistent(signature)
        return signature

    @classmethod
    def from_json(cls, text: str | bytes) -> "Signature":
        return cls.from_dict(record_json.parse_json(text, "signature"))


def tier_parameters(channel: ChannelSignature, tier: str) -> tuple[list[str], np.ndarray]:
    """Names and values of one tier's parameters (the quantities zeta compares).

    Parameters
    ----------
    channel : ChannelSignature
    tier : str
        One of :data:`TIERS` (see :mod:`graybox.tiers`).

    Returns
    -------
    names : list of str
    values : ndarray
    """
    return tier_kind(tier).parameters(channel)


def check_consistent(signature: Signature) -> None:
    """Check that every tier's parameters have the shapes its frozen structure says.

    A stored signature whose weights disagree with its structure would be accepted and
    then break the batched fit of every asset it is fitted with; it is refused on load.

    Raises
    ------
    ArtifactError
        Naming the channel and the field that is wrong.
    """
    if not signature.channels:
        raise ArtifactError("Signature.channels: must name at least one channel")
    if len(set(signature.channel_names)) != len(signature.channel_names):
        raise ArtifactError(f"Signature.channels: repeated channel in {signature.channel_names}")
    for name in ("sample_interval", "analysis_interval"):
        value = getattr(signature, name)
        if value is not None and not value > 0:
            raise ArtifactError(f"Signature.{name} must be > 0, got {value!r}")
    for channel in signature.channels:
        where = f"Signature channel {channel.channel!r}"
        s = channel.structure
        for name in ("period", "seasonal_order", "diff_order", "ar_order"):
            if getattr(s, name) < 0:
                raise ArtifactError(f"{where}: structure.{name} must be >= 0, got "
                                    f"{getattr(s, name)}")
        for name in ("tau", "embedding_dim", "hidden_units"):
            if getattr(s, name) < 1:
                raise ArtifactError(f"{where}: structure.{name} must be >= 1, got "
                                    f"{getattr(s, name)}")
        for name in ("scale", "nn_scale"):
            if not getattr(s, name) > 0:
                raise ArtifactError(f"{where}: structure.{name} must be > 0, got "
                                    f"{getattr(s, name)}")
        linear, network = channel.linear, channel.nonlinear
        if len(linear.coefficients) != s.ar_order or len(linear.standard_errors) != s.ar_order:
            raise ArtifactError(f"{where}: linear.coefficients and standard_errors must have "
                                f"ar_order = {s.ar_order} items, got "
                                f"{len(linear.coefficients)} and {len(linear.standard_errors)}")
        if len(network.output_weights) != s.hidden_units:
            raise ArtifactError(f"{where}: nonlinear.output_weights must have hidden_units = "
                                f"{s.hidden_units} items, got {len(network.output_weights)}")
        shape = (len(network.input_weights),
                 *sorted({len(row) for row in network.input_weights}))
        if shape != (s.hidden_units, s.embedding_dim):
            raise ArtifactError(f"{where}: nonlinear.input_weights must have shape "
                                f"(hidden_units, embedding_dim) = ({s.hidden_units}, "
                                f"{s.embedding_dim}), got rows of lengths "
                                f"{[len(row) for row in network.input_weights]}")
        level = channel.level
        if level is not None and (len(level.slopes) != len(level.center) or level.horizon < 1
                                  or not level.residual_std >= 0):
            raise ArtifactError(f"{where}: level must have as many slopes as centre values, "
                                f"horizon >= 1 and residual_std >= 0, got {len(level.slopes)} "
                                f"slopes, {len(level.center)} centre values, horizon "
                                f"{level.horizon}, residual_std {level.residual_std}")
