"""Alerts: one record per asset, window, channel and tier whose zeta exceeded epsilon.

An alert carries zeta, epsilon, their ratio, a severity from the ratio, the window, and the
parameters that moved most (the root-cause hint: :class:`graybox.drift.ParameterChange`
entries). Alerts are stored twice:

* in the registry (the candidate's MLflow run: the ``fleet_health.alarm`` tag, zeta/epsilon/
  ratio metrics and ``drift.json``), which :meth:`registry.Registry.alerts` reads back;
* in a JSON-lines file (``[alerts] jsonl``), one object per line, for scripts and the
  ``fleet-health alerts`` command.

The JSON-lines file is append-only and idempotent: a line's key is
``(asset_id, window_start, window_end, channel, tier)``, appends happen under an exclusive
file lock, and a key already in the file is not written again, so a rerun of the same window
(after an interruption, or by two overlapping runs) adds no duplicate.
"""
from __future__ import annotations

import contextlib
import fcntl
import json
import os
import pathlib
from dataclasses import asdict, dataclass, field
from typing import Iterable, Iterator

import pandas as pd

SEVERITIES = ("minor", "major", "critical")


def severity(ratio: float | None, major_ratio: float = 2.0, critical_ratio: float = 5.0) -> str:
    """``minor`` for 1 < zeta/epsilon < major_ratio, ``major`` up to critical_ratio, else
    ``critical``."""
    if ratio is None:
        return "minor"
    if ratio >= critical_ratio:
        return "critical"
    if ratio >= major_ratio:
        return "major"
    return "minor"


@dataclass(frozen=True)
class Alert:
    """One exceeded threshold: asset, window, channel and tier.

    Attributes
    ----------
    asset_id, vehicle_class : str
    window_start, window_end : str
        ISO UTC bounds of the candidate's telemetry window (end exclusive).
    channel, tier : str
    zeta, epsilon, ratio : float
    severity : str
        ``minor``, ``major`` or ``critical`` (from ``ratio``).
    top_changes : list of dict
        The parameters that moved most: ``name``, ``baseline``, ``candidate`` and
        ``contribution`` (its share of zeta).
    version : int or None
        The candidate's registered model version (None for a reanalysis).
    baseline_version : int or None
    run_id : str or None
        The candidate's MLflow run.
    source : str
        ``nightly`` or ``reanalysis``.
    """

    asset_id: str
    vehicle_class: str
    window_start: str
    window_end: str
    channel: str
    tier: str
    zeta: float
    epsilon: float
    ratio: float
    severity: str
    top_changes: list = field(default_factory=list)
    version: int | None = None
    baseline_version: int | None = None
    run_id: str | None = None
    source: str = "nightly"

    @property
    def key(self) -> tuple[str, str, str, str, str]:
        return (self.asset_id, self.window_start, self.window_end, self.channel, self.tier)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "Alert":
        known = {f for f in cls.__dataclass_fields__}
        return cls(**{k: v for k, v in data.items() if k in known})

    def hint(self, count: int = 3) -> str:
        """The moved parameters, e.g. ``a1 0.91→1.12, W1_3 ...``."""
        return ", ".join(f"{c['name']} {c['baseline']:.3g}→{c['candidate']:.3g}"
                         for c in self.top_changes[:count])


def alerts_from_drift(drift, *, asset_id: str, vehicle_class: str, window_start: str,
                      window_end: str, version: int | None, baseline_version: int | None,
                      run_id: str | None, major_ratio: float = 2.0,
                      critical_ratio: float = 5.0, source: str = "nightly") -> list[Alert]:
    """The alerts of a :class:`graybox.drift.Drift`: one per entry whose zeta exceeds epsilon,
    largest ratio first."""
    out = []
    for entry in drift.alarms:
        ratio = entry.ratio
        out.append(Alert(
            asset_id=asset_id, vehicle_class=vehicle_class, window_start=window_start,
            window_end=window_end, channel=entry.channel, tier=entry.tier,
            zeta=float(entry.zeta), epsilon=float(entry.epsilon),
            ratio=float(ratio) if ratio is not None else float("nan"),
            severity=severity(ratio, major_ratio, critical_ratio),
            top_changes=[{"name": c.name, "baseline": c.baseline, "candidate": c.candidate,
                          "contribution": c.contribution} for c in entry.top_changes],
            version=version, baseline_version=baseline_version, run_id=run_id, source=source))
    out.sort(key=lambda a: -a.ratio)
    return out


