"""How raw telemetry is checked and gridded: :class:`GridPolicy`, whose limits are durations.

Limits are physical time, not sample counts, so one policy means the same at 1 s, 10 s or
60 s samples. Durations are given as seconds (a number) or as a string with a unit that
:class:`pandas.Timedelta` reads (``"5s"``, ``"10min"``, ``"2h"``, ``"1h30min"``); they are
stored as float seconds.
"""
from __future__ import annotations

import datetime
import math
from dataclasses import dataclass, replace
from typing import Mapping

import pandas as pd

from graybox.telemetry.layout import NS_PER_SECOND

ALL_CHANNELS = "*"
"""Key of a ``stuck_after`` mapping that sets the limit of every channel not listed."""

_DEFAULT_STUCK_AFTER = 600.0
#: a stuck channel holds one value for ``stuck_after`` and for at least this many samples: a
#: logger slower than a minute takes as many readings as one at a minute does in the default
#: 10 minutes (a 0.1-degree reading every 5 minutes holds for two samples as a matter of
#: course)
MIN_STUCK_SAMPLES = 10
#: a baseline learns how long each channel held one value where nothing explained it
#: (:func:`graybox.telemetry.validation.longest_holds`); its candidates may hold a value this
#: many times as long as the baseline's longest hold ...
HOLD_FACTOR = 2.0
#: ... and at most this long (seconds); a baseline's own windows may hold one that long
HOLD_CAP = 6 * 3600.0


def duration_seconds(value, what: str = "duration") -> float:
    """A duration as float seconds.

    Parameters
    ----------
    value : float, int, str, datetime.timedelta or pandas.Timedelta
        A number is seconds; a string needs a unit (``"5s"``, ``"10min"``, ``"2h"``): a bare
        number in a string is refused, as pandas would read it as nanoseconds.
    what : str, default "duration"
        The name used in the error message.

    Returns
    -------
    float
        Seconds, finite and >= 0.

    Raises
    ------
    ValueError
        If ``value`` is not a duration or is negative or not finite.
    """
    example = "a duration such as '5s', '10min' or '2h', or a number of seconds"
    if isinstance(value, bool):
        raise ValueError(f"{what} must be {example}, got {value!r}")
    if isinstance(value, (int, float)):
        seconds = float(value)
    elif isinstance(value, str):
        if not any(c.isalpha() for c in value):
            raise ValueError(f"{what} {value!r} has no unit: write {example}")
        try:
            delta = pd.Timedelta(value.strip())
        except (ValueError, TypeError):
            raise ValueError(f"{what} must be {example}, got {value!r}") from None
        if delta is pd.NaT:
            raise ValueError(f"{what} must be {example}, got {value!r}")
        seconds = delta.value / NS_PER_SECOND
    elif isinstance(value, datetime.timedelta):  # pandas.Timedelta is one
        seconds = pd.Timedelta(value).value / NS_PER_SECOND
    else:
        raise ValueError(f"{what} must be {example}, got {value!r}")
    if not math.isfinite(seconds) or seconds < 0:
        raise ValueError(f"{what} must be finite and >= 0, got {value!r}")
    return seconds


def format_duration(seconds: float) -> str:
    """A duration as the shortest exact string of one unit: ``"4min"``, ``"1h"``, ``"2.5s"``."""
    for unit, size in (("h", 3600.0), ("min", 60.0)):
        if seconds >= size and (seconds / size).is_integer():
            return f"{int(seconds / size)}{unit}"
    return f"{seconds:g}s"


