"""The tier kinds: which parameters a tier has, and how zeta scales their changes.

One small object per kind (as ``ruptures`` has one ``BaseCost`` subclass per cost), so that
code which needs "the parameters of tier X" or "the changes of tier X" asks the kind instead
of dispatching on its name. :data:`TIER_KINDS` lists them in the order every table, plot and
parameter vector uses; :data:`TIERS` holds their names in the same order.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from graybox.exceptions import StructureMismatchError
from graybox.level_tier import extrapolation
from graybox.noise_tier import MOMENT_WEIGHTS

if TYPE_CHECKING:  # pragma: no cover - typing only (graybox.signature imports this module)
    from graybox.signature import ChannelSignature


class Tier:
    """One tier kind.

    Attributes
    ----------
    name : str
        The tier's name in signatures, drifts and calibrations.

    Notes
    -----
    Subclasses define :meth:`parameters`; :meth:`deltas` defaults to the plain differences of
    those parameters.
    """

    name: str = ""
    #: the name of the tier's one stored array (:meth:`tensors`), e.g. ``coefficients``
    tensor_part: str = ""

    def present(self, channel: ChannelSignature) -> bool:
        """Whether ``channel`` has this tier (signatures stored before a tier existed lack it).

        Parameters
        ----------
        channel : ChannelSignature

        Returns
        -------
        bool
        """
        return True

    def parameters(self, channel: ChannelSignature) -> tuple[list[str], np.ndarray]:
        """Names and values of this tier's parameters in ``channel``.

        Parameters
        ----------
        channel : ChannelSignature

        Returns
        -------
        names : list of str
        values : ndarray of shape (len(names),)
        """
        raise NotImplementedError

    def tensors(self, channel: ChannelSignature) -> dict[str, np.ndarray]:
        """The tier's parameters as the arrays a signature bundle stores, by part name (the
        bundle names them ``<channel>.<tier>.<part>``): by default one array,
        :attr:`tensor_part`, of :meth:`parameters`' values.

        Parameters
        ----------
        channel : ChannelSignature

        Returns
        -------
        dict of str to ndarray
        """
        return {self.tensor_part: self.parameters(channel)[1]}

    def deltas(self, candidate: ChannelSignature, baseline: ChannelSignature) -> np.ndarray:
        """Per-parameter changes of ``candidate`` from ``baseline``, in the units zeta sums
        (before :meth:`drift_deltas` discounts a night outside the baseline's range).

        Parameters
        ----------
        candidate, baseline : ChannelSignature
            The same channel of a candidate and of its baseline.

        Returns
        -------
        ndarray
            One change per parameter, in the order of :meth:`parameters`.

        Raises
        ------
        StructureMismatchError
            When the two have different numbers of parameters in this tier.
        """
        _, current = self.parameters(candidate)
        _, healthy = self.parameters(baseline)
        if current.shape != healthy.shape:
            raise StructureMismatchError(
                f"channel {candidate.channel!r} {self.name} tier has {current.size} parameters, "
                f"the baseline {healthy.size}: fit the candidate with the baseline's structure")
        return current - healthy

    def parameter_changes(self, candidate: ChannelSignature,
                          baseline: ChannelSignature) -> np.ndarray:
        """Per-parameter changes shown as an alarm's hint, in the order of :meth:`parameters`.

        The same as :meth:`deltas` where zeta is a sum over the parameters themselves.
        """
        return self.deltas(candidate, baseline)

    def outside(self, candidate: ChannelSignature, baseline: ChannelSignature,
                conditions: float = 0.0) -> float:
        """How far outside the baseline's operating range the candidate lies for this tier
        (above 1: outside): by default ``conditions``, the asset's distance beyond its
        baseline's input conditions (:func:`graybox.operating_conditions.outside`).

        Parameters
        ----------
        candidate, baseline : ChannelSignature
        conditions : float, default 0
            The candidate's :func:`graybox.operating_conditions.outside` of its baseline.
        """
        return conditions

    def drift_deltas(self, candidate: ChannelSignature, baseline: ChannelSignature,
                     conditions: float = 0.0) -> np.ndarray:
        """The changes zeta sums: :meth:`deltas` divided by :meth:`outside` where that
        exceeds 1. A tier's healthy change grows with the distance from the conditions
        calibration saw, which reached 1 (:mod:`graybox.operating_conditions`)."""
        return self.deltas(candidate, baseline) / max(1.0, self.outside(candidate, baseline,
                                                                        conditions))

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class LinearTierKind(Tier):
    """The AR tier: coefficients ``a_1..a_n``; changes ``a_i - a_i0``."""

    name = "linear"
    tensor_part = "coefficients"

    def parameters(self, channel: ChannelSignature) -> tuple[list[str], np.ndarray]:
        coefficients = channel.linear.coefficients
        return [f"a{i}" for i in range(1, len(coefficients) + 1)], np.asarray(coefficients, float)


class NonlinearTierKind(Tier):
    """The network tier: output weights ``W_1j`` then input weights ``w_jk``.

    Its parameters are the weights, and :meth:`parameter_changes` their changes, so that Eq. 28
    is recorded and shown. The alarm measure (:meth:`deltas`) is the change of the network's
    *function* on a fixed reference set of delay vectors: hidden units permute and flip sign
    (``tanh`` is odd: ``(w_j, W_1j) -> (-w_j, -W_1j)``) and trade weight along flat directions
    while the function stays the same, so two fits of equally healthy data can land far apart
    in weight space; their functions cannot. A structure without ``reference_points`` (stored
    before the measure existed) keeps Eq. 28 on the weights.
    """

    name = "nonlinear"

    def tensors(self, channel: ChannelSignature) -> dict[str, np.ndarray]:
        """``input_weights`` of shape (J, m) and ``output_weights`` (J,)."""
        w, W = channel.nonlinear.weight_arrays()
        return {"input_weights": w, "output_weights": W}

    def parameters(self, channel: ChannelSignature) -> tuple[list[str], np.ndarray]:
        w, W = channel.nonlinear.weight_arrays()
        names = [f"W1_{j}" for j in range(1, len(W) + 1)]
        names += [f"w_{j}_{k}" for j in range(1, w.shape[0] + 1) for k in range(1, w.shape[1] + 1)]
        return names, np.concatenate([W, w.ravel()])

    def parameter_changes(self, candidate: ChannelSignature,
                          baseline: ChannelSignature) -> np.ndarray:
        """``W_1j - W_1j0`` and ``w_jk - w_jk0``, whose squares sum to Eq. 28's zeta."""
        return super().deltas(candidate, baseline)

    def deltas(self, candidate: ChannelSignature, baseline: ChannelSignature) -> np.ndarray:
        """``(f(z_r) - f0(z_r)) / sqrt(R)`` over the reference set: their squares sum to the
        mean squared change of the network's one-step prediction (scaled units)."""
        reference = reference_set(baseline)
        if reference is None:
            return self.parameter_changes(candidate, baseline)
        current, healthy = candidate.nonlinear, baseline.nonlinear
        if (current.hidden_units, current.embedding_dim) != (healthy.hidden_units,
                                                             healthy.embedding_dim):
            raise StructureMismatchError(
                f"channel {candidate.channel!r} nonlinear tier has {current.hidden_units} x "
                f"{current.embedding_dim} input weights, the baseline {healthy.hidden_units} x "
                f"{healthy.embedding_dim}: fit the candidate with the baseline's structure")
        return (network_function(current, reference) -
                network_function(healthy, reference)) / np.sqrt(len(reference))


def network_function(tier, points: np.ndarray) -> np.ndarray:
    """The Eq. 25 network's output ``tanh(tanh(z w^T) W)`` at delay vectors ``points``."""
    w, W = tier.weight_arrays()
    return np.tanh(np.tanh(points @ w.T) @ W)


def reference_set(baseline: ChannelSignature) -> np.ndarray | None:
    """The fixed delay vectors on which a network's drift is measured, or None (Eq. 28).

    ``reference_points`` draws, seeded by the baseline's ``init_seed``, from a normal
    distribution with independent coordinates at the spread of the network's scaled input
    (the AR residual, nearly white, divided by ``nn_scale``): the same points for the
    baseline, its calibration pieces and every candidate, placed where the data lie.
    """
    structure = baseline.structure
    count = structure.reference_points or 0
    if count <= 0:
        return None
    variance = float(baseline.noise.variance)
    spread = (np.sqrt(variance) / structure.nn_scale
              if np.isfinite(variance) and variance > 0 and structure.nn_scale > 0 else 0.25)
    rng = np.random.default_rng([int(structure.init_seed), 0x2EF])
    return rng.normal(0.0, spread, (count, structure.embedding_dim))


class NoiseTierKind(Tier):
    """The noise tier: mean, variance, skewness and excess kurtosis of the final residual.

    Changes are in units of the baseline noise standard deviation (mean), relative (variance),
    or as they are (skewness, kurtosis), each scaled by the square root of
    :data:`graybox.noise_tier.MOMENT_WEIGHTS`.
    """

    name = "noise"
    tensor_part = "moments"

    def parameters(self, channel: ChannelSignature) -> tuple[list[str], np.ndarray]:
        names = ["mean", "variance", "skewness", "excess_kurtosis"]
        return names, np.asarray(channel.noise.moments)

    def deltas(self, candidate: ChannelSignature, baseline: ChannelSignature) -> np.ndarray:
        delta = super().deltas(candidate, baseline)
        variance = baseline.noise.variance
        delta = delta / np.array([np.sqrt(variance), variance, 1.0, 1.0])
        return delta * np.sqrt(MOMENT_WEIGHTS)


class LevelTierKind(Tier):
    """The level tier (:mod:`graybox.level_tier`): the channel's level at the baseline's
    operating point.

    One parameter, ``level``; its change is in units of the baseline's regression residual
    standard deviation. Its :meth:`outside` is the candidate's own
    :func:`~graybox.level_tier.extrapolation` (not the asset's input conditions): a night
    whose operating-condition correction is twice the largest of a baseline day's has its
    level change halved in :meth:`drift_deltas`, since the slopes that make the correction
    were only checked up to that reach (a slope's error grows the level error in proportion
    to the distance). Absent from signatures stored before the tier existed.
    """

    name = "level"
    tensor_part = "level"

    def present(self, channel: ChannelSignature) -> bool:
        return channel.level is not None

    def parameters(self, channel: ChannelSignature) -> tuple[list[str], np.ndarray]:
        if channel.level is None:
            raise StructureMismatchError(f"channel {channel.channel!r} has no level tier (a "
                                         f"signature stored before the tier existed)")
        return ["level"], np.array([channel.level.level])

    def deltas(self, candidate: ChannelSignature, baseline: ChannelSignature) -> np.ndarray:
        delta = super().deltas(candidate, baseline)
        spread = baseline.level.residual_std
        return delta / spread if spread > 0 else delta

    def outside(self, candidate: ChannelSignature, baseline: ChannelSignature,
                conditions: float = 0.0) -> float:
        return extrapolation(candidate.level, baseline.level)


#: the tier kinds, in the order of every table, plot and parameter vector
TIER_KINDS: tuple[Tier, ...] = (LinearTierKind(), NonlinearTierKind(), NoiseTierKind(),
                                LevelTierKind())

#: their names, in the same order
TIERS: tuple[str, ...] = tuple(kind.name for kind in TIER_KINDS)


def tier_kind(tier: str) -> Tier:
    """The tier kind called ``tier``.

    Parameters
    ----------
    tier : str
        One of :data:`TIERS`.

    Returns
    -------
    Tier

    Raises
    ------
    ValueError
        For an unknown name.
    """
    for kind in TIER_KINDS:
        if kind.name == tier:
            return kind
    raise ValueError(f"unknown tier {tier!r}; tiers: {TIERS}")
