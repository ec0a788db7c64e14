"""The tiers: one :class:`~graybox.tiers.base.Tier` subclass per tier, one module each, and
their registration.

Each kind owns its tier's fitting (given what the shared fit pipeline prepares), its
parameters, their changes and the names the tier is stored under (see
:mod:`graybox.tiers.base`). :data:`TIER_KINDS` lists the built-in kinds in the order every
table, plot and parameter vector uses and the pipeline fits them in; :data:`TIERS` holds
their names in the same order. A fit, a drift or a parameter vector can be given other kinds
(``kinds=``): a new tier is one module and one entry in such a tuple.
"""
from __future__ import annotations

from graybox.tiers.base import Tier
from graybox.tiers.level import LevelTierKind
from graybox.tiers.linear import LinearTierKind
from graybox.tiers.noise import NoiseTierKind
from graybox.tiers.nonlinear import NonlinearTierKind, network_function, reference_set

__all__ = ["Tier", "LinearTierKind", "NonlinearTierKind", "NoiseTierKind", "LevelTierKind",
           "TIER_KINDS", "TIERS", "tier_kind", "tier_order", "network_function", "reference_set"]

#: the tier kinds, in the order of every table, plot and parameter vector
TIER_KINDS: tuple[Tier, ...] = (LinearTierKind(), NonlinearTierKind(), NoiseTierKind(),
                                LevelTierKind())

#: their names, in the same order
TIERS: tuple[str, ...] = tuple(kind.name for kind in TIER_KINDS)


def tier_order(tier: str) -> tuple[int, str]:
    """Where the tier called ``tier`` sorts in a table or plot: the built-in tiers in
    :data:`TIERS` order, then tiers added through ``kinds=`` by name.

    Parameters
    ----------
    tier : str

    Returns
    -------
    tuple of (int, str)
        A sort key.
    """
    return (TIERS.index(tier), "") if tier in TIERS else (len(TIERS), tier)


def tier_kind(tier: str, kinds: tuple[Tier, ...] = TIER_KINDS) -> Tier:
    """The tier kind called ``tier``.

    Parameters
    ----------
    tier : str
        One of :data:`TIERS` (of ``kinds``' names).
    kinds : tuple of Tier, default TIER_KINDS

    Returns
    -------
    Tier

    Raises
    ------
    ValueError
        For an unknown name.
    """
    for kind in kinds:
        if kind.name == tier:
            return kind
    raise ValueError(f"unknown tier {tier!r}; tiers: {tuple(kind.name for kind in kinds)}")
