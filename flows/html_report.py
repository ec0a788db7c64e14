"""The fleet report as one static, self-contained HTML page.

The heat map (an inline ``data:`` PNG), the coverage counts of the latest night and the
alert table of the nights shown (with the run table's likely cause of each alert,
:func:`flows.run_tables.alert_rows`); no script, no stylesheet or image to fetch, so the file
can be mailed or archived as it is.
"""
from __future__ import annotations

import base64
import html
from typing import Sequence

from flows.fleet_view import FleetView
from flows.run_tables import alert_rows
from graybox.alert import Alert

NUMBER_CELL = '<td class="n">'
ALERT_COLUMNS = ("asset", "night", "tier", "channel", "zeta/epsilon", "severity", "moved most",
                 "likely cause")
#: the likely cause of an alert that was not diagnosed (a stale-telemetry alert, a run
#: recorded before diagnoses existed): said, not left blank
NOT_DIAGNOSED = "not diagnosed"
_STYLE = """
body { font-family: sans-serif; margin: 1.5em; color: #212121; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }
td.n { text-align: right; }
tr.critical td { background: #ffcdd2; } tr.major td { background: #ffe0b2; }
img { max-width: 100%; }
"""


def png_data_uri(png: bytes) -> str:
    """``data:image/png;base64,...`` of PNG bytes."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def render_page(view: FleetView, png: bytes, alerts: Sequence[Alert],
                title: str = "fleet-health: the fleet at a glance") -> str:
    """The page (HTML text) of ``view``: its heat map ``png``, coverage and ``alerts``."""
    e = html.escape
    span = f"{view.nights[0]} to {view.nights[-1]}" if view.nights else "no nights"
    parts = [f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
             f"<title>{e(title)}</title><style>{_STYLE}</style></head><body>",
             f"<h1>{e(title)}</h1>",
             f"<p>Nights {e(span)} (UTC). Cell: the asset's worst zeta/epsilon ratio of the "
             f"night over its tiers and channels; above 1 is an alarm.</p>"]
    parts.append("<h2>Coverage</h2>")
    if view.coverage:
        parts.append(f"<p>Of the nightly run of {e(view.coverage_night or '')}:</p>"
                     "<table id=\"coverage\"><tr>"
                     + "".join(f"<th>{e(k)}</th>" for k, _ in view.coverage)
                     + "</tr><tr>" + "".join(f"{NUMBER_CELL}{v}</td>" for _, v in view.coverage)
                     + "</tr></table>")
    else:
        parts.append("<p>No nightly run recorded its statuses in these nights.</p>")
    parts.append(f"<p>{len(view.rows)} assets recorded in these nights, "
                 f"{sum(row.flagged for row in view.rows)} flagged (an alarm or a mark).</p>")
    parts.append(f"<h2>Heat map</h2><img id=\"heatmap\" alt=\"heat map of assets x nights\" "
                 f"src=\"{png_data_uri(png)}\">")
    rows = alert_rows(alerts)
    parts.append(f"<h2>Alerts ({len(rows)})</h2>")
    if rows:
        parts.append("<table id=\"alerts\"><tr>" + "".join(f"<th>{e(c)}</th>"
                                                          for c in ALERT_COLUMNS) + "</tr>")
        for row in rows:
            cells = "".join((NUMBER_CELL if c == "zeta/epsilon" else "<td>")
                            + e(_text(row, c)) + "</td>" for c in ALERT_COLUMNS)
            parts.append(f"<tr class=\"{e(row['severity'])}\">{cells}</tr>")
        parts.append("</table>")
    else:
        parts.append("<p>No alerts in these nights.</p>")
    parts.append("</body></html>\n")
    return "\n".join(parts)


def _text(row: dict, column: str) -> str:
    if column == "likely cause" and not row[column]:
        return NOT_DIAGNOSED
    return str(row[column])
