"""Alert: one record per asset, window, channel and tier whose zeta exceeded epsilon.

The one alert type of fleet-health, and its one home: the step after the drift
(telemetry -> residual -> signature -> drift -> alert), as pure as the drift it comes from.
Grading (:class:`graybox.severity.SeverityScale`, a small record of its own) and alert
making (:func:`alerts_from_drift`, the only place an alert is made from a drift;
:func:`stale_alert`; :func:`dormant_alert`; :func:`sensor_alert`, a candidate night whose
sensor the telemetry checks found stuck or out of range) are here; the pipeline makes
alerts from a fresh
:class:`graybox.drift.Drift`, :meth:`registry.Registry.alerts` makes the same records again
from the drift it stored, and the JSON-lines file (:class:`flows.alerts.AlertLog`) writes
and reads them. An alert becomes a dict only at the edges: :meth:`Alert.to_dict` /
:meth:`Alert.from_dict` for JSON lines, run summaries, Prefect artifacts and ``--json``
output.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import TYPE_CHECKING, Any, Mapping, Sequence

from graybox.alert_diagnosis import cause_text
from graybox.severity import SeverityScale
from graybox.tiers import Tier, tier_kind

if TYPE_CHECKING:  # pragma: no cover
    from graybox.drift import Drift
    from graybox.exceptions import TelemetryError

NIGHTLY, REANALYSIS = "nightly", "reanalysis"
SOURCES = (NIGHTLY, REANALYSIS)
DRIFT, STALE, SENSOR, DORMANT = "drift", "stale", "sensor", "dormant"
#: a drift over its threshold; an asset whose telemetry stopped; a sensor found stuck, out
#: of range or silent by the telemetry checks; an asset that has not operated for too long
KINDS = (DRIFT, STALE, SENSOR, DORMANT)
#: the telemetry checks' findings that are a sensor's fault (:class:`TelemetryError` kinds)
SENSOR_FAULTS = ("stuck_channel", "out_of_range", "silent_channel")


@dataclass(frozen=True)
class Alert:
    """One exceeded threshold: asset, window, channel and tier.

    Attributes
    ----------
    asset_id, vehicle_class : str
    window_start, window_end : str
        ISO UTC bounds of the candidate's telemetry window (end exclusive), as recorded.
    channel, tier : str
    zeta, epsilon, ratio : float
    severity : str
        ``minor``, ``major`` or ``critical`` (``ratio`` graded by a
        :class:`~graybox.severity.SeverityScale`).
    top_changes : tuple of dict
        The parameters that moved most, largest first: ``name``, ``baseline``,
        ``candidate`` and ``contribution`` (its share of zeta). A list given is kept as a
        tuple.
    version : int or None
        The candidate's registered model version (None for a reanalysis).
    baseline_version : int or None
        The baseline version the candidate was compared with.
    run_id : str or None
        The candidate's MLflow run.
    source : str
        ``nightly`` or ``reanalysis``.
    kind : str
        ``drift`` (the fields above), or ``stale``: the asset's telemetry stopped arriving
        (:func:`stale_alert`: ``window_start`` and ``window_end`` are both the time of its
        newest sample, ``zeta`` its age and ``epsilon`` the ``stale_after`` limit, in days),
        or ``sensor``: a channel of the night read stuck or out of range
        (:func:`sensor_alert`: ``tier`` is the finding, ``zeta`` and ``epsilon`` how far it
        went and may go), or ``dormant``: the asset has not operated for longer than
        ``not_operating_after`` (:func:`dormant_alert`: ``window_start`` and ``window_end``
        are both the end of its last monitored night, ``zeta`` the days since and
        ``epsilon`` the limit).
    diagnosis : tuple of dict
        The physical diagnosis of the alert's window (the same for every alert of the
        window), ranked: ``hypothesis``, ``kind``, ``target``, ``baseline``, ``estimate``,
        ``interval`` (``[low, high]``) and ``score``. ``diagnosis[0]`` is the likely cause; or
        the marker ``kind`` ``"none"`` (``hypothesis`` "no single cause explains it", the
        ranking after it kept for inspection) or ``"failed"`` (``hypothesis`` "diagnosis
        failed: <reason>"). ``()``: not diagnosed (a stale alert, or recorded before
        diagnoses). See :mod:`graybox.alert_diagnosis`. A list given is kept as a tuple.
    conditions : str or None
        For a window driven beyond every baseline day's input conditions, the input figure
        farthest outside with the baseline days' range (``Drift.conditions``, e.g.
        ``demand_flow mean 4.42 (baseline days 2.91 to 3.62)``): the tiers' changes were
        discounted for it, and a longer or more varied baseline would cover it. None inside.
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
    top_changes: tuple[dict, ...] = ()
    version: int | None = None
    baseline_version: int | None = None
    run_id: str | None = None
    source: str = NIGHTLY
    kind: str = DRIFT
    diagnosis: tuple[dict, ...] = ()
    conditions: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "top_changes", tuple(dict(c) for c in self.top_changes))
        object.__setattr__(self, "diagnosis", tuple(dict(h) for h in self.diagnosis))

    @property
    def key(self) -> tuple[str, str, str, str, str]:
        """``(asset_id, window_start, window_end, channel, tier)``: one alert per key."""
        return (self.asset_id, self.window_start, self.window_end, self.channel, self.tier)

    def hint(self, count: int = 3) -> str:
        """The tier's hint (:meth:`graybox.tiers.base.Tier.hint`): the moved parameters, e.g.
        ``a1 0.91→1.12, W1_3 ...`` (and, for a window driven beyond the baseline's input
        conditions, which input left them); for the level tier ``level moved from 129.02 to
        129.49 (+0.47)``; for a stale or sensor alert, what was found."""
        if self.kind == STALE:
            return f"no telemetry since {self.window_end} ({self.zeta:.1f} days)"
        if self.kind == DORMANT:
            return (f"not operating since {self.window_end} ({self.zeta:.1f} days; "
                    f"not_operating_after {self.epsilon:.1f} days)")
        if self.kind == SENSOR:
            if self.tier == "stuck_channel":
                return (f"sensor {self.channel} stuck for {self.zeta:.0f} s "
                        f"(stuck_after {self.epsilon:.0f} s)")
            if self.tier == "silent_channel":
                return (f"sensor {self.channel} gave no reading for {self.zeta:.0f} s "
                        f"(max_gap {self.epsilon:.0f} s)")
            return (f"sensor {self.channel} out of range: {self.zeta:.6g} from its centre, "
                    f"{self.epsilon:.6g} allowed")
        try:
            kind = tier_kind(self.tier)
        except ValueError:     # a tier added through ``kinds=``: the generic hint
            kind = Tier()
        return kind.hint(self.top_changes, self.conditions, count)

    def likely_cause(self) -> str:
        """The diagnosis' first entry in a line (see
        :func:`graybox.alert_diagnosis.cause_text`), ``""`` when not diagnosed; for a
        ``sensor`` alert, the sensor's fault (``omega sensor stuck``)."""
        if self.kind == SENSOR:
            fault = {"stuck_channel": "stuck", "silent_channel": "silent"}.get(
                self.tier, "out of range")
            return f"{self.channel} sensor {fault}"
        return cause_text(self.diagnosis[0] if self.diagnosis else None)

    def to_dict(self) -> dict[str, Any]:
        """The alert as plain JSON types (``top_changes`` and ``diagnosis`` lists of dicts)."""
        data = asdict(self)
        data["top_changes"] = [dict(c) for c in self.top_changes]
        data["diagnosis"] = [dict(h) for h in self.diagnosis]
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "Alert":
        """The alert of :meth:`to_dict` (or its JSON); unknown keys are ignored.

        Raises
        ------
        TypeError
            If a field without a default is missing.
        """
        known = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in data.items() if k in known})


