"""The fleet at a glance: the view record, its heat map and page, and the nightly flow
publishing it (Prefect artifact, one MLflow fleet run per night)."""
from __future__ import annotations

import base64
import io
import json

import numpy as np
import pytest

from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, FAULTY, day
from flows.fleet_view import (FleetView, Mark, build_view, night_of, summary_marks,
                              window_nights)
from registry.fleet_nights import NightRatio

CELL_PIXELS = 600          # a heat-map cell has more pixels, a legend patch fewer
NIGHTS = ("2026-02-01", "2026-02-02", "2026-02-03")


def _small_view() -> FleetView:
    """A: alarm on night 2, nothing recorded night 3; B healthy; C failed on night 2 without
    any window; D stale on night 3; E critical on night 1 only."""
    r = NightRatio
    ratios = [r("A", "turbine", NIGHTS[0], 0.5), r("A", "turbine", NIGHTS[1], 1.5),
              r("B", "pump", NIGHTS[0], 0.2), r("B", "pump", NIGHTS[1], 0.3),
              r("B", "pump", NIGHTS[2], 0.4), r("E", "turbine", NIGHTS[0], 3.0),
              r("E", "turbine", NIGHTS[1], 0.9), r("E", "turbine", NIGHTS[2], 0.8),
              r("D", "turbine", NIGHTS[0], 0.6),
              r("B", "pump", "2026-01-31", 9.0)]            # before the view: ignored
    marks = [Mark("C", "turbine", NIGHTS[1], "failed", "bad file"),
             Mark("D", "turbine", NIGHTS[2], "stale", "no telemetry"),
             Mark("B", "pump", "2026-02-04", "failed")]       # after the view: ignored
    return build_view(NIGHTS, ratios, marks, {"assets": 5, "failed": 1, "stale": 1},
                      NIGHTS[2])


def test_view_cells_hold_the_worst_ratio_and_marks_worst_first():
    view = _small_view()
    assert [row.asset_id for row in view.rows] == ["D", "E", "A", "C", "B"]
    by = {row.asset_id: row for row in view.rows}
    assert by["A"].ratios == (0.5, 1.5, None) and by["A"].marks == (None, None, None)
    assert by["B"].ratios == (0.2, 0.3, 0.4) and not by["B"].flagged
    assert by["C"].ratios == (None, None, None) and by["C"].marks == (None, "failed", None)
    assert by["D"].ratios == (0.6, None, None) and by["D"].marks == (None, None, "stale")
    assert by["E"].worst == 3.0 and by["E"].vehicle_class == "turbine"
    assert by["B"].vehicle_class == "pump"
    assert dict(view.coverage) == {"assets": 5, "failed": 1, "stale": 1}


def test_two_windows_of_a_night_keep_the_larger_ratio_and_old_failures_show_first_night():
    view = build_view(NIGHTS, [NightRatio("A", "t", NIGHTS[0], 0.7),
                               NightRatio("A", "t", NIGHTS[0], 1.2),
                               NightRatio("A", "t", NIGHTS[0], 0.1)],
                      [Mark("F", "t", "2026-01-20", "failed")])
    by = {row.asset_id: row for row in view.rows}
    assert by["A"].ratios == (1.2, None, None)
    assert by["F"].marks == ("failed", None, None)


def test_fold_keeps_the_top_rows_and_one_band_of_the_rest():
    view = _small_view()
    shown, band = view.fold(2)
    assert [row.asset_id for row in shown] == ["D", "E"]
    assert band.count == 3 and band.flagged == 2          # A (alarm) and C (failed)
    assert band.ratios == (0.5, 1.5, 0.4)                  # per night, max over A, C, B
    assert band.label == "3 more assets (2 flagged)"
    assert view.fold(4) == (view.rows, None)               # one leftover row is shown
    assert view.fold(10) == (view.rows, None)


def test_view_round_trips_through_json():
    view = _small_view()
    again = FleetView.from_dict(json.loads(json.dumps(view.to_dict())))
    assert again == view


def test_nights_of_a_run():
    assert night_of("2026-01-07T00:00:00+00:00") == "2026-01-06"
    assert night_of("2026-01-07T02:30:00") == "2026-01-06"
    assert window_nights("2026-03-01", 3) == ("2026-02-27", "2026-02-28", "2026-03-01")
    with pytest.raises(ValueError):
        window_nights("2026-03-01", 0)


