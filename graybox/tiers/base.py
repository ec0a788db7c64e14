"""The tier protocol: one class per tier owns its fitting, parameters, changes and names.

As ``ruptures`` has one small ``BaseCost`` subclass per cost, graybox has one :class:`Tier`
subclass per tier, each in its own module of :mod:`graybox.tiers`; code that fits, stores,
compares or plots "tier X" asks the tier's object instead of dispatching on its name. A new
tier is one module (a subclass and its record) and one registration: listed in the kinds a
fit is given (``fit_signatures(..., kinds=TIER_KINDS + (MyTier(),))``, no global state),
or, as a built-in tier, in :data:`graybox.tiers.TIER_KINDS`.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, Mapping, Sequence

import numpy as np

from graybox import record_json
from graybox.frozen_map import FrozenMap
from graybox.exceptions import ConstantSeriesError, GrayBoxError, StructureMismatchError
from graybox.settings import GrayBoxSettings

if TYPE_CHECKING:  # pragma: no cover - typing only (graybox.signature imports this module)
    from graybox.signature import ChannelSignature
    from graybox.tiers.fit_state import AssetFit


def stood_still(channel: str, error: ConstantSeriesError) -> ConstantSeriesError:
    """A tier's "constant" error, naming the channel and the likely cause: the machine stood
    still through the window (a class whose machine stops declares when it runs with its
    grid's ``running``, so that those hours are left out)."""
    return ConstantSeriesError(f"channel {channel!r}: {error} (did the machine stand still "
                               f"all window? a class whose machine stops declares when it "
                               f"runs: its grid's `running`)")


class Tier:
    """One tier kind.

    Attributes
    ----------
    name : str
        The tier's name in signatures, drifts, calibrations, bundle arrays and metrics.
    tensor_part : str
        The name of the tier's one stored array (:meth:`tensors`), e.g. ``coefficients``.
    field : str or None
        The :class:`~graybox.signature.ChannelSignature` field holding the tier's record (the
        four tiers the signature format was written with); None keeps the record, as its JSON
        dict, in ``ChannelSignature.tiers`` under :attr:`name`.
    record_type : type
        The frozen record of one channel's fitted tier (read back from ``tiers`` by it).
    stage : str
        The :class:`~graybox.stage_clock.StageClock` stage the tier's fitting is timed in.
    early : bool
        Whether :meth:`fit` runs as each asset is prepared (True) or after every tier's
        :meth:`fit_batch`, as each asset is finished (False: the noise tier, which describes
        what the batched network leaves).
    condition_figures : tuple of str
        The kinds of input figure (:data:`graybox.operating_conditions.FIGURE_KINDS`) whose
        distance beyond the baseline's days :meth:`outside` is given: the inputs' means and
        spreads by default (the operating point the tier's parameters were fitted at).

    Notes
    -----
    **Fitting.** The shared pipeline (:func:`graybox.signature_fit.fit_signatures`) prepares
    each asset: the residual of every channel at the analysis interval, its segments and
    their windows, the white box's states, and for a candidate the baseline's channel (each
    :class:`~graybox.tiers.fit_state.ChannelFit`'s ``reference``, whose structure is frozen).
    Then, in the order of the kinds it is given, it calls each early tier's :meth:`fit` on
    the asset, each tier's :meth:`fit_batch` on all assets of the call together, and each
    late tier's :meth:`fit`. :meth:`fit` sets ``channel.records[name]`` for every channel
    (None where the tier is absent); a tier may read the records (and ``structure``,
    ``w_segments``, ``network_errors``) the tiers before it set: tiers hand each other data
    on the channel, never a callback. The residual segments and the states are there for the
    early tiers only (dropped before the batched fits, to keep memory low).

    :meth:`fit_batch` exists for speed: a tier whose work is many small computations of the
    same shape across assets (the network's training) does them in one batched computation
    there, after its :meth:`fit` prepared each asset's problem. A request's result must not
    depend on the other requests: when :meth:`fit_batch` raises, the pipeline calls it for
    each asset alone, so only the asset that causes the error fails; it returns the errors of
    assets whose batched fit came out unusable. By default it does nothing.

    **Parameters and changes.** Subclasses define :meth:`parameters`; :meth:`deltas` defaults
    to the plain differences of those parameters, :meth:`drift_deltas` discounts them outside
    the baseline's operating range (:meth:`outside`).
    """

    name: ClassVar[str] = ""
    tensor_part: ClassVar[str] = ""
    field: ClassVar[str | None] = None
    record_type: ClassVar[type] = object
    stage: ClassVar[str] = ""
    early: ClassVar[bool] = True
    condition_figures: ClassVar[tuple[str, ...]] = ("mean", "spread")

    # -- fitting ---------------------------------------------------------------------------

    def fit(self, asset: AssetFit, settings: GrayBoxSettings) -> None:
        """Fit this tier for every channel of one asset: set ``channel.records[name]``.

        Parameters
        ----------
        asset : AssetFit
            What the shared pipeline prepared, with the records of the tiers fitted before.
        settings : GrayBoxSettings
            The settings the asset is fitted with (a candidate: its baseline's).

        Raises
        ------
        GrayBoxError
            When the asset's data cannot be fitted; the asset's result is the error.
        """
        raise NotImplementedError

    def fit_batch(self, assets: Sequence[AssetFit], settings: GrayBoxSettings,
                  chunk_size: int) -> dict[int, GrayBoxError]:
        """The part of the fit done for many assets together (see the class notes).

        Parameters
        ----------
        assets : sequence of AssetFit
        settings : GrayBoxSettings
        chunk_size : int
            Series per batched computation (an execution detail: no result depends on it).

        Returns
        -------
        dict of int to GrayBoxError
            By ``id`` of the asset, the errors of assets whose result is unusable.
        """
        return {}

    # -- records -------------------------------------------------------------------------

    def record(self, channel: ChannelSignature) -> Any:
        """This tier's record in ``channel``, or None where the channel lacks the tier."""
        if self.field is not None:
            return getattr(channel, self.field)
        stored = (channel.tiers or {}).get(self.name)
        return None if stored is None else record_json.from_dict(self.record_type, stored)

    def present(self, channel: ChannelSignature) -> bool:
        """Whether ``channel`` has this tier (signatures stored before a tier existed lack it).

        Parameters
        ----------
        channel : ChannelSignature

        Returns
        -------
        bool
        """
        if self.field is not None:
            return getattr(channel, self.field) is not None
        return self.name in (channel.tiers or {})

    # -- parameters and changes -------------------------------------------------------------

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
        bundle names them :meth:`tensor_name`): by default one array, :attr:`tensor_part`, of
        :meth:`parameters`' values.

        Parameters
        ----------
        channel : ChannelSignature

        Returns
        -------
        dict of str to ndarray
        """
        return {self.tensor_part: self.parameters(channel)[1]}

    def tensor_name(self, channel: str, part: str) -> str:
        """The name of a bundle array: ``<channel>.<tier>.<part>``."""
        return f"{channel}.{self.name}.{part}"

    def fit_metrics(self, channel: ChannelSignature) -> dict[str, float | None]:
        """The tier's own fit figures in ``channel`` as per-channel metrics, by name (e.g.
        ``fit.omega.ar_innovation_variance``; a None value is left out where they are
        recorded): by default none.

        Parameters
        ----------
        channel : ChannelSignature
            A channel that has the tier (:meth:`present`).

        Returns
        -------
        dict of str to float or None
        """
        return {}

    def summary_lines(self, channel: ChannelSignature) -> list[str]:
        """The tier's section of :meth:`graybox.signature.Signature.summary` for ``channel``
        (which has the tier): by default its name, then its parameters.

        Parameters
        ----------
        channel : ChannelSignature

        Returns
        -------
        list of str
            Lines of at most :data:`graybox.summary.WIDTH` characters.
        """
        from graybox.summary import field_lines, format_number

        names, values = self.parameters(channel)
        return [f"Tier {self.name}"] + field_lines(
            [(name, format_number(float(value))) for name, value in zip(names, values)], "  ")

    def hint(self, changes: Sequence[Mapping[str, Any]], conditions: str | None = None,
             count: int = 3) -> str:
        """An alert's root-cause hint for this tier (:meth:`graybox.alert.Alert.hint`): by
        default the ``count`` parameters that moved most, ``a1 0.91→1.12, ...``, and, for a
        window driven beyond the baseline's input conditions, which input left them.

        Parameters
        ----------
        changes : sequence of mapping
            The alert's ``top_changes`` (``name``, ``baseline``, ``candidate``), largest
            first.
        conditions : str, optional
            The alert's ``conditions``.
        count : int, default 3

        Returns
        -------
        str
        """
        moved = ", ".join(f"{c['name']} {c['baseline']:.3g}→{c['candidate']:.3g}"
                          for c in changes[:count])
        return moved + (f"; outside the baseline's conditions: {conditions}"
                        if conditions else "")

    def metric_name(self, kind: str, channel: str) -> str:
        """The name of a per-channel metric of this tier: ``<kind>.<channel>.<tier>`` (e.g.
        ``zeta.omega.linear``)."""
        return f"{kind}.{channel}.{self.name}"

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

    def discount(self, candidate: ChannelSignature, baseline: ChannelSignature,
                 conditions: float = 0.0) -> float:
        """What :meth:`drift_deltas` divides the changes by: :meth:`outside` where that
        exceeds 1, else 1. A tier's healthy change grows with the distance from the
        conditions calibration saw, which reached 1 (:mod:`graybox.operating_conditions`);
        to first order in proportion to it."""
        return max(1.0, self.outside(candidate, baseline, conditions))

    def epsilon_floor(self, candidate: ChannelSignature, baseline: ChannelSignature,
                      conditions: float = 0.0, alpha: float | None = None) -> float:
        """The least epsilon of the tier for this pair: a zeta no measurement can tell from
        no change (:func:`graybox.drift.compute_drift` takes the larger of it and the
        calibrated epsilon). 0: the calibration alone decides.

        ``alpha``: the calibration's per-threshold false-alarm rate, for a tier whose floor
        is a quantile of the zeta sampling noise alone gives (None: no such quantile)."""
        return 0.0

    def drift_deltas(self, candidate: ChannelSignature, baseline: ChannelSignature,
                     conditions: float = 0.0) -> np.ndarray:
        """The changes zeta sums: :meth:`deltas` divided by :meth:`discount`."""
        return self.deltas(candidate, baseline) / self.discount(candidate, baseline, conditions)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


def channel_fields(kinds: Sequence[Tier], records: dict[str, Any]) -> dict[str, Any]:
    """The :class:`~graybox.signature.ChannelSignature` keyword arguments that keep the
    tiers' fitted ``records`` (by tier name): a tier with a :attr:`~Tier.field` in it, the
    others' records as JSON dicts in ``tiers`` (None when there are none).

    Parameters
    ----------
    kinds : sequence of Tier
    records : dict of str to record
        Per tier name, the channel's record or None (the tier absent).

    Returns
    -------
    dict
    """
    fields: dict[str, Any] = {}
    others = {}
    for kind in kinds:
        record = records.get(kind.name)
        if kind.field is not None:
            fields[kind.field] = record
        elif record is not None:
            others[kind.name] = record_json.to_dict(record)
    fields["tiers"] = FrozenMap(others) if others else None
    return fields
