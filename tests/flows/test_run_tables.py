"""The run's tables: the line under the alert table that counts the alerts on nights driven
beyond their baseline's conditions (flows.run_tables.outside_line)."""
from __future__ import annotations

import dataclasses

from flows.run_tables import outside_line
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