def test_a_failure_is_marked_on_the_night_of_its_window():
    from flows.results import AssetResult, ErrorInfo, RunSummary

    summary = RunSummary("nightly", "2026-02-04T01:00:00+00:00", as_of="2026-02-04T00:00:00+00:00")
    summary.assets = [
        AssetResult("A", "t", "failed", error=ErrorInfo("bad row", "TelemetryError",
                                                        window_start="2026-02-02T00:00:00+00:00")),
        AssetResult("B", "t", "failed", error=ErrorInfo("registry down", "OSError")),
        AssetResult("C", "t", "stale", note="no telemetry since 2026-01-30"),
        AssetResult("D", "t", "ok"), AssetResult("E", "t", "no baseline")]
    marks = summary_marks(summary, night_of(summary.as_of))
    assert [(m.asset_id, m.night, m.status) for m in marks] == [
        ("A", "2026-02-02", "failed"), ("B", "2026-02-03", "failed"),
        ("C", "2026-02-03", "stale")]
    assert marks[0].reason == "bad row"


def test_a_night_that_did_not_operate_is_drawn_but_does_not_flag_its_row():
    from flows.fleet_plot import MARK_STYLE, heatmap_png
    from flows.results import AssetResult, RunSummary

    summary = RunSummary("nightly", "2026-02-04T01:00:00+00:00", as_of="2026-02-04T00:00:00+00:00")
    summary.assets = [AssetResult("W", "turbine", "not operating", note="too little operation"),
                      AssetResult("V", "turbine", "ok")]
    marks = summary_marks(summary, night_of(summary.as_of))
    assert [(m.asset_id, m.night, m.status) for m in marks] == [
        ("W", "2026-02-03", "not operating")]
    r = NightRatio
    view = build_view(NIGHTS, [r("W", "turbine", NIGHTS[0], 0.4), r("V", "turbine", NIGHTS[0], 0.2),
                               r("X", "turbine", NIGHTS[0], 1.5)], marks)
    by = {row.asset_id: row for row in view.rows}
    assert by["W"].marks == (None, None, "not operating")
    assert not by["W"].flagged and not by["W"].flagged_last_night
    # a calm night is not a problem: the row is not sorted above an earlier alarm
    assert [row.asset_id for row in view.rows] == ["X", "W", "V"]
    assert _has_colour(_pixels(heatmap_png(view)), MARK_STYLE["not operating"][0])


def test_a_dormant_night_is_drawn_and_flags_its_row():
    """Not operating for longer than [alerts] not_operating_after is a problem: its own
    mark, and its row sorted with the alarms of the last night."""
    from flows.fleet_plot import MARK_STYLE, heatmap_png
    from flows.fleet_view import coverage_counts
    from flows.results import AssetResult, RunSummary

    summary = RunSummary("nightly", "2026-02-04T01:00:00+00:00", as_of="2026-02-04T00:00:00+00:00")
    summary.assets = [AssetResult("W", "turbine", "dormant", note="dormant: not operating"),
                      AssetResult("V", "turbine", "ok")]
    marks = summary_marks(summary, night_of(summary.as_of))
    assert [(m.asset_id, m.night, m.status) for m in marks] == [("W", "2026-02-03", "dormant")]
    assert coverage_counts(summary)["dormant"] == 1
    r = NightRatio
    view = build_view(NIGHTS, [r("W", "turbine", NIGHTS[0], 0.4), r("V", "turbine", NIGHTS[0], 0.2),
                               r("X", "turbine", NIGHTS[0], 1.5)], marks)
    assert [row.asset_id for row in view.rows] == ["W", "X", "V"]
    assert view.rows[0].flagged_last_night
    assert MARK_STYLE["dormant"][0] != MARK_STYLE["not operating"][0]
    assert _has_colour(_pixels(heatmap_png(view)), MARK_STYLE["dormant"][0])


def _pixels(png: bytes) -> np.ndarray:
    from matplotlib.image import imread

    return (imread(io.BytesIO(png), format="png")[..., :3] * 255).round().astype(int)


