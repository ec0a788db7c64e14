"""Every choice of the gray-box method that is not learned from data.

Choices that concern time are given in seconds, never in samples, so that a fault is seen the
same way at 1 s, 10 s and 60 s telemetry: they are turned into sample counts at the
*analysis interval* (see :mod:`graybox.analysis_rate`) by :meth:`GrayBoxSettings.samples`.
Counts that remain are statistical (how many samples an estimate needs), not durations.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar, Mapping

from graybox import record_json
from graybox.network_settings import FitSettings
from graybox.residual import RESIDUAL_METHODS

#: keys of settings stored before the method was rate-invariant; such baselines were fitted
#: at their native sample interval with these counts, which their frozen structures keep
LEGACY_KEYS = ("max_ar_order", "max_delay")

#: residual samples per window ``min_samples = "auto"`` asks for where the windows hold them
MIN_SAMPLES_TARGET = 200
#: the fewest residual samples ``"auto"`` ever accepts (half a day at 15 minutes)
MIN_SAMPLES_FLOOR = 48
#: telemetry samples ``"auto"`` leaves a window for the structure (differencing, AR order,
#: network delays: a few samples at a slow logger's interval)
STRUCTURE_ROOM = 50
#: the fewest samples of an operating period fitted beside others: stationarizing compares
#: autocorrelations up to a quarter of the shortest residual segment and needs two lags of
#: them (8 residual samples), after the one-step residual and a difference have taken two
MIN_PERIOD_SAMPLES = 10


@dataclass(frozen=True)
class GrayBoxSettings:
    """Every choice of the method that is not learned from data.

    Attributes
    ----------
    residual : {"one_step", "inverse"}
        Eqs. 2-3 or Eq. 13.
    analysis_interval : float or {"auto", "native"}
        Seconds between the residual samples the tiers see. ``"auto"`` chooses it from the
        white box's dynamics at the data's operating points (see
        :func:`graybox.analysis_rate.choose_analysis_interval`); ``"native"`` keeps the
        telemetry's sample interval. A candidate always uses its baseline's interval.
    ar_span : float
        Seconds of history the AR order may cover: the order is chosen by ``ar_criterion``
        up to ``ar_span / analysis interval`` (20 lags at 10 s).
    ar_criterion : {"bic", "aic"}
    max_diff_order, max_seasonal_order : int
        Upper bounds of ``m1`` and ``m2``.
    hidden_units : int
        ``J`` of the Eq. 25 network.
    delay_span : float
        Seconds: the embedding delay ``tau`` is searched up to this (20 samples at 10 s).
    max_embedding_dim : int
        Upper bound of ``m`` (a number of coordinates, not a duration).
    holdout_fraction : float
        Tail of each baseline window held out to decide whether the network is needed.
    min_heldout_gain : float
        Relative held-out error reduction the network must achieve to count as needed.
    network : FitSettings
        Optimizer settings (identical for baselines, calibration refits and candidates).
    nn_scale_factor : float
        The network sees the AR residual divided by this many of its baseline standard
        deviations, which keeps targets well inside tanh's (-1, 1).
    min_samples : int or "auto"
        Fewest residual samples (at the analysis interval) per window after differencing and
        embedding: a statistical floor for the estimates, so a count and not a duration.
        ``"auto"`` (the default) is resolved by each new baseline from its own windows
        (:meth:`for_windows`): 200 wherever the shortest window holds 250 samples or more,
        as a fixed 200 did; a slow logger's shorter windows (a day at 15 minutes holds 96)
        keep 50 samples for the structure and use the rest, down to 48. The baseline
        records the resolved count, and its candidates use it.
    calibration_splits : int
        Most pieces each healthy window is cut into for calibrating epsilon; fewer when the
        pieces would hold less than the structure plus ``min_samples`` (slow telemetry).
    derivative_span : float
        Seconds covered by the Savitzky-Golay window of the inverse residual (Eq. 13): 7
        samples at 10 s, never fewer than 5.
    null_network : {"fixed_features", "trained"}
        How a network is fitted where the baseline has no nonlinear structure to explain.
        ``"fixed_features"``: the hidden layer stays at seeded random weights and only the
        output weights are fitted (one minimum, so healthy zeta is stable). ``"trained"``:
        every weight is fitted from the same seeded start (more sensitive to a nonlinearity
        that appears, but a network fitted to noise can land in another shallow minimum).
    needed_network : {"fixed_features", "trained"}
        How a network is fitted where the baseline's held-out test says the residual needs
        it. ``"fixed_features"`` (default): a seeded random hidden layer of
        ``needed_hidden_units`` units stays fixed and only the output weights are fitted, a
        problem with one minimum (fast, and a refit of the same function lands on the same
        weights). ``"trained"``: every weight of a ``hidden_units`` network is trained by
        L-BFGS in PyTorch (more flexible, 30-40 times the cost, and its weights are not
        identifiable).
    needed_hidden_units : int
        Hidden units of a needed network with fixed features: random features need more
        units than a trained layer to represent the same function.
    reference_points : int
        Delay vectors of the fixed reference set on which the nonlinear tier's drift is
        measured in function space (``0``: Eq. 28 on the weights decides, as baselines stored
        before this setting did).
    """

    residual: str = "one_step"
    analysis_interval: float | str = "auto"
    ar_span: float = 200.0
    ar_criterion: str = "bic"
    max_diff_order: int = 2
    max_seasonal_order: int = 1
    hidden_units: int = 8
    delay_span: float = 200.0
    max_embedding_dim: int = 6
    holdout_fraction: float = 0.2
    min_heldout_gain: float = 0.01
    network: FitSettings = FitSettings()
    nn_scale_factor: float = 4.0
    min_samples: int | str = "auto"
    calibration_splits: int = 8
    derivative_span: float = 60.0
    null_network: str = "fixed_features"
    needed_network: str | None = "fixed_features"
    needed_hidden_units: int | None = 32
    reference_points: int | None = 256

    #: None in settings stored before these fields (see :meth:`migrate`); written only when
    #: set, so such settings read and write back as they were stored
    omitted_when_none: ClassVar[frozenset[str]] = frozenset(
        {"needed_network", "needed_hidden_units", "reference_points"})

    def __post_init__(self):
        if self.residual not in RESIDUAL_METHODS:
            raise ValueError(f"residual must be one of {RESIDUAL_METHODS}, got {self.residual!r}")
        if self.ar_criterion not in ("aic", "bic"):
            raise ValueError(f"ar_criterion must be 'aic' or 'bic', got {self.ar_criterion!r}")
        if not 0 < self.holdout_fraction < 1:
            raise ValueError("holdout_fraction must be in (0, 1)")
        for name, allowed in (("null_network", ("fixed_features", "trained")),
                              ("needed_network", ("fixed_features", "trained", None))):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name} must be 'fixed_features' or 'trained', "
                                 f"got {getattr(self, name)!r}")
        for name, low in (("needed_hidden_units", 1), ("reference_points", 0)):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or value < low):
                raise ValueError(f"{name} must be >= {low}, got {value!r}")
        interval = self.analysis_interval
        if isinstance(interval, str):
            if interval not in ("auto", "native"):
                raise ValueError(f"analysis_interval must be a number of seconds, 'auto' or "
                                 f"'native', got {interval!r}")
        elif isinstance(interval, bool) or not (math.isfinite(interval) and interval > 0):
            raise ValueError(f"analysis_interval must be > 0 seconds, got {interval!r}")
        for name in ("ar_span", "delay_span", "derivative_span"):
            value = getattr(self, name)
            if isinstance(value, bool) or not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
        if self.calibration_splits < 1:
            raise ValueError(f"calibration_splits must be >= 1, got {self.calibration_splits}")
        count = self.min_samples
        if count != "auto" and (isinstance(count, (bool, str)) or not isinstance(count, int)
                                or count < 1):
            raise ValueError(f"min_samples must be an integer >= 1 or 'auto', got {count!r}")

    @property
    def trains_needed_network(self) -> bool:
        """Whether a needed network's hidden layer is trained (not fixed random features)."""
        return self.needed_network in ("trained", None)

    @property
    def needed_units(self) -> int:
        """Hidden units of a network the residual needs."""
        return (self.needed_hidden_units if self.needed_hidden_units is not None
                and not self.trains_needed_network else self.hidden_units)

    def for_windows(self, shortest_window: int) -> "GrayBoxSettings":
        """These settings with ``min_samples = "auto"`` resolved for a baseline whose shortest
        window holds ``shortest_window`` telemetry samples (operating samples); settings with
        a count are returned as they are.

        ``min(MIN_SAMPLES_TARGET, max(MIN_SAMPLES_FLOOR, shortest_window - STRUCTURE_ROOM))``:
        200 from 250 samples up (nothing changes where a fixed 200 fitted), fewer for a slow
        logger's windows, never fewer than 48 (a window too short for that gets the linear
        tier's error, which names the settings that help).

        Parameters
        ----------
        shortest_window : int

        Returns
        -------
        GrayBoxSettings
        """
        if self.min_samples != "auto":
            return self
        count = min(MIN_SAMPLES_TARGET, max(MIN_SAMPLES_FLOOR, int(shortest_window) - STRUCTURE_ROOM))
        return replace(self, min_samples=count)

    @property
    def min_sample_count(self) -> int:
        """``min_samples`` as a count: itself, or for an unresolved ``"auto"`` the target
        (:data:`MIN_SAMPLES_TARGET`) that :meth:`for_windows` keeps wherever windows hold it."""
        return MIN_SAMPLES_TARGET if self.min_samples == "auto" else self.min_samples

    @property
    def samples_per_window(self) -> int:
        """Analysis samples a window should keep for the tiers and their calibration:
        ``calibration_splits`` pieces of ``min_samples`` (the cap on the analysis interval's
        decimation, :func:`graybox.analysis_rate.choose_analysis_interval`)."""
        return self.calibration_splits * self.min_sample_count

    def samples(self, seconds: float, interval: float, low: int = 1) -> int:
        """``seconds`` as a whole number of samples of ``interval`` seconds, at least ``low``."""
        return max(low, int(round(seconds / interval)))

    def max_ar_order(self, interval: float) -> int:
        """The AR order cap at an analysis interval of ``interval`` seconds."""
        return self.samples(self.ar_span, interval)

    def max_delay(self, interval: float) -> int:
        """The largest embedding delay tried at ``interval`` seconds."""
        return self.samples(self.delay_span, interval)

    @property
    def shortest_period(self) -> float:
        """Seconds an operating period must last to be fitted, in a window of several
        periods: ``ar_span + delay_span + derivative_span`` (shorter ones are left out)."""
        return self.ar_span + self.delay_span + self.derivative_span

    def shortest_period_samples(self, interval: float) -> int:
        """Samples an operating period must hold to be fitted, in a window of several periods:
        :attr:`shortest_period` at ``interval`` seconds, and at a slow rate at least
        :data:`MIN_PERIOD_SAMPLES`."""
        return max(math.ceil(self.shortest_period / interval - 1e-9), MIN_PERIOD_SAMPLES)

    def derivative_window(self, interval: float, polyorder: int = 3) -> int:
        """The odd Savitzky-Golay window covering about ``derivative_span`` at ``interval``."""
        half = int(self.derivative_span / (2 * interval))
        return max(2 * half + 1, polyorder + 2 + (polyorder + 1) % 2)

    def to_dict(self) -> dict:
        """A JSON-ready dict; :meth:`from_dict` gives back equal settings."""
        return record_json.to_dict(self)

    @classmethod
    def from_dict(cls, data: Mapping) -> "GrayBoxSettings":
        """Rebuild from :meth:`to_dict` (through :meth:`migrate`); raises ArtifactError."""
        return record_json.from_dict(cls, data)

    @classmethod
    def migrate(cls, data: Mapping) -> dict:
        """Stored settings in today's fields (applied by :func:`graybox.record_json.from_dict`).

        Settings stored before the method was rate-invariant (with ``max_ar_order`` and
        ``max_delay`` counts) were fitted at the telemetry's own interval: they load with
        ``analysis_interval="native"``; their counts live on in the frozen structure.
        Settings stored before ``needed_network`` existed trained their needed networks with
        ``hidden_units`` units and compared weights (Eq. 28): they load with the three new
        fields None, which means exactly that (:attr:`trains_needed_network`,
        :attr:`needed_units`).
        """
        data = dict(data)
        if "needed_network" not in data:
            for key in ("needed_network", "needed_hidden_units", "reference_points"):
                data.setdefault(key, None)
        if any(key in data for key in LEGACY_KEYS):
            for key in LEGACY_KEYS:
                data.pop(key, None)
            data.setdefault("analysis_interval", "native")
        return data
