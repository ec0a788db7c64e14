"""What a channel's tiers are fitted with: the frozen structure a candidate shares with its
baseline, and the evidence behind a baseline's choices of it."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from graybox.stationarize import Differencing


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
    reference_points : int
        Size of the fixed reference set of delay vectors on which the network's drift is
        measured in function space (:class:`graybox.tiers.NonlinearTierKind`); None (or 0)
        where the drift is Eq. 28 on the weights, as in signatures stored before the measure.
    centred_network : bool or None
        True: the network models each window's AR residual less that window's mean
        (:func:`graybox.nonlinear_tier.window_centred`), as every baseline fitted since
        2026-11-30 does; None: the residual as it is, as in signatures stored before.
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
    reference_points: int | None = None
    centred_network: bool | None = None

    #: written only when set, so structures stored before these read and write as before
    omitted_when_none: ClassVar[frozenset[str]] = frozenset({"reference_points",
                                                             "centred_network"})

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

    #: diagnostics only (never compared): a degenerate series may give NaN
    non_finite_fields: ClassVar[frozenset[str]] = frozenset(
        {"acf_area", "raw_acf_area", "adf_statistic"})