def _count(pixels: np.ndarray, hex_colour: str) -> int:
    rgb = [int(hex_colour[i:i + 2], 16) for i in (1, 3, 5)]
    return int((np.abs(pixels - rgb).sum(axis=-1) <= 3).sum())


def _has_colour(pixels: np.ndarray, hex_colour: str) -> bool:
    """Whether a cell (not only the legend's small patch) has this colour."""
    return _count(pixels, hex_colour) > CELL_PIXELS


def test_heat_map_png_draws_alarms_marks_and_the_band():
    from flows.fleet_plot import MARK_STYLE, RATIO_COLORS, heatmap_png

    png = heatmap_png(_small_view(), top=2)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    pixels = _pixels(png)
    assert pixels.shape[0] > 200 and pixels.shape[1] > 400
    assert _has_colour(pixels, MARK_STYLE["stale"][0])         # D, night 3
    assert _has_colour(pixels, RATIO_COLORS[3])                # E's 3.0 (major)
    assert _has_colour(pixels, RATIO_COLORS[2])                # the band's 1.5 (A)
    assert not _has_colour(pixels, MARK_STYLE["unusable baseline"][0])  # legend only
    # C's failure is folded into the band (top 2): with every row shown, a black cell more
    # (black is also the text's colour)
    full = _pixels(heatmap_png(_small_view(), top=10))
    black = MARK_STYLE["failed"][0]
    assert _count(full, black) > _count(pixels, black) + 2 * CELL_PIXELS


def test_html_page_holds_the_image_the_alerts_and_the_coverage():
    from flows.fleet_plot import heatmap_png
    from flows.html_report import render_page
    from graybox.alert import Alert

    view = _small_view()
    png = heatmap_png(view, top=2)
    alert = Alert("A", "turbine", "2026-02-02T00:00:00+00:00", "2026-02-03T00:00:00+00:00",
                  "omega", "linear", 3.0, 2.0, 1.5, "minor",
                  ({"name": "a1", "baseline": 0.9, "candidate": 1.2, "contribution": 0.8},))
    page = render_page(view, png, [alert])
    assert page.startswith("<!DOCTYPE html>")
    assert f"data:image/png;base64,{base64.b64encode(png).decode()}" in page
    assert ("<tr class=\"minor\"><td>A</td><td>2026-02-02</td><td>linear</td><td>omega</td>"
            "<td class=\"n\">1.50</td><td>minor</td><td>a1 0.9→1.2</td>"
            "<td>not diagnosed</td></tr>") in page
    assert "<th>failed</th>" in page and "<td class=\"n\">5</td>" in page
    assert "http" not in page                       # self-contained: nothing to fetch


def _fleet_runs(registry):
    from registry.store import naming

    client = registry.backend.client
    experiment = client.get_experiment_by_name(naming.FLEET_EXPERIMENT)
    return [] if experiment is None else client.search_runs([experiment.experiment_id], "")


def _markdown_artifacts(flow_run_id):
    from prefect.client.orchestration import get_client

    with get_client(sync_client=True) as client:
        response = client.request("POST", "/artifacts/filter", json={
            "artifacts": {"key": {"any_": ["fleet-health-fleet-view"]},
                          "flow_run_id": {"any_": [flow_run_id]}},
            "limit": 5, "offset": 0, "sort": "UPDATED_DESC"})
    return response.json()