class AlertLog:
    """The JSON-lines alert file: idempotent appends under a lock, reads with filters.

    Parameters
    ----------
    path : path-like
        The ``.jsonl`` file (its directory is created on the first append). A lock file
        ``<path>.lock`` sits beside it.
    """

    def __init__(self, path: str | os.PathLike):
        self.path = pathlib.Path(path)

    @contextlib.contextmanager
    def _locked(self) -> Iterator[None]:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path.with_name(self.path.name + ".lock"), "a+") as handle:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.flock(handle.fileno(), fcntl.LOCK_UN)

    def _read_lines(self) -> list[dict]:
        if not self.path.exists():
            return []
        records = []
        with open(self.path, encoding="utf-8") as handle:
            for number, line in enumerate(handle, 1):
                line = line.strip()
                if not line:
                    continue
                try:
                    records.append(json.loads(line))
                except json.JSONDecodeError:
                    # a torn last line (a crash mid-write) is skipped, never fatal
                    continue
        return records

    def append(self, alerts: Iterable[Alert]) -> list[Alert]:
        """Append the alerts whose key is not in the file yet; returns those written."""
        alerts = list(alerts)
        if not alerts:
            return []
        with self._locked():
            seen = {_key(r) for r in self._read_lines()}
            new = []
            for alert in alerts:
                if alert.key in seen:
                    continue
                seen.add(alert.key)
                new.append(alert)
            if new:
                self._ensure_newline()
                with open(self.path, "a", encoding="utf-8") as handle:
                    for alert in new:
                        handle.write(json.dumps(alert.to_dict(),
                                                default=_json_default) + "\n")
                    handle.flush()
                    os.fsync(handle.fileno())
            return new

    def _ensure_newline(self) -> None:
        """After a torn write, start the next line on a line of its own."""
        if not self.path.exists() or self.path.stat().st_size == 0:
            return
        with open(self.path, "rb+") as handle:
            handle.seek(-1, os.SEEK_END)
            if handle.read(1) != b"\n":
                handle.write(b"\n")

    def read(self, since=None, assets: Iterable[str] | None = None,
             windows: Iterable[tuple[str, str, str]] | None = None) -> list[Alert]:
        """Alerts in the file, oldest window first.

        Parameters
        ----------
        since : timestamp-like, optional
            Only windows ending at or after this instant (naive is UTC).
        assets : iterable of str, optional
        windows : iterable of (asset_id, window_start, window_end), optional
            Only these windows.
        """
        records = [Alert.from_dict(r) for r in self._read_lines() if _valid(r)]
        if since is not None:
            limit = _utc(since)
            records = [a for a in records if _utc(a.window_end) >= limit]
        if assets is not None:
            wanted = set(assets)
            records = [a for a in records if a.asset_id in wanted]
        if windows is not None:
            wanted_windows = {(a, _utc(s), _utc(e)) for a, s, e in windows}
            records = [a for a in records
                       if (a.asset_id, _utc(a.window_start), _utc(a.window_end)) in wanted_windows]
        records.sort(key=lambda a: (_utc(a.window_end), a.asset_id, -a.ratio))
        return records


def _utc(value) -> pd.Timestamp:
    stamp = pd.Timestamp(value)
    return stamp.tz_localize("UTC") if stamp.tzinfo is None else stamp.tz_convert("UTC")


def _valid(record: dict) -> bool:
    return all(k in record for k in ("asset_id", "window_start", "window_end", "channel", "tier",
                                     "zeta", "epsilon", "ratio", "severity", "vehicle_class"))


def _key(record: dict) -> tuple:
    return (record.get("asset_id"), record.get("window_start"), record.get("window_end"),
            record.get("channel"), record.get("tier"))


def _json_default(value):
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"not JSON serializable: {type(value).__name__}")