@dataclass(frozen=True)
class GridPolicy:
    """How raw telemetry is checked and put on a uniform grid; limits are durations.

    Each duration is seconds (a number) or a string with a unit (``"5s"``, ``"10min"``,
    ``"2h"``); every field is stored as float seconds (``stuck_after`` as seconds or a tuple
    of ``(channel, seconds)`` pairs), so the policy is hashable.

    "Sample interval" below is ``dt``, the grid step (``sample_interval``, or the median raw
    step when that is ``None``). Times between rows and the limits are counted in whole
    sample intervals, rounded to the nearest, so timestamp jitter below ``dt / 2`` and an
    inferred ``dt`` slightly off the true one never matter; a limit is exact when it is a
    multiple of ``dt`` (``"4min"`` at 1, 10 or 60 s), else it acts as the nearest multiple.

    Parameters
    ----------
    sample_interval : duration or None, default None
        Grid step. ``None`` infers it as the median step of the raw timestamps.
    max_gap : duration, default "4min"
        The longest time between two consecutive rows that is bridged by linear
        interpolation; rows further apart separate two operating periods (each gridded
        and analysed on its own). A gap of ``k`` intervals has ``k - 1`` missing samples, so
        ``"4min"`` fills up to 3 missing samples at 60 s, 23 at 10 s and 239 at 1 s, and a
        10-minute gap separates two periods at every rate (``"40s"`` is the old
        ``max_fill = 3`` at 10 s). Consecutive samples are always
        accepted, even if ``max_gap`` is shorter than ``dt``.
    stuck_after : duration or mapping of str to duration, default "10min"
        A channel that holds one value (at least two identical consecutive samples) for this
        long is an error (kind ``"stuck_channel"``). A value holds from its first sample to
        the next sample with another value (to the end of the window's last interval if
        none): 60 identical samples at 10 s hold 10 minutes. A logger slower than a minute
        needs :data:`MIN_STUCK_SAMPLES` (10) identical samples as well, as many as 10 minutes
        give at 1-minute samples (at 5-minute samples, 50 minutes). ``0`` disables the check. A
        mapping gives limits per channel (telemetry column); its key ``"*"`` sets the limit
        of channels not listed (default 10 minutes), e.g. ``{"pdisch": "30min"}``. Columns
        passed as ``inputs`` to :func:`validate` are never checked. Not stuck: a run at
        exactly 0 while another sensor moves (a part at rest), and a run whose both ends the
        plant explains (an input that holds through it changes there, or a coarse reading
        moves there by its resolution), and a reading on a grid whose noise is about its
        resolution repeating where the process stands still (docs/configuration.md,
        "Channel roles"); rows a logger held are dropped before the check
        (:mod:`graybox.telemetry.holds`).
    min_duration : duration, default "1h"
        A window covering less time (grid points times ``dt``) is an error (kind
        ``"too_few_samples"``). A duration, not a count, so that it asks for the same
        coverage at every rate (500 samples would be 8 minutes at 1 s and more than 8 hours
        at 60 s); whether the samples are enough for the fits is the estimator's check
        (``GrayBoxSettings.min_samples``).
    ranges : mapping of str to (low, high), optional
        Plausible values per channel (telemetry column), e.g. ``{"shaft_speed": [0, 2000]}``:
        a finite value outside ``[low, high]`` is an error (kind ``"out_of_range"``).
    plausible_spread : float, default 1000
        Channels without ``ranges``: a value farther from the channel's median in the window
        than ``plausible_spread`` times its 1st-to-99th percentile span (or, when that span
        is 0, times the median's magnitude) is an error (kind ``"out_of_range"``). The span
        of 98 % of the samples is the channel's own scale, unaffected by a few wild samples;
        a thousand times it is far beyond any physical excursion of a monitored process, but
        a corrupt sample (1e10) would dominate every least-squares fit. ``0`` disables it.
    intermittent : bool, default False
        The asset runs in operating periods (a few hours a day, say): a time between rows
        longer than ``max_gap`` is its pause, not a logger's outage (for every asset such a
        time ends one operating period and starts the next: each period is gridded on its
        own, a value held across it does not count as stuck, ``min_duration`` counts the
        operating time, and the fits never let a residual, difference or delay span it,
        :meth:`TelemetryWindow.periods`). ``True``: the flows do not say that its windows
        were read in parts, as they do for a continuous asset's outages.
    running : mapping of str to (low, high), optional
        When the machine runs, for assets that write rows while stopped, e.g.
        ``{"speed": [50, 5000]}``: rows with a listed channel outside its ``[low, high]`` are
        the machine off and are dropped before the other checks (their values are not data;
        a sensor frozen while stopped is not stuck), so they become pauses: ``running``
        implies ``intermittent``. A listed channel need not be a model variable (it is read as
        well); a non-finite value in it is an error (kind ``"non_finite"``).

    Raises
    ------
    ValueError
        If a field is not a duration, or ``sample_interval`` or ``min_duration`` is 0.
    """

    sample_interval: float | None = None
    max_gap: float = 240.0
    stuck_after: float | tuple[tuple[str, float], ...] = _DEFAULT_STUCK_AFTER
    min_duration: float = 3600.0
    ranges: tuple[tuple[str, float, float], ...] = ()
    plausible_spread: float = 1000.0
    intermittent: bool = False
    running: tuple[tuple[str, float, float], ...] = ()

    def __post_init__(self):
        if not isinstance(self.intermittent, bool):
            raise ValueError(f"intermittent must be true or false, got {self.intermittent!r}")
        object.__setattr__(self, "running", _ranges(self.running, "running"))
        if self.running:  # the rows of a stopped machine are pauses between periods
            object.__setattr__(self, "intermittent", True)
        if self.sample_interval is not None:
            interval = duration_seconds(self.sample_interval, "sample_interval")
            if interval <= 0:
                raise ValueError(f"sample_interval must be a positive duration or None, "
                                 f"got {self.sample_interval!r}")
            object.__setattr__(self, "sample_interval", interval)
        object.__setattr__(self, "max_gap", duration_seconds(self.max_gap, "max_gap"))
        minimum = duration_seconds(self.min_duration, "min_duration")
        if minimum <= 0:
            raise ValueError(f"min_duration must be a positive duration, got {self.min_duration!r}")
        object.__setattr__(self, "min_duration", minimum)
        object.__setattr__(self, "stuck_after", _stuck_limits(self.stuck_after))
        object.__setattr__(self, "ranges", _ranges(self.ranges))
        spread = self.plausible_spread
        if isinstance(spread, bool) or not isinstance(spread, (int, float)) or \
                not math.isfinite(spread) or spread < 0:
            raise ValueError(f"plausible_spread must be a number >= 0 (0: off), got {spread!r}")
        object.__setattr__(self, "plausible_spread", float(spread))

    def value_range(self, channel: str) -> tuple[float, float] | None:
        """The configured ``(low, high)`` of a channel, or None."""
        for name, low, high in self.ranges:
            if name == channel:
                return low, high
        return None

    def stuck_limit(self, channel: str) -> float:
        """The ``stuck_after`` limit of one channel in seconds (0: not checked)."""
        if not isinstance(self.stuck_after, tuple):
            return self.stuck_after
        limits = dict(self.stuck_after)
        return limits.get(channel, limits[ALL_CHANNELS])

    def for_baseline(self) -> "GridPolicy":
        """The limits a new baseline's windows are checked with (``read_window(...,
        holds=True)``): a checked channel may hold one value up to :data:`HOLD_CAP` (a
        coarse reading of a steady plant holds for longer than ``stuck_after`` and is not bad
        telemetry); the baseline records how long each held (``Signature.holds``) and its
        candidates are read :meth:`with_holds`.

        Returns
        -------
        GridPolicy
        """
        limits = {channel: limit and max(limit, HOLD_CAP)
                  for channel, limit in self._limits().items()}
        return replace(self, stuck_after=limits)

    def with_holds(self, holds: Mapping[str, float] | None) -> "GridPolicy":
        """The policy a baseline's candidates are read with: a channel the baseline saw hold
        one value for ``holds[channel]`` seconds, with nothing in the plant to explain it (a
        1-kPa tyre pressure on the highway), may hold :data:`HOLD_FACTOR` times as long, up to
        :data:`HOLD_CAP`, before it reads as stuck; never less than its ``stuck_after``.

        Parameters
        ----------
        holds : mapping of str to float or None
            Channel -> longest hold in seconds (``Signature.holds``); None or empty: this
            policy.

        Returns
        -------
        GridPolicy
        """
        limits = self._limits()
        learned = {channel: max(self.stuck_limit(channel), min(HOLD_FACTOR * held, HOLD_CAP))
                   for channel, held in (holds or {}).items() if self.stuck_limit(channel)}
        if all(limit == self.stuck_limit(channel) for channel, limit in learned.items()):
            return self
        return replace(self, stuck_after={**limits, **learned})

    def _limits(self) -> dict[str, float]:
        """``stuck_after`` as a mapping with its ``"*"`` key."""
        if isinstance(self.stuck_after, tuple):
            return dict(self.stuck_after)
        return {ALL_CHANNELS: self.stuck_after}


