"""``fleet-health report --out DIR``: the static page of the fleet at a glance."""
from __future__ import annotations

import base64
import json
import re

import pytest

from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, FAULTY, day


def test_help_explains_the_page(capsys):
    from flows.cli import main

    assert main(["report", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for words in ("--out DIR", "--nights N", "(default 14)", "worst zeta/epsilon ratio",
                  "folded into one band row", "coverage counts", "self-contained"):
        assert words in text, words


def test_an_empty_registry_is_one_clear_line_and_exit_1(tmp_path, capsys):
    from flows.cli import main

    config = tmp_path / "fleet.toml"
    config.write_text('[classes.turbine]\nmodel = "graybox.models:GasTurbineShaft"\n'
                      'assets = ["T-*"]\n')
    status = main(["--config", str(config), "--tracking-uri",
                   f"sqlite:///{tmp_path / 'mlflow.db'}", "report", "--out",
                   str(tmp_path / "out")])
    assert status == 1
    assert "nothing recorded" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_report_after_a_night_with_a_failed_asset(workspace, corrupt, capsys):
    from flows.cli import main

    bad_day = BASELINE_DAYS + 1
    root, _ = corrupt("T-003", bad_day, "inf")
    workspace.configure(telemetry=root)
    assert main(["--config", str(workspace.config), "run", "--as-of", day(DAYS).isoformat(),
                 "--json"]) == 1                                    # T-003 failed
    summary = json.loads(capsys.readouterr().out)
    assert summary["extra"]["fleet_view"]["published"]
    alerts = summary["alerts"]
    assert {a["asset_id"] for a in alerts} == set(FAULTY)

    out = workspace.path / "report"
    assert main(["--config", str(workspace.config), "report", "--out", str(out),
                 "--nights", "5"]) == 0
    printed = capsys.readouterr().out
    assert f"{len(ASSETS)} assets over nights {day(DAYS - 5):%Y-%m-%d} to " \
           f"{day(DAYS - 1):%Y-%m-%d}" in printed and f"{len(alerts)} alert(s)" in printed

    view = json.loads((out / "fleet_view.json").read_text())
    assert view["nights"] == [f"{day(i):%Y-%m-%d}" for i in range(DAYS - 5, DAYS)]
    rows = {row["asset_id"]: row for row in view["rows"]}
    failed = rows["T-003"]
    column = view["nights"].index(f"{day(bad_day):%Y-%m-%d}")
    assert failed["marks"][column] == "failed"
    assert failed["ratios"][column - 1] is not None                # the night before: done
    assert failed["ratios"][column] is None and failed["ratios"][column + 1] is None
    assert view["coverage"]["failed"] == 1 and view["coverage"]["assets"] == len(ASSETS)
    assert view["coverage"]["monitored"] == len(ASSETS) - 1
    assert view["coverage_night"] == f"{day(DAYS - 1):%Y-%m-%d}"
    # worst first: the assets flagged on the last night, T-003 (flagged earlier) next
    order = [row["asset_id"] for row in view["rows"]]
    assert set(order[:2]) == set(FAULTY) and order[2] == "T-003"

    page = (out / "index.html").read_text()
    png = (out / "fleet_heatmap.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"data:image/png;base64,{base64.b64encode(png).decode()}" in page
    table = page[page.index('<table id="alerts">'):]
    assert len(re.findall(r"<tr class=", table)) == len(alerts)
    for alert in alerts:
        assert f"<td>{alert['asset_id']}</td><td>{alert['window_start'][:10]}</td>" \
               f"<td>{alert['tier']}</td><td>{alert['channel']}</td>" in table
    assert "<th>failed</th>" in page
