"""Drift: how far a candidate's parameters moved from the healthy baseline (zeta, Eq. 28)."""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Sequence

import numpy as np

from graybox.exceptions import StructureMismatchError
from graybox.operating_conditions import farthest
from graybox.signature import ChannelSignature, Signature
from graybox.summary import drift_summary
from graybox.tiers import TIER_KINDS, Tier, tier_kind


def tier_deltas(candidate: ChannelSignature, baseline: ChannelSignature,
                tier: str) -> tuple[list[str], np.ndarray]:
    """Per-parameter changes whose squares sum to zeta (of a night inside the baseline's
    operating range: :meth:`graybox.tiers.Tier.drift_deltas` discounts one outside it).

    Linear tier: ``a_i - a_i0``. Nonlinear tier: the change of the network's output on a fixed
    reference set of delay vectors (function space; Eq. 28 on the weights for structures stored
    before that measure, see :class:`graybox.tiers.NonlinearTierKind`). Noise tier: moment
    changes in units of the baseline noise standard deviation (mean), relative (variance), or
    as they are (skewness, kurtosis), each divided by its sampling standard deviation under the
    baseline residual's own distribution (:attr:`graybox.noise_tier.NoiseTier.moment_weights`;
    see :mod:`graybox.tiers`).

    Parameters
    ----------
    candidate, baseline : ChannelSignature
    tier : str
        One of :data:`graybox.tiers.TIERS`.

    Returns
    -------
    names : list of str
    deltas : ndarray
    """
    kind = tier_kind(tier)
    names, _ = kind.parameters(candidate)
    return names, kind.deltas(candidate, baseline)


@dataclass(frozen=True)
class ParameterChange:
    """One parameter's move, in the units zeta adds up."""

    name: str
    baseline: float
    candidate: float
    contribution: float   #: its share of zeta (squared scaled change)

    @classmethod
    def from_dict(cls, data: dict) -> "ParameterChange":
        """The change of :func:`dataclasses.asdict` (or its JSON)."""
        return cls(str(data["name"]), float(data["baseline"]), float(data["candidate"]),
                   float(data["contribution"]))


@dataclass(frozen=True)
class TierDrift:
    """Zeta of one tier of one channel, and its threshold when calibrated.

    ``parameter_zeta`` is the sum of the squared parameter changes where the alarm measure is
    not (the nonlinear tier: ``zeta`` is its change in function space, ``parameter_zeta``
    Eq. 28 on the weights, recorded and shown); None elsewhere.

    ``outside`` is set where the candidate lies outside the baseline's operating range and
    the tier discounted its change for that (above 1): for the level tier the night's
    operating-condition correction over the largest of a baseline day's
    (:func:`graybox.level_tier.extrapolation`), for the other tiers the night's input
    conditions beyond every baseline day's (:func:`graybox.operating_conditions.outside`);
    None inside the range.
    """

    channel: str
    tier: str
    zeta: float
    epsilon: float | None
    top_changes: tuple[ParameterChange, ...]
    parameter_zeta: float | None = None
    outside: float | None = None

    @property
    def ratio(self) -> float | None:
        """``zeta / epsilon`` (above 1 is an alarm). A tier without parameters (an AR
        order of 0) has zeta and epsilon 0: no change, ratio 0."""
        if self.epsilon is None:
            return None
        if self.epsilon > 0:
            return self.zeta / self.epsilon
        return float("inf") if self.zeta > 0 else 0.0

    @property
    def exceeded(self) -> bool:
        """No alarm while ``zeta <= epsilon`` (Eq. 29)."""
        return self.epsilon is not None and self.zeta > self.epsilon

    @classmethod
    def from_dict(cls, data: dict) -> "TierDrift":
        """The entry of :meth:`Drift.to_dict` (or its JSON); other keys are ignored."""
        epsilon, parameter_zeta = data.get("epsilon"), data.get("parameter_zeta")
        outside = data.get("outside")
        return cls(str(data["channel"]), str(data["tier"]), float(data["zeta"]),
                   None if epsilon is None else float(epsilon),
                   tuple(ParameterChange.from_dict(c) for c in data.get("top_changes", ())),
                   None if parameter_zeta is None else float(parameter_zeta),
                   None if outside is None else float(outside))


