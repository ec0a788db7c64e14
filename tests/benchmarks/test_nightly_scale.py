"""benchmarks.nightly_scale: the measurement of a child process, the FLOP floor, the tables
from a recorded quick run, and (slow) the quick run end to end through the real flows."""
from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import pytest

from benchmarks.measured_process import run_measured
from benchmarks.nightly_scale import (child_environment, keep_baseline, parse_args,
                                      restore_baseline)
from benchmarks.scale_floor import Structure, flops_per_asset_night, matmul_rate
from benchmarks.scale_report import derive, render_markdown, render_text, target_checks

RECORDED = pathlib.Path(__file__).with_name("nightly_scale_quick.json")
REPO = pathlib.Path(__file__).resolve().parents[2]


def test_a_child_is_measured_from_outside(tmp_path):
    # 200 MB touched, then half a second of sleep: wait4 sees the memory, not the sleep
    code = "import time, numpy; a = numpy.ones(25_000_000); time.sleep(0.5); print('done')"
    measured = run_measured([sys.executable, "-c", code], tmp_path, dict(os.environ),
                            tmp_path / "logs", "child")
    assert measured.returncode == 0 and measured.stdout.strip() == "done"
    assert measured.wall >= 0.5 and measured.cpu < measured.wall
    assert measured.max_rss > 200 * 10 ** 6
    assert measured.tree_rss > 100 * 10 ** 6          # sampled: at least during the sleep
    assert measured.load


def test_the_floor_counts_each_tier():
    flops = flops_per_asset_night(Structure.assumed())
    # RK4, 2 sub-steps of 56 operations, on every 1-Hz sample
    assert flops["residual"] == pytest.approx(86_400 * (2 * 56 + 2))
    assert flops["network"] > 100 * flops["stationarize_ar"]      # 200 trained iterations
    assert flops["total"] == pytest.approx(sum(v for k, v in flops.items() if k != "total"))
    fixed = flops_per_asset_night(Structure(12_343, 29, 6, 8, 0.0, 200, 1))
    assert fixed["network"] < flops["network"] / 5          # hidden layer computed once
    assert matmul_rate(size=64, repeat=1).float64 > 1e6


def test_the_tables_render_from_a_recorded_run():
    results = json.loads(RECORDED.read_text())
    size = results["sizes"][0]
    d = derive(size)
    nightly, startup = size["nightly"], size["startup"]
    assert d["nights"] == size["n"] == 2
    assert d["per_asset"] == pytest.approx((nightly["wall"] - startup["wall"]) / 2)
    assert d["fleet"] == pytest.approx(startup["wall"] + 1000 * d["per_asset"])
    stage_wall = sum(s["wall"] for s in d["stages"].values())
    assert stage_wall + d["rest"]["wall"] == pytest.approx(d["total"]["wall"])
    assert [name for name, _, _ in target_checks(results)] == [
        "nightly", "fleet", "startup", "baseline", "memory", "registry"]
    text = render_text(results)
    assert "QUICK RUN" in text and "network" in text and "Prefect and start-up" in text
    markdown = render_markdown(results)
    for heading in ("# Performance", "## Targets", "## Growth with the fleet",
                    "## Where a night's time goes", "## Baseline with calibration",
                    "## The floor", "```sh\npython -m benchmarks.nightly_scale"):
        assert heading in markdown
    assert "load average" in markdown


def test_quick_is_two_assets_at_ten_seconds():
    args = parse_args(["--quick"])
    assert (args.sizes, args.baseline_days, args.sample_interval) == ([2], 3, 10.0)
    with pytest.raises(SystemExit):
        parse_args(["--baseline-days", "2"])


def test_the_nights_use_a_running_prefect_server_only_when_given(tmp_path, monkeypatch):
    # a server the caller's shell happens to point at is never used by accident
    monkeypatch.setenv("PREFECT_API_URL", "http://elsewhere:4200/api")
    assert parse_args([]).prefect_server is False
    assert parse_args(["--prefect-server"]).prefect_server is True
    assert "PREFECT_API_URL" not in child_environment(tmp_path)
    url = "http://127.0.0.1:4299/api"
    env = child_environment(tmp_path, url)
    assert env["PREFECT_API_URL"] == url
    assert env["PREFECT_HOME"] == str(tmp_path / ".prefect")


def test_the_store_after_the_baseline_is_kept_and_restored(tmp_path):
    # --keep saves everything but the telemetry; --reuse puts it back as it was and removes
    # what the nights added, leaving the telemetry alone
    work = tmp_path / "n3"
    (work / "telemetry" / "asset_id=A").mkdir(parents=True)
    (work / "telemetry" / "asset_id=A" / "day.parquet").write_text("rows")
    (work / "mlartifacts" / "1").mkdir(parents=True)
    (work / "mlflow.db").write_text("baselines")
    (work / "mlartifacts" / "1" / "signature.json").write_text("{}")
    with pytest.raises(SystemExit, match="run with --keep"):
        restore_baseline(work)
    keep_baseline(work, 1.5, {"wall": 40.0})
    assert not (work / "after-baseline" / "telemetry").exists()
    (work / "mlflow.db").write_text("baselines and a night")
    (work / "mlartifacts" / "2").mkdir()
    (work / "fleet-alerts.jsonl").write_text("{}")
    assert restore_baseline(work) == (1.5, {"wall": 40.0})
    assert (work / "mlflow.db").read_text() == "baselines"
    assert sorted(p.name for p in (work / "mlartifacts").iterdir()) == ["1"]
    assert not (work / "fleet-alerts.jsonl").exists() and not (work / "baseline.json").exists()
    assert (work / "telemetry" / "asset_id=A" / "day.parquet").read_text() == "rows"
    assert restore_baseline(work) == (1.5, {"wall": 40.0})      # as often as one likes


@pytest.mark.slow
def test_quick_run_end_to_end(tmp_path):
    """Three real flow runs in child processes (about 40 s idle, 90 s on a busy machine)."""
    out = tmp_path / "performance.md"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    # one-night candidates: no unmeasured night before the measured one (one child less)
    done = subprocess.run([sys.executable, "-m", "benchmarks.nightly_scale", "--quick",
                           "--candidate-nights", "1",
                           "--workdir", str(tmp_path / "work"), "--out", str(out)],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    results = json.loads((tmp_path / "work" / "nightly_scale.json").read_text())
    size = results["sizes"][0]
    assert size["nightly"]["windows"] == 2 and size["startup"]["windows"] == 0
    assert size["baseline"]["counts"].get("ok") == 2
    assert {"read", "residual", "network", "registry"} <= set(size["nightly"]["stages"])
    assert size["structure"]["candidates"] == 2
    assert "N = 2: nightly run, per asset-night" in done.stdout
    assert "## Targets" in out.read_text()
