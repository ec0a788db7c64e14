"""Tables of a run: rows for the Prefect table artifacts and rich tables for the terminal."""
from __future__ import annotations

import math
from typing import Sequence

import pandas as pd
from rich.markup import escape
from rich.table import Table

from flows.errors import AssetsNotMonitored
from flows.results import DORMANT, FAILED, NOT_OPERATING, UNUSABLE_BASELINE, RunSummary
from graybox.alert import Alert
from graybox.alert_diagnosis import NO_SINGLE_CAUSE


def _when(value: str | None, fmt: str = "%Y-%m-%d %H:%M") -> str:
    return "" if not value else pd.Timestamp(value).strftime(fmt)


def window_label(start: str, end: str) -> str:
    """``2026-01-07`` for a whole UTC day, else ``2026-01-07 06:00 → 12:00``."""
    s, e = pd.Timestamp(start), pd.Timestamp(end)
    if s == s.normalize() and e - s == pd.Timedelta(days=1):
        return s.strftime("%Y-%m-%d")
    if s.normalize() == (e - pd.Timedelta(microseconds=1)).normalize():
        return f"{s:%Y-%m-%d %H:%M} → {e:%H:%M}"
    return f"{s:%Y-%m-%d %H:%M} → {e:%Y-%m-%d %H:%M}"


def _ratio(value) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return "inf" if math.isinf(value) else f"{value:.2f}"


def fleet_rows(summary: RunSummary) -> list[dict]:
    """One row per asset (the fleet table): its largest ratio with the channel and tier it
    is in, and in ``reason``, after a failure's message or its note, the first of its windows
    driven beyond its baseline's conditions (alarmed or not: its changes were discounted)."""
    rows = []
    for a in summary.assets:
        rated = [w for w in a.windows if w.max_ratio is not None]
        top = max(rated, key=lambda w: w.max_ratio) if rated else None
        beyond = next((w for w in a.windows if w.conditions), None)
        reason = a.reason()
        if beyond is not None:
            reason = "; ".join(filter(None, [
                reason, f"{window_label(beyond.window_start, beyond.window_end)} beyond its "
                        f"baseline's conditions: {beyond.conditions}"]))
        rows.append({
            "asset": a.asset_id, "class": a.vehicle_class, "status": a.status,
            "windows": len(a.windows), "alarmed": sum(1 for w in a.windows if w.alarm),
            "max ratio": _ratio(top.max_ratio) if top else "",
            "channel tier": (top.max_ratio_at or "") if top else "",
            "baseline": f"v{a.baseline_version}" if a.baseline_version else "",
            "watermark": _when(a.watermark_after),
            "reason": reason})
    return rows


def alert_rows(alerts: Sequence[Alert]) -> list[dict]:
    """One row per alert (asset, window, tier, channel): the alert table, with the window's
    likely cause (the diagnosis' best hypothesis with its estimate and interval, "no single
    cause", or "diagnosis failed: ..."; empty when not diagnosed)."""
    rows = []
    for alert in sorted(alerts, key=lambda a: (a.window_start, a.asset_id, -(a.ratio or 0))):
        rows.append({"asset": alert.asset_id,
                     "night": window_label(alert.window_start, alert.window_end),
                     "tier": alert.tier, "channel": alert.channel,
                     "zeta/epsilon": _ratio(alert.ratio),
                     "severity": alert.severity, "moved most": alert.hint(),
                     "likely cause": likely_cause(alert)})
    return rows


def likely_cause(alert: Alert) -> str:
    """The run table's short cause: ``parameter inertia 50 -> 33.4 (-33 %; interval 33.1 to
    33.7)``, ``no single cause``, ``diagnosis failed: ...``, or ``""``."""
    text = alert.likely_cause()
    return "no single cause" if text == NO_SINGLE_CAUSE else text


def flow_result(summary: RunSummary, config):
    """A flow's return value: publish its artifacts, then the summary as a dict; when an asset
    that should have been covered was not (exit status 1), a Failed state whose message is the
    coverage line (which assets, and why) and whose data is an
    :class:`~flows.errors.AssetsNotMonitored` carrying the summary
    (:func:`flows.results.run_summary` reads either)."""
    # prefect loads only inside a flow: the command line prints these tables without it
    from prefect.runtime import flow_run
    from prefect.states import Failed

    summary.flow_run_id = str(flow_run.id) if flow_run.id else None
    publish_artifacts(summary, config)
    data = summary.to_dict()
    if not summary.exit_status:
        return data
    line = summary.coverage.line()
    return Failed(message=line, data=AssetsNotMonitored(line, data))


