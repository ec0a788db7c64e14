"""What the shared fit pipeline hands each tier: one asset's prepared residual and the
records the tiers fitted so far (:meth:`graybox.tiers.base.Tier.fit`)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from graybox.channel_structure import ChannelStructure, Selection
from graybox.integration import Integration
from graybox.operating_conditions import OperatingConditions
from graybox.parameter_estimate import ParameterEstimate
from graybox.segment_cache import SegmentCache
from graybox.state_estimation import WindowStates

if TYPE_CHECKING:  # pragma: no cover - typing only
    from graybox.signature import ChannelSignature
    from graybox.signature_fit import FitRequest


@dataclass
class ChannelFit:
    """One channel being fitted.

    Attributes
    ----------
    name : str
    segments : list of ndarray
        The channel's residual at the analysis interval, one array per operating segment;
        kept while the early tiers are fitted, then dropped (empty).
    seed : int
        Seeds the random starting weights of a new baseline's network.
    reference : ChannelSignature or None
        The baseline's channel for a candidate (its structure is frozen); None for a new
        baseline.
    structure : ChannelStructure or None
        The frozen structure: the reference's, or for a new baseline set by the tiers that
        choose it (the linear tier its differencing and order, the nonlinear tier its
        embedding).
    w_segments : list of ndarray
        The linear tier's innovations (the AR residual), per segment.
    n_samples : int
        Stationarized residual samples the tiers used.
    selection : Selection or None
        Evidence behind a new baseline's structure choices.
    records : dict of str to record
        Per tier name, the fitted record (None: the tier is absent); also read as attributes,
        ``channel.linear`` for ``channel.records["linear"]``.
    network_errors : list of ndarray or None
        The needed network's in-sample one-step errors per segment (after its delays), set by
        the nonlinear tier from its fit's own prediction
        (:func:`graybox.tiers.nonlinear.network_errors`): what the noise tier describes,
        without running the network over the data again; it drops them once described. None
        where the network is not needed or its fit computed no prediction (a trained
        network).
    """

    name: str
    segments: list[np.ndarray]
    seed: int
    reference: ChannelSignature | None = None
    structure: ChannelStructure | None = None
    w_segments: list[np.ndarray] = field(default_factory=list)
    n_samples: int = 0
    selection: Selection | None = None
    records: dict[str, Any] = field(default_factory=dict)
    network_errors: list[np.ndarray] | None = None

    def __getattr__(self, name: str) -> Any:
        records = self.__dict__.get("records", {})
        if name in records:
            return records[name]
        raise AttributeError(f"{type(self).__name__} has no attribute or tier {name!r}")


@dataclass
class AssetFit:
    """One asset being fitted: the pipeline's preparation, then every tier's records.

    Attributes
    ----------
    request : FitRequest
        The request, with its tuned white box.
    sample_interval, analysis_interval : float
        Seconds between telemetry samples, and between the residual samples the tiers see.
    window_start, window_end : str or None
    asset_id : str or None
    integration : Integration
    hidden_starts : tuple of HiddenStart or None
    owners : list of int
        The telemetry window of each segment.
    windows : list of WindowStates
        Each segment's white-box states at the analysis interval; kept while the early tiers
        are fitted, then dropped (empty).
    cache : SegmentCache or None
        Per-segment results of earlier fits of the same segments.
    channels : list of ChannelFit
    tuning : ParameterEstimate or None
    conditions : OperatingConditions or None
    """

    request: FitRequest
    sample_interval: float
    analysis_interval: float
    window_start: str | None
    window_end: str | None
    asset_id: str | None
    integration: Integration
    hidden_starts: tuple | None
    owners: list[int] = field(default_factory=list)
    windows: Sequence[WindowStates] = ()
    cache: SegmentCache | None = None
    channels: list[ChannelFit] = field(default_factory=list)
    tuning: ParameterEstimate | None = None
    conditions: OperatingConditions | None = None


def per_window(lengths: Sequence[int], owners: Sequence[int]) -> np.ndarray:
    """Sums of per-segment counts per window (``owners[i]``: the window of segment ``i``)."""
    return np.bincount(np.asarray(owners, dtype=np.intp), weights=np.asarray(lengths, float),
                       minlength=max(owners) + 1).astype(int)
