"""The JSON-lines alert file: :class:`graybox.alert.Alert` records, one object per line.

An alert (:class:`graybox.alert.Alert`, made from a drift by
:func:`graybox.alert.alerts_from_drift`) carries zeta, epsilon, their ratio, a severity from
the ratio, the window, and the parameters that moved most (the root-cause hint). Alerts are
stored twice, as the same records:

* in the registry, the system of record (the candidate's MLflow run: the
  ``fleet_health.alarm`` tag, zeta/epsilon/ratio metrics for the MLflow UI, and
  ``drift.json``, from which :meth:`registry.Registry.alerts` makes the records again); the
  batches write only there, so workers on many hosts need nothing but the tracking store;
* in a JSON-lines file (``[alerts] jsonl``), one object per line, for scripts and the
  ``fleet-health alerts`` command: an export of the registry's alerts
  (:func:`export_alerts`), written by the nightly flow's own process after its batches, and
  rebuilt at any time by ``fleet-health alerts --export``.

The JSON-lines file is append-only and idempotent: a line's key is
``(asset_id, window_start, window_end, channel, tier)``, appends happen under an exclusive
file lock, and a key already in the file is not written again, so a rerun of the same window
(after an interruption, or by two overlapping runs) adds no duplicate.
"""
from __future__ import annotations

import contextlib
import json
import os
import pathlib
from typing import Iterable, Iterator

from graybox.timestamps import utc
from graybox.alert import Alert
from graybox.severity import SeverityScale
from registry import file_lock

#: seconds an append waits for the alerts file's lock before the run fails (never hangs)
LOCK_TIMEOUT = 120.0

__all__ = ["AlertLog", "export_alerts"]


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
    def _locked(self, timeout: float = LOCK_TIMEOUT) -> Iterator[None]:
        # a stuck holder fails this run after ``timeout`` seconds instead of hanging it
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with file_lock(self.path.with_name(self.path.name + ".lock"), timeout=timeout,
                       what=f"the alerts file {self.path}"):
            yield

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
            limit = utc(since)
            records = [a for a in records if utc(a.window_end) >= limit]
        if assets is not None:
            wanted = set(assets)
            records = [a for a in records if a.asset_id in wanted]
        if windows is not None:
            wanted_windows = {(a, utc(s), utc(e)) for a, s, e in windows}
            records = [a for a in records
                       if (a.asset_id, utc(a.window_start), utc(a.window_end)) in wanted_windows]
        records.sort(key=lambda a: (utc(a.window_end), a.asset_id, -a.ratio))
        return records


def export_alerts(registry, log: AlertLog, since=None, scale: SeverityScale = SeverityScale()
                  ) -> tuple[list[Alert], list[Alert]]:
    """Append the registry's nightly alerts to the JSON-lines file (those not in it yet).

    Parameters
    ----------
    registry : registry.Registry
    log : AlertLog
    since : timestamp-like, optional
        Only windows ending at or after this instant (default: every alert recorded).
    scale : SeverityScale, optional
        Grades the alerts' severity (``[alerts]`` of fleet.toml; default 2 and 5).

    Returns
    -------
    (list of Alert, list of Alert)
        The registry's alerts since ``since``, and those of them newly written.
    """
    recorded = registry.alerts(since=since, scale=scale)
    return recorded, log.append(recorded)



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