def publish_artifacts(summary: RunSummary, config=None) -> None:
    """The night's fleet table (and alert table) as Prefect table artifacts."""
    # prefect loads only inside a flow: the command line prints these tables without it
    from prefect.artifacts import create_table_artifact

    counts = summary.counts()
    stamp = _when(summary.as_of)
    description = (f"**fleet-health {summary.flow}** as of {stamp} UTC: "
                   + ", ".join(f"{n} {status}" for status, n in counts.items() if n)
                   + f"; {len(summary.alerts)} alert(s). Coverage: {summary.coverage.line()}")
    if summary.unmatched:
        description += (f" {len(summary.unmatched)} asset(s) in the telemetry match no vehicle "
                        f"class: {', '.join(summary.unmatched[:20])}.")
    create_table_artifact(fleet_rows(summary), key=f"fleet-health-{summary.flow}",
                          description=description)
    if summary.alerts:
        create_table_artifact(alert_rows(summary.alerts), key=f"fleet-health-{summary.flow}-alerts",
                              description=f"Alerts of the fleet-health {summary.flow} run as of "
                                          f"{stamp} UTC (zeta above its calibrated epsilon).")


# -- rich -----------------------------------------------------------------------------------

def fleet_table(summary: RunSummary, title: str | None = None):
    rows = fleet_rows(summary)
    table = Table(title=title or f"Fleet ({len(rows)} assets)", title_justify="left")
    for column in ("asset", "class", "status", "windows", "alarmed", "max ratio",
                   "channel tier", "baseline", "watermark", "reason"):
        table.add_column(column, no_wrap=column != "reason",
                         justify="right" if column in ("windows", "alarmed", "max ratio")
                         else "left")
    styles = {"ok": "green", FAILED: "bold red", "no baseline": "yellow",
              NOT_OPERATING: "yellow", DORMANT: "bold red", UNUSABLE_BASELINE: "bold red"}
    for row in rows:
        status = row["status"]
        style = styles.get(status)
        cells = [str(row[c]) for c in ("asset", "class")]
        cells.append(f"[{style}]{status}[/]" if style else status)
        alarmed = str(row["alarmed"]) if row["alarmed"] else ""
        if alarmed:
            alarmed = f"[bold red]{alarmed}[/]"
        cells += [str(row["windows"]), alarmed, row["max ratio"], row["channel tier"],
                  row["baseline"], row["watermark"], _escape(row["reason"])]
        table.add_row(*cells)
    return table


def alert_table(alerts: Sequence[Alert], title: str | None = None):
    rows = alert_rows(alerts)
    table = Table(title=title or f"Alerts ({len(rows)})", title_justify="left")
    for column in ("asset", "night", "tier", "channel", "zeta/epsilon", "severity",
                   "moved most", "likely cause"):
        table.add_column(column, no_wrap=column not in ("moved most", "likely cause"),
                         justify="right" if column == "zeta/epsilon" else "left")
    styles = {"critical": "bold red", "major": "red", "minor": "yellow"}
    for row in rows:
        style = styles.get(row["severity"], "")
        table.add_row(row["asset"], row["night"], row["tier"], row["channel"],
                      row["zeta/epsilon"], f"[{style}]{row['severity']}[/]" if style
                      else row["severity"], _escape(row["moved most"]),
                      _escape(row["likely cause"]))
    return table


def outside_line(alerts: Sequence[Alert]) -> str | None:
    """One line under the alert table when some alerts' nights were driven beyond their
    baseline's conditions (``Alert.conditions``): how many, on which assets, and what judges
    such nights without extrapolating. None when there are none.

    Examples
    --------
    ``"2 of 3 alerts (AHU-1, AHU-2) are on nights driven beyond their baseline's conditions
    ...``
    """
    beyond = [a for a in alerts if a.conditions]
    if not beyond:
        return None
    assets = sorted({a.asset_id for a in beyond})
    named = ", ".join(assets[:10]) + (f" and {len(assets) - 10} more" if len(assets) > 10
                                      else "")
    return (f"{len(beyond)} of {len(alerts)} alert{'' if len(alerts) == 1 else 's'} ({named}) "
            f"{'is' if len(beyond) == 1 else 'are'} on nights driven beyond their baseline's "
            f"conditions (the hint names the input): a baseline refitted over days that include "
            f"such conditions judges them without extrapolating (docs/baselines.md).")


def _escape(text: str) -> str:
    return escape(text or "")
