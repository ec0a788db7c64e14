"""The run's tables: the line under the alert table that counts the alerts on nights driven
beyond their baseline's conditions (flows.run_tables.outside_line), and the fleet table's
nearest tier and conditions (flows.run_tables.fleet_rows)."""
from __future__ import annotations

import dataclasses

from flows.results import AssetResult, ErrorInfo, RunSummary, WindowResult
from flows.run_tables import fleet_rows, outside_line
from graybox.alert import Alert


def alert(asset: str) -> Alert:
    return Alert(asset, "ahu", "2026-01-05T00:00:00+00:00", "2026-01-06T00:00:00+00:00",
                 "supply_temp", "level", zeta=1.5, epsilon=0.5, ratio=3.0, severity="major")


def test_alerts_beyond_their_baselines_conditions_are_counted_with_their_assets():
    inside = alert("AHU-3")
    beyond = [dataclasses.replace(alert(asset), conditions="outdoor_temp mean 4.2 (baseline "
                                                          "days 12.2 to 16)")
              for asset in ("AHU-2", "AHU-1", "AHU-2")]
    line = outside_line([inside, *beyond])
    assert line.startswith("3 of 4 alerts (AHU-1, AHU-2) are on nights driven beyond their "
                           "baseline's conditions (the hint names the input): a baseline "
                           "refitted over days that include such conditions")
    assert outside_line(beyond[:1]).startswith("1 of 1 alert (AHU-2) is on nights")
    # none beyond, or no alerts: no line
    assert outside_line([inside]) is None and outside_line([]) is None
    many = [dataclasses.replace(b, asset_id=f"A-{i:02d}") for i, b in enumerate(beyond * 4)]
    assert "(A-00, A-01, A-02, A-03, A-04, A-05, A-06, A-07, A-08, A-09 and 2 more)" in \
        outside_line(many)


def window(day: int, ratio: float | None, at: str | None, conditions: str | None = None
           ) -> WindowResult:
    start, end = (f"2026-01-{d:02d}T00:00:00+00:00" for d in (day, day + 1))
    return WindowResult(start, end, day, f"run{day}", bool(ratio and ratio > 1), ratio, True, at,
                        conditions)


def test_the_fleet_row_names_the_nearest_tier_and_a_night_beyond_the_conditions():
    quiet = AssetResult("L-05", "lift", "ok", [
        window(20, 0.76, "temp nonlinear",
               "ambient mean 19.1 (baseline days 20.02 to 21.3)"),
        window(21, 0.32, "temp level")])
    failed = AssetResult("L-02", "lift", "failed", [window(20, 0.11, "speed noise")],
                         error=ErrorInfo("no rows", "TelemetryError"))
    unrated = AssetResult("L-03", "lift", "ok", [window(20, None, None)])
    summary = RunSummary("nightly", "2026-01-22T02:30:00+00:00",
                         assets=[quiet, failed, unrated])
    rows = {row["asset"]: row for row in fleet_rows(summary)}
    assert (rows["L-05"]["max ratio"], rows["L-05"]["channel tier"]) == ("0.76", "temp nonlinear")
    assert rows["L-05"]["reason"] == ("2026-01-20 beyond its baseline's conditions: ambient mean "
                                      "19.1 (baseline days 20.02 to 21.3)")
    assert rows["L-02"]["channel tier"] == "speed noise"
    assert rows["L-02"]["reason"] == "no rows"            # the failure, no conditions
    assert (rows["L-03"]["max ratio"], rows["L-03"]["channel tier"]) == ("", "")
    # a summary read back from a flow's JSON of before these fields: none of them
    old = AssetResult.from_dict({**quiet.to_dict(), "windows": [
        {k: v for k, v in w.to_dict().items() if k not in ("max_ratio_at", "conditions")}
        for w in quiet.windows]})
    assert [w.max_ratio_at for w in old.windows] == [None, None]


def test_the_reanalysis_table_names_each_windows_channel_and_tier():
    from rich.console import Console

    from flows.commands.reanalyze import window_table

    asset = AssetResult("L-05", "lift", "ok", [window(20, 0.76, "temp noise"),
                                               window(21, None, None)], baseline_version=1)
    console = Console(width=200, record=True)
    console.print(window_table(RunSummary("reanalyze", "2026-01-22T00:00:00+00:00",
                                          assets=[asset])))
    lines = [line for line in console.export_text().splitlines() if "L-05" in line]
    assert len(lines) == 2
    assert "0.76" in lines[0] and "temp noise" in lines[0] and "v1" in lines[0]
    assert "temp noise" not in lines[1]
