"""A window of one asset's telemetry on a uniform time grid (what the gray-box fits take)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd


@dataclass(frozen=True, eq=False, repr=False)
class TelemetryWindow:
    """A window of one asset's telemetry on a uniform time grid.

    Equality is identity (the frame is a DataFrame); compare ``frame`` explicitly. The repr
    is a one-line summary.

    Parameters
    ----------
    asset_id : str
        The asset.
    frame : pandas.DataFrame
        One float64 column per channel, indexed by a ``DatetimeIndex`` named ``"timestamp"``
        (tz UTC) on a uniform grid of step ``sample_interval``.
    sample_interval : float
        Grid step in seconds.
    filled_samples : int
        Grid points created by interpolation across short gaps (no raw sample within half a
        step). Points interpolated between jittered raw samples are not counted.
    files : tuple of str
        The files whose rows make up the window, in read order.
    unread : tuple of (str, int)
        Per channel, the rows left out because its readings were missing: for longer than
        ``GridPolicy.max_gap`` (a sensor's dropout), or at all in a ``running`` channel
        (``Rows.unread``); empty: none.
    resent : int
        Rows left out because a logger sent them twice (the same timestamp and readings as a
        row before them, ``Rows.resent``); 0: none.
    holds : tuple of (str, float)
        Per channel, the longest time (seconds) it held one value that the plant did not
        explain, where long enough to widen the channel's ``stuck_after``
        (:func:`graybox.telemetry.validation.longest_holds`); read only when asked
        (``read_window(..., holds=True)``, a baseline's windows); empty: none found or not
        read.

    Notes
    -----
    A window with pauses or outages (times between rows longer than ``GridPolicy.max_gap``)
    holds its operating periods one after another, each on its own uniform grid;
    :meth:`periods` gives them apart. A window without any is one period.
    """

    asset_id: str
    frame: pd.DataFrame
    sample_interval: float
    filled_samples: int
    files: tuple[str, ...]
    unread: tuple[tuple[str, int], ...] = ()
    resent: int = 0
    holds: tuple[tuple[str, float], ...] = ()
    # per grid point: True where it was filled across a gap (lets split apportion the count)
    _filled_mask: np.ndarray | None = field(repr=False, compare=False, default=None)
    # per grid point: indexes into files of the raw samples bracketing it (lets split name
    # the files each sub-window was made from)
    _file_span: np.ndarray | None = field(repr=False, compare=False, default=None)
    # first grid point of each operating period (None: one period, the whole frame)
    _period_starts: np.ndarray | None = field(repr=False, compare=False, default=None)

    def __post_init__(self):
        index = self.frame.index
        if not isinstance(index, pd.DatetimeIndex) or str(index.tz) != "UTC":
            raise ValueError("TelemetryWindow.frame needs a DatetimeIndex with tz UTC")
        if len(index) == 0:
            raise ValueError("TelemetryWindow.frame is empty")
        n = len(index)
        if self._filled_mask is None and self.filled_samples == 0:
            object.__setattr__(self, "_filled_mask", np.zeros(n, dtype=bool))
        if self._filled_mask is not None:
            if len(self._filled_mask) != n or int(self._filled_mask.sum()) != self.filled_samples:
                raise ValueError("_filled_mask does not match the frame or filled_samples")
        if self._file_span is not None and self._file_span.shape != (n, 2):
            raise ValueError("_file_span must have shape (n_samples, 2)")
        if self._period_starts is not None:
            starts = np.asarray(self._period_starts, dtype=np.intp)
            if not (len(starts) and starts[0] == 0 and np.all(np.diff(starts) > 0)
                    and starts[-1] < n):
                raise ValueError("_period_starts must be increasing positions from 0")
            object.__setattr__(self, "_period_starts", starts)

    def __repr__(self) -> str:
        return (f"TelemetryWindow(asset_id={self.asset_id!r}, start={self.start.isoformat()!r}, "
                f"end={self.end.isoformat()!r}, n_samples={self.n_samples}, "
                f"channels={list(self.frame.columns)!r}, sample_interval={self.sample_interval:g}, "
                f"filled_samples={self.filled_samples}, files={len(self.files)}"
                + (f", periods={self.n_periods})" if self.n_periods > 1 else ")"))

    @property
    def start(self) -> pd.Timestamp:
        """First grid timestamp (inclusive)."""
        return self.frame.index[0]

    @property
    def end(self) -> pd.Timestamp:
        """Last grid timestamp plus one sample interval (exclusive)."""
        return self.frame.index[-1] + pd.Timedelta(seconds=self.sample_interval)

    @property
    def n_samples(self) -> int:
        """Number of grid points."""
        return len(self.frame)

    @property
    def n_periods(self) -> int:
        """Number of operating periods (1 for continuous telemetry)."""
        return 1 if self._period_starts is None else len(self._period_starts)

    def periods(self) -> list[pd.DataFrame]:
        """The frame of each operating period, in time order, each on a uniform grid.

        Residuals, differences, delays and calibration pieces never span two periods.
        """
        if self._period_starts is None:
            return [self.frame]
        bounds = np.append(self._period_starts, len(self.frame))
        return [self.frame.iloc[a:b] for a, b in zip(bounds[:-1], bounds[1:])]

    def split(self, period: str = "1D", min_samples: int = 1) -> list["TelemetryWindow"]:
        """Cut the window into consecutive sub-windows aligned to ``period`` boundaries.

        Parameters
        ----------
        period : str, default "1D"
            A fixed-length pandas frequency (``"1D"``, ``"6h"``, ...). Boundaries are
            multiples of the period since the Unix epoch, so ``"1D"`` cuts at UTC midnight.
        min_samples : int, default 1
            Sub-windows with fewer grid points are dropped.

        Returns
        -------
        list of TelemetryWindow
            In time order. Each keeps the grid step; ``filled_samples`` counts the filled
            points inside it, ``files`` the files its samples were interpolated from, and
            its operating periods are those of this window inside it.
        """
        if self._filled_mask is None:
            raise ValueError("this window has filled_samples > 0 but no _filled_mask; "
                             "cannot apportion filled samples")
        keys = self.frame.index.floor(period).asi8
        cuts = np.flatnonzero(keys[1:] != keys[:-1]) + 1
        bounds = np.concatenate([[0], cuts, [len(keys)]])
        windows = []
        for a, b in zip(bounds[:-1], bounds[1:]):
            if b - a < min_samples:
                continue
            mask = self._filled_mask[a:b]
            if self._file_span is None:
                files, span = self.files, None
            else:
                span = self._file_span[a:b]
                used = np.unique(span)
                files = tuple(self.files[i] for i in used)
                span = np.searchsorted(used, span)  # re-index into the sub-window's files
            starts = None
            if self._period_starts is not None:
                inside = self._period_starts[(self._period_starts > a) & (self._period_starts < b)]
                starts = np.concatenate([[0], inside - a]) if len(inside) else None
            windows.append(TelemetryWindow(
                asset_id=self.asset_id, frame=self.frame.iloc[a:b].copy(),
                sample_interval=self.sample_interval, filled_samples=int(mask.sum()),
                files=files, holds=self.holds, _filled_mask=mask.copy(), _file_span=span,
                _period_starts=starts))
        return windows


def window_periods(window) -> list[pd.DataFrame]:
    """The operating periods of a window: a TelemetryWindow's, a DataFrame as one, or a
    sequence of DataFrames as given."""
    if hasattr(window, "periods"):
        return window.periods()
    frames = [window] if isinstance(window, pd.DataFrame) else list(window)
    for frame in frames:
        if not isinstance(frame, pd.DataFrame):
            raise TypeError(f"expected a TelemetryWindow, a DataFrame or a sequence of "
                            f"DataFrames, got {type(frame).__name__}")
    return frames