def alerts_from_drift(drift: "Drift", *, asset_id: str, vehicle_class: str, window_start: str,
                      window_end: str, version: int | None, baseline_version: int | None,
                      run_id: str | None, scale: SeverityScale = SeverityScale(),
                      source: str = NIGHTLY, diagnosis: Sequence[dict] = ()) -> list[Alert]:
    """The alerts of a drift: one per entry whose zeta exceeds epsilon, largest ratio first.

    Parameters
    ----------
    drift : graybox.drift.Drift
    asset_id, vehicle_class, window_start, window_end : str
        The candidate's asset and recorded window.
    version, baseline_version : int or None
    run_id : str or None
    scale : SeverityScale, optional
        Grades each alert's ratio (``[alerts]`` of fleet.toml; default 2 and 5).
    source : str
        ``nightly`` or ``reanalysis``.
    diagnosis : sequence of dict, optional
        The window's diagnosis (:func:`graybox.alert_diagnosis.alert_entries`), given to
        each alert.

    Returns
    -------
    list of Alert
    """
    if source not in SOURCES:
        raise ValueError(f"alert source must be one of {SOURCES}, not {source!r}")
    out = []
    for entry in drift.alarms:
        ratio = entry.ratio
        out.append(Alert(
            asset_id=asset_id, vehicle_class=vehicle_class, window_start=window_start,
            window_end=window_end, channel=entry.channel, tier=entry.tier,
            zeta=float(entry.zeta), epsilon=float(entry.epsilon),
            ratio=float(ratio) if ratio is not None else float("nan"),
            severity=scale.grade(ratio),
            top_changes=tuple(asdict(c) for c in entry.top_changes),
            version=version, baseline_version=baseline_version, run_id=run_id, source=source,
            diagnosis=tuple(diagnosis), conditions=drift.conditions))
    out.sort(key=lambda a: -a.ratio)
    return out


