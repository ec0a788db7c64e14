"""Every failed window of an asset is kept and named (a reanalysis goes on past a failed
window; only the first error used to be reported, the later ones were dropped)."""
from __future__ import annotations

import argparse
import json

import pandas as pd

from flows.commands.plumbing import report_summary
from flows.discovery import AssetRef
from flows.pipeline import PendingAsset
from flows.results import FAILED, AssetResult, RunSummary
from graybox.exceptions import TelemetryError


def _failed_twice() -> AssetResult:
    asset = PendingAsset(AssetRef("P-1", "pumps"), AssetResult("P-1", "pumps", "ok"), model=None)
    first, last = (pd.Timestamp("2026-03-01 10:00", tz="UTC"),
                   pd.Timestamp("2026-03-01 10:20", tz="UTC"))
    asset.fail(TelemetryError("P-1", "too_few_samples",
                              "the window covers 117s, need at least min_duration=4min"), first)
    asset.fail(ValueError("the fit diverged"), last)
    return asset.result


def test_each_failed_window_is_kept_the_first_is_the_assets_error():
    result = _failed_twice()
    assert result.status == FAILED
    assert [e.window_start for e in result.window_errors] == ["2026-03-01T10:00:00+00:00",
                                                             "2026-03-01T10:20:00+00:00"]
    assert result.error == result.window_errors[0]
    assert result.window_errors[0].kind == "too_few_samples"
    # the run summary's JSON carries them and reads them back
    again = AssetResult.from_dict(json.loads(json.dumps(result.to_dict())))
    assert again.window_errors == result.window_errors
    # a summary written before the field existed still reads
    old = result.to_dict()
    del old["window_errors"]
    assert AssetResult.from_dict(old).window_errors == []


def test_the_command_line_names_every_failed_window(capsys):
    summary = RunSummary("reanalyze", "2026-03-02T00:00:00+00:00", assets=[_failed_twice()])
    status = report_summary(argparse.Namespace(json=True), summary, "Reanalysis")
    assert status == 1
    err = capsys.readouterr().err
    assert "P-1 failed: " in err and "the window covers 117s" in err
    assert "P-1 window 2026-03-01T10:20:00+00:00 failed too: the fit diverged" in err


def test_the_reanalysis_table_lists_the_failed_windows():
    from rich.console import Console

    from flows.commands.reanalyze import window_table

    summary = RunSummary("reanalyze", "2026-03-02T00:00:00+00:00", assets=[_failed_twice()])
    console = Console(width=200, record=True)
    console.print(window_table(summary))
    text = console.export_text()
    assert "2026-03-01 10:00 ..." in text and "2026-03-01 10:20 ..." in text
    assert text.count("FAILED") == 2 and "too_few_samples" in text and "ValueError" in text