@pytest.mark.slow
def test_nightly_publishes_the_heat_map_once_per_night(workspace, monkeypatch):
    from flows.fleet_view import collect_view
    from flows.nightly import nightly

    # two nights: the second reuses the first's published view for the nights before it
    first = nightly(config_path=str(workspace.config), as_of=day(DAYS - 1).isoformat(),
                    return_state=True)
    assert first.is_completed(), first.message
    assert first.result()["extra"]["fleet_view"]["night"] == f"{day(DAYS - 2):%Y-%m-%d}"
    state = nightly(config_path=str(workspace.config), as_of=day(DAYS).isoformat(),
                    return_state=True)
    assert state.is_completed(), state.message
    summary = state.result()
    note = summary["extra"]["fleet_view"]
    night = f"{day(DAYS - 1):%Y-%m-%d}"
    assert note["published"] and note["night"] == night and note["assets"] == len(ASSETS)

    # the Prefect artifact: markdown with the PNG inline
    artifacts = _markdown_artifacts(summary["flow_run_id"])
    assert len(artifacts) == 1 and artifacts[0]["type"] == "markdown"
    markdown = artifacts[0]["data"]
    start = markdown.index("data:image/png;base64,") + len("data:image/png;base64,")
    png = base64.b64decode(markdown[start:markdown.index(")", start)])
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000

    # the MLflow fleet run of the night, with the same picture and the view
    registry = workspace.registry()
    runs = {run.data.tags["fleet_health.night"]: run for run in _fleet_runs(registry)}
    assert sorted(runs) == [f"{day(DAYS - 2):%Y-%m-%d}", night]
    assert runs[night].info.run_id == note["fleet_run_id"]
    assert runs[night].data.metrics["assets"] == len(ASSETS)
    client = registry.backend.client
    names = {f.path for f in client.list_artifacts(note["fleet_run_id"])}
    assert names == {"fleet_heatmap.png", "fleet_view.json", "night_statuses.json"}
    local = client.download_artifacts(note["fleet_run_id"], "fleet_view.json",
                                      str(workspace.path / "dl"))
    view = FleetView.from_dict(json.loads(open(local).read()))
    assert view.nights[-1] == night and len(view.nights) == 14
    assert {row.asset_id for row in view.rows} == set(ASSETS)
    assert {row.asset_id for row in view.rows if row.flagged} == set(FAULTY)
    assert {row.asset_id for row in view.rows[:len(FAULTY)]} == set(FAULTY)   # worst first
    processed = [f"{day(i):%Y-%m-%d}" for i in range(BASELINE_DAYS, DAYS)]
    for row in view.rows:
        for n, ratio in zip(view.nights, row.ratios):
            assert (ratio is not None) == (n in processed), (row.asset_id, n)
    # the cell is the run's recorded max ratio of the night
    history = registry.zeta_history("T-002")
    last = history[history["window_start"].str.startswith(night)]
    assert view.rows[[r.asset_id for r in view.rows].index("T-002")].ratios[-1] == \
        pytest.approx(last["ratio"].max())
    # the nightly view (reused cells + tonight's night read) equals a full registry read
    full = collect_view(registry, night)
    assert [(r.asset_id, r.ratios) for r in full.rows] == \
        [(r.asset_id, r.ratios) for r in view.rows]
    # the ratios read from the tags' and metrics' rows (SQLite) are MLflow's run search's
    assert registry.backend.sql_writer() is not None
    ratios = registry.night_ratios(view.nights)
    assert len(ratios) == len(ASSETS) * len(processed)
    registry.backend.sql_writes = False
    assert registry.night_ratios(view.nights) == ratios
    registry.backend.sql_writes = True

    # the same night again: the same fleet run, its artifacts replaced, never a second run
    again = nightly(config_path=str(workspace.config), as_of=day(DAYS).isoformat(),
                    return_state=True)
    assert again.is_completed(), again.message
    assert again.result()["extra"]["fleet_view"]["fleet_run_id"] == note["fleet_run_id"]
    assert len(_fleet_runs(registry)) == 2
    local = client.download_artifacts(note["fleet_run_id"], "fleet_view.json",
                                      str(workspace.path / "dl2"))
    assert FleetView.from_dict(json.loads(open(local).read())) == view
    # the fleet experiment is not a vehicle class: the class searches do not see it
    assert len(registry.backend.experiment_ids()) == 1

    # a picture that cannot be drawn is a warning and a note, not a failed night
    import flows.fleet_plot

    def broken(*args, **kwargs):
        raise RuntimeError("no canvas")

    monkeypatch.setattr(flows.fleet_plot, "heatmap_png", broken)
    third = nightly(config_path=str(workspace.config), as_of=day(DAYS).isoformat(),
                    return_state=True)
    assert third.is_completed(), third.message
    note = third.result()["extra"]["fleet_view"]
    assert note == {"published": False, "error": "the fleet heat map was not published: "
                                                 "RuntimeError: no canvas"}
    assert len(_fleet_runs(registry)) == 2
