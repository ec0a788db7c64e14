"""Errors raised by the gray-box core.

Every error a user can cause derives from :class:`GrayBoxError`, so callers (the flows, the
command line) can tell bad input from a bug.
"""
from __future__ import annotations


class GrayBoxError(Exception):
    """Base class of every error the gray-box core raises on bad input or configuration."""


class ModelSpecError(GrayBoxError):
    """A physics-model plugin is badly declared, cannot be loaded, or is badly configured."""


class ModelChangedError(ModelSpecError):
    """A stored record's white box is no longer the one it was fitted with: the class's
    fingerprint (an FMU's GUID) differs from the record's."""


class TelemetryError(GrayBoxError):
    """Telemetry that cannot be used, with where it was found.

    Parameters
    ----------
    asset_id : str
        The asset whose telemetry is bad.
    kind : str
        A short machine-readable reason: ``"schema"``, ``"non_finite"``, ``"out_of_range"``,
        ``"duplicate_timestamp"``, ``"backward_timestamp"``, ``"gap"``, ``"stuck_channel"``,
        ``"silent_channel"``, ``"too_few_samples"``,
        ``"no_data"``, ``"unreadable"`` (not valid Parquet) or ``"io_error"`` (the file system
        failed to deliver the file: worth a retry).
    message : str
        What is wrong, in words.
    file : str or None
        The Parquet file the bad row came from.
    row : int or None
        The 0-based row index inside ``file``.
    channel : str or None
        For a sensor's fault (``"stuck_channel"``, ``"out_of_range"``,
        ``"silent_channel"``): the channel.
    excess : tuple of float or None
        For a sensor's fault: how far it went and how far it may go, ``(seconds held,
        stuck_after)``, ``(distance from the channel's centre, the distance allowed)`` or
        ``(seconds without a reading, max_gap)``.
    """

    def __init__(self, asset_id: str, kind: str, message: str, file: str | None = None,
                 row: int | None = None, channel: str | None = None,
                 excess: tuple[float, float] | None = None):
        self.asset_id = asset_id
        self.kind = kind
        self.message = message
        self.file = file
        self.row = row
        self.channel = channel
        self.excess = excess
        where = f"asset {asset_id!r}"
        if file is not None:
            where += f", file {file}"
        if row is not None:
            where += f", row {row}"
        super().__init__(f"{where}: {message} [{kind}]")

    def __reduce__(self):
        # rebuilt from its fields (the default rebuilds from the message alone and fails):
        # the error travels back from a process computing a night (flows.pooled_execute)
        return type(self), (self.asset_id, self.kind, self.message, self.file, self.row,
                            self.channel, self.excess)


class InsufficientDataError(GrayBoxError):
    """Too little data for the requested fit (for example a window shorter than the model needs)."""


class ConstantSeriesError(InsufficientDataError):
    """A series with nothing to describe: constant, or constant to rounding (a machine that
    stood still)."""


class ShortWindowsError(InsufficientDataError):
    """Windows of one fit too short for it (too little operation in them).

    Parameters
    ----------
    message : str
    windows : tuple of int
        Their positions among the fit's windows: a new baseline leaves them out where enough
        others remain (:func:`graybox.calibration.fit_baselines`).
    """

    def __init__(self, message: str, windows: tuple[int, ...] = ()):
        super().__init__(message)
        self.windows = tuple(int(k) for k in windows)

    def __reduce__(self):
        return type(self), (self.args[0], self.windows)


class StructureMismatchError(GrayBoxError):
    """Two signatures were fitted with different frozen structures and cannot be compared."""


class ArtifactError(GrayBoxError):
    """A stored signature, calibration or weight file is missing, malformed or tampered with."""


class InvalidAssetIdError(GrayBoxError):
    """An asset id that does not match ``[A-Za-z0-9_.-]{1,64}`` (rejected before any path or name use)."""
