"""The HTML page's alert table: the likely cause of each alert, the very text of the run
table (flows.run_tables.likely_cause), and "not diagnosed" said rather than left blank."""
from __future__ import annotations

import html

from flows.fleet_view import build_view
from graybox.diagnosis import Diagnosis, Hypothesis
from graybox.alert import Alert
from graybox.alert_diagnosis import DiagnosisFailure, alert_entries
from registry.fleet_nights import NightRatio

NIGHT = "2026-02-02"
INERTIA = Hypothesis("parameter inertia", "parameter", "inertia", 50.0, 33.4, (33.1, 33.7),
                     412.0, 210.0)
NOISE = Hypothesis("omega noise level", "noise", "omega", 1.0, 1.02, (0.9, 1.2), -4.0, 0.5)


def _alert(asset: str, ratio: float, diagnosis=None) -> Alert:
    return Alert(asset, "turbine", f"{NIGHT}T00:00:00+00:00", "2026-02-03T00:00:00+00:00",
                 "omega", "level", ratio, 1.0, ratio, "major", diagnosis=alert_entries(diagnosis))


def _page(alerts) -> str:
    from flows.html_report import render_page

    view = build_view((NIGHT,), [NightRatio(a.asset_id, "turbine", NIGHT, a.ratio)
                                 for a in alerts], [])
    return render_page(view, b"\x89PNG\r\n\x1a\n", alerts)


def _cause_cells(page: str) -> dict[str, str]:
    """Each alert row's asset and last cell."""
    rows = [line for line in page.splitlines() if line.startswith("<tr class=")]
    return {row.split("<td>")[1].split("</td>")[0]:
            row.rsplit("<td>", 1)[1].removesuffix("</td></tr>") for row in rows}


def test_the_alert_table_says_each_alerts_likely_cause():
    from flows.run_tables import likely_cause

    explained = _alert("A", 3.0, Diagnosis((INERTIA, NOISE), True, 0.0, ("omega",), 900, 300.0))
    unexplained = _alert("B", 2.0, Diagnosis((NOISE,), False, 0.0, ("omega",), 900, 300.0))
    stale = _alert("C", 1.5)
    failed = _alert("D", 1.2, DiagnosisFailure("GrayBoxError: out of time"))
    page = _page([explained, unexplained, stale, failed])
    assert "<th>moved most</th><th>likely cause</th></tr>" in page
    assert _cause_cells(page) == {
        "A": "parameter inertia 50 -&gt; 33.4 (-33%; interval 33.1 to 33.7)",
        "B": "no single cause", "C": "not diagnosed",
        "D": "diagnosis failed: GrayBoxError: out of time"}
    # the run table's text, escaped
    assert html.escape(likely_cause(explained)) == _cause_cells(page)["A"]