def _stuck_limits(value) -> float | tuple[tuple[str, float], ...]:
    """A duration, or a mapping (or its stored tuple of pairs) as sorted pairs with ``"*"``."""
    if isinstance(value, tuple) and all(isinstance(p, tuple) and len(p) == 2 for p in value):
        value = dict(value)
    if not isinstance(value, Mapping):
        return duration_seconds(value, "stuck_after")
    limits = {ALL_CHANNELS: _DEFAULT_STUCK_AFTER}
    for channel, limit in value.items():
        if not isinstance(channel, str) or not channel:
            raise ValueError(f"stuck_after keys must be channel names or '*', got {channel!r}")
        limits[channel] = duration_seconds(limit, f"stuck_after[{channel!r}]")
    return tuple(sorted(limits.items()))


def _ranges(value, what: str = "ranges") -> tuple[tuple[str, float, float], ...]:
    """A mapping channel -> (low, high) (or its stored tuple of triples) as sorted triples."""
    if isinstance(value, tuple) and all(isinstance(t, tuple) and len(t) == 3 for t in value):
        value = {name: (low, high) for name, low, high in value}
    if not isinstance(value, Mapping):
        raise ValueError(f"{what} must map channel names to [low, high], got {value!r}")
    out = []
    for channel, bounds in value.items():
        if not isinstance(channel, str) or not channel:
            raise ValueError(f"{what} keys must be channel names, got {channel!r}")
        try:
            low, high = (float(b) for b in bounds)
        except (TypeError, ValueError):
            raise ValueError(f"{what}[{channel!r}] must be [low, high], got {bounds!r}") from None
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise ValueError(f"{what}[{channel!r}] must be finite with low < high, got "
                             f"{bounds!r}")
        out.append((channel, low, high))
    return tuple(sorted(out))