@dataclass(frozen=True)
class Drift:
    """Zeta per tier and channel of a candidate against its baseline.

    ``conditions`` says, for a candidate driven beyond every baseline day's input conditions
    (:mod:`graybox.operating_conditions`), which input figure lies farthest outside, with its
    value and the baseline days' range; None inside the range.
    """

    entries: tuple[TierDrift, ...]
    n_samples: int
    conditions: str | None = None

    def get(self, channel: str, tier: str) -> TierDrift:
        for entry in self.entries:
            if entry.channel == channel and entry.tier == tier:
                return entry
        raise KeyError((channel, tier))

    @property
    def zeta(self) -> dict[tuple[str, str], float]:
        return {(e.channel, e.tier): e.zeta for e in self.entries}

    @property
    def alarms(self) -> tuple[TierDrift, ...]:
        """The entries whose zeta exceeds epsilon."""
        return tuple(e for e in self.entries if e.exceeded)

    @property
    def alarmed(self) -> bool:
        return bool(self.alarms)

    @property
    def largest(self) -> TierDrift | None:
        """The entry with the largest zeta / epsilon: where the window came nearest to an
        alarm (None where no entry is calibrated)."""
        rated = [e for e in self.entries if e.ratio is not None]
        return max(rated, key=lambda e: e.ratio) if rated else None

    @property
    def discounted(self) -> dict[float, list[str]]:
        """The entries discounted outside the baseline's operating range, as
        ``"channel tier"``, grouped by how far outside (the input conditions set one figure
        for the linear and nonlinear tiers, one with the inputs' excitation for the noise
        tier and the level its own, see :mod:`graybox.operating_conditions`)."""
        groups: dict[float, list[str]] = {}
        for e in self.entries:
            if e.outside is not None:
                groups.setdefault(e.outside, []).append(f"{e.channel} {e.tier}")
        return groups

    def summary(self) -> str:
        """A readable plain-text table of the drift, as statsmodels' ``summary()``.

        Returns
        -------
        str
            Per channel and tier zeta, epsilon, their ratio and whether zeta exceeds epsilon
            (``YES``), notes where a tier's measure needs one, and the top parameter changes.

        Examples
        --------
        >>> print(gb.compute_drift(candidate, baseline, calibration).summary())  # doctest: +SKIP
        """
        return drift_summary(self)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "Drift":
        """The drift of :meth:`to_dict` (or its JSON): an exact round trip; other keys are
        ignored."""
        conditions = data.get("conditions")
        return cls(tuple(TierDrift.from_dict(e) for e in data["entries"]),
                   int(data["n_samples"]), None if conditions is None else str(conditions))


def check_comparable(candidate: Signature, baseline: Signature) -> None:
    """Raise :class:`StructureMismatchError` unless the two share the frozen structure."""
    mine, theirs = candidate.frozen_structure(), baseline.frozen_structure()
    if mine != theirs:
        differing = [key for key in mine if mine[key] != theirs.get(key)]
        raise StructureMismatchError(
            f"candidate and baseline differ in {differing}; a candidate must be fitted with the "
            f"baseline's frozen structure (GrayBox(..., baseline=...))")


def compute_drift(candidate: Signature, baseline: Signature, calibration=None,
                  top: int = 3, kinds: Sequence[Tier] = TIER_KINDS) -> Drift:
    """Zeta of every tier and channel of ``candidate`` against ``baseline``.

    Parameters
    ----------
    candidate, baseline : Signature
        Fitted with the same frozen structure (checked).
    calibration : graybox.calibration.Calibration, optional
        Supplies epsilon per tier and channel (scaled to the candidate's sample count and
        the baseline's, see :mod:`graybox.epsilon_scaling`), at least the tier's
        :meth:`~graybox.tiers.Tier.epsilon_floor` (the level tier's: one step of a quantized
        reading; the noise tier's: what the moments' sampling noise alone exceeds at the
        calibration's per-threshold rate).
    top : int, default 3
        Parameter changes kept per entry as a root-cause hint.
    kinds : sequence of Tier, default TIER_KINDS
        The tiers compared (those the signatures were fitted with, see
        :func:`graybox.signature_fit.fit_signatures`).

    Returns
    -------
    Drift
    """
    check_comparable(candidate, baseline)
    # per kind of tier, how far beyond the baseline's days the figures it answers to lie
    far = {figures: farthest(candidate.conditions, baseline.conditions, figures)
           for figures in {kind.condition_figures for kind in kinds}}
    entries = []
    for channel in candidate.channels:
        healthy = baseline.channel(channel.channel)
        for kind in kinds:
            if not (kind.present(channel) and kind.present(healthy)):
                continue  # a tier one of them was stored without
            tier = kind.name
            conditions = far[kind.condition_figures][0]
            names, current = kind.parameters(channel)
            _, reference = kind.parameters(healthy)
            beyond = kind.outside(channel, healthy, conditions)
            discount = kind.discount(channel, healthy, conditions)
            zeta = float(np.sum(kind.drift_deltas(channel, healthy, conditions) ** 2))
            contributions = (kind.parameter_changes(channel, healthy) / discount) ** 2
            order = np.argsort(contributions)[::-1][:top]
            changes = tuple(ParameterChange(names[i], float(reference[i]), float(current[i]),
                                            float(contributions[i])) for i in order)
            parameter_zeta = float(contributions.sum())
            epsilon = None
            if calibration is not None:
                epsilon = max(calibration.epsilon(channel.channel, tier,
                                                  n_samples=channel.n_samples,
                                                  baseline_samples=healthy.n_samples),
                              kind.epsilon_floor(channel, healthy, conditions,
                                                 calibration.test_alpha))
            entries.append(TierDrift(channel.channel, tier, zeta, epsilon, changes,
                                     None if parameter_zeta == zeta else parameter_zeta,
                                     beyond if beyond > 1 else None))
    conditions, figure = max(far.values(), key=lambda pair: pair[0], default=(0.0, None))
    return Drift(tuple(entries), candidate.n_samples, figure if conditions > 1 else None)