def stale_alert(*, asset_id: str, vehicle_class: str, last_data: str, age_days: float,
                stale_after_days: float) -> Alert:
    """The alert of an asset whose newest telemetry is older than ``stale_after``.

    One per (asset, newest sample): its key's window is ``[last_data, last_data]`` and its
    channel and tier ``"*"`` and ``"stale"``, so later runs with no new data add no duplicate.

    Parameters
    ----------
    asset_id, vehicle_class : str
    last_data : str
        ISO UTC time of the asset's newest sample.
    age_days, stale_after_days : float
        How old that sample is at the run's as-of time, and the limit, in days.
    """
    ratio = age_days / stale_after_days
    return Alert(asset_id=asset_id, vehicle_class=vehicle_class, window_start=last_data,
                 window_end=last_data, channel="*", tier=STALE, zeta=float(age_days),
                 epsilon=float(stale_after_days), ratio=float(ratio), severity="major",
                 source=NIGHTLY, kind=STALE)


def dormant_alert(*, asset_id: str, vehicle_class: str, last_operated: str, age_days: float,
                  limit_days: float) -> Alert:
    """The alert of an asset that has not operated for longer than ``not_operating_after``
    (it has telemetry, but every new night ran too little to monitor).

    One per (asset, last operated night): its key's window is ``[last_operated,
    last_operated]`` and its channel and tier ``"*"`` and ``"dormant"``, so later runs while
    it stays parked add no duplicate.

    Parameters
    ----------
    asset_id, vehicle_class : str
    last_operated : str
        ISO UTC end of the asset's last monitored night (or of its baseline's window).
    age_days, limit_days : float
        How long ago that is at the run's as-of time, and the limit, in days.
    """
    return Alert(asset_id=asset_id, vehicle_class=vehicle_class, window_start=last_operated,
                 window_end=last_operated, channel="*", tier=DORMANT, zeta=float(age_days),
                 epsilon=float(limit_days), ratio=float(age_days / limit_days),
                 severity="major", source=NIGHTLY, kind=DORMANT)


def sensor_alert(error: "TelemetryError", *, vehicle_class: str, window_start: str,
                 window_end: str, scale: SeverityScale = SeverityScale(),
                 source: str = NIGHTLY) -> Alert | None:
    """The alert of a candidate night whose telemetry check found a sensor's fault.

    A stuck sensor or an impossible reading fails the night's fit (bad telemetry is never
    fitted); it is also what a diagnostics engineer wants in the alert feed, named by channel.
    One per (asset, night, channel, finding), so later runs of the same night add no
    duplicate.

    Parameters
    ----------
    error : graybox.exceptions.TelemetryError
    vehicle_class, window_start, window_end : str
        The asset's class and the night's window (ISO UTC).
    scale : SeverityScale, optional
        Grades how far the sensor went past its limit.
    source : str
        ``nightly`` or ``reanalysis``.

    Returns
    -------
    Alert or None
        None when the finding is not a sensor's fault (:data:`SENSOR_FAULTS`: a gap, a
        schema error, ... are the data's).
    """
    if error.kind not in SENSOR_FAULTS or error.channel is None or error.excess is None:
        return None
    went, allowed = error.excess
    ratio = went / allowed if allowed > 0 else float("inf")
    return Alert(asset_id=error.asset_id, vehicle_class=vehicle_class,
                 window_start=window_start, window_end=window_end, channel=error.channel,
                 tier=error.kind, zeta=float(went), epsilon=float(allowed), ratio=float(ratio),
                 severity=scale.grade(ratio), source=source, kind=SENSOR)
