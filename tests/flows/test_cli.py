"""The command line: commands, exit statuses (0 ok, 1 some assets failed, 2 bad usage or
configuration) and --json output."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

from flows.cli import COMMANDS, build_parser, main
from flows.commands.temporary_server import (TEMPORARY_SERVER_HINT, TemporaryServer,
                                             temporary_server_hint)
from flowtest_fleet import BASELINE_DAYS, DAYS, day


def run(capsys, *argv):
    status = main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_help_lists_every_command(capsys):
    status, out, _ = run(capsys, "--help")
    assert status == 0
    for command in ("demo", "simulate", "import", "baseline", "run", "reanalyze", "alerts",
                    "serve"):
        assert command in out and command in COMMANDS
    for argv in (["run", "--help"], ["baseline", "fit", "--help"], ["reanalyze", "--help"],
                 ["alerts", "--help"], ["simulate", "--help"], ["serve", "--help"],
                 ["demo", "--help"], ["baseline", "list", "--help"], ["import", "--help"]):
        assert run(capsys, *argv)[0] == 0


def test_python_dash_m_flows_is_the_same_command():
    result = subprocess.run([sys.executable, "-m", "flows", "--help"], capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0 and "reanalyze" in result.stdout


@pytest.mark.parametrize("argv, message", [
    (["frobnicate"], "invalid choice"),
    (["run", "--as-of", "tomorrow-ish"], "--as-of 'tomorrow-ish'"),
    (["run", "--asset", "../etc"], "invalid asset id"),
    (["run", "--asset", "Z-1"], "belongs to no vehicle class"),
    (["run", "--class", "bus"], "unknown vehicle class"),
    (["baseline", "fit", "--start", "2026-01-01", "--end", "2026-01-04"],
     "name the assets, a --class, or --all"),
    (["baseline", "fit", "--all", "--start", "2026-01-01", "--end", "2026-01-04", "--promote"],
     "--promote needs --reason"),
    (["baseline", "fit", "--all", "--start", "2026-01-01", "--end", "2026-01-03"],
     "at least 3 whole windows"),
    (["reanalyze", "--start", "2026-01-01", "--end", "2026-01-02"], "name the assets"),
    (["reanalyze", "--asset", "T-001", "--start", "2026-01-02", "--end", "2026-01-01"],
     "empty range"),
    (["simulate", "--out", "x", "--fault", "T-099:noise:3:1"], "unknown vehicle"),
    (["simulate", "--out", "x", "--fault", "T-001:rust:3:1"], "fault kind must be one of"),
])
def test_bad_usage_exits_2(workspace, capsys, argv, message):
    status, _, err = run(capsys, "--config", str(workspace.config), *argv)
    assert status == 2, err
    assert message in err


def test_bad_configuration_exits_2(tmp_path, capsys):
    status, _, err = run(capsys, "--config", str(tmp_path / "missing.toml"), "run")
    assert status == 2 and "no such configuration file" in err
    bad = tmp_path / "fleet.toml"
    bad.write_text('[classes.turbine]\nmodle = "graybox.models:GasTurbineShaft"\n'
                   'assets = ["T-*"]\n')
    for argv in (["run"], ["alerts"], ["baseline", "list"], ["serve", "--dry-run"],
                 ["reanalyze", "--asset", "T-001", "--start", "2026-01-01", "--end",
                  "2026-01-02"]):
        status, _, err = run(capsys, "--config", str(bad), *argv)
        assert status == 2, argv
        assert "fleet.toml: classes.turbine.modle: unknown key" in err


def test_run_json_alerts_and_baseline_list(workspace, fleet, capsys, tmp_path):
    # a new asset without a baseline, and one that no class claims
    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)
    shutil.copytree(root / "asset_id=T-001", root / "asset_id=T-009")
    shutil.copytree(root / "asset_id=T-001", root / "asset_id=PUMP-1")
    workspace.configure(telemetry=root)
    config = str(workspace.config)

    as_of = day(BASELINE_DAYS + 1).isoformat()
    status, out, err = run(capsys, "--config", config, "run", "--as-of", as_of, "--json")
    # issue 13: T-009 should be monitored and is not (no baseline): exit status 1, named
    assert status == 1, err
    assert "T-009 not monitored (no baseline)" in err
    summary = json.loads(out)
    assert summary["exit_status"] == 1 and summary["as_of"] == as_of
    assert summary["coverage"] == {
        "flow": "nightly", "assets": 6, "up_to_date": 5, "stale": 0, "no_baseline": 1,
        "unusable_baseline": 0, "failed": 0, "no_telemetry": 0, "not_operating": 0,
        "dormant": 0,
        "missed": ["T-009"],
        "complete": False}
    statuses = {a["asset_id"]: a["status"] for a in summary["assets"]}
    assert statuses["T-009"] == "no baseline"
    assert {statuses[a] for a in statuses if a != "T-009"} == {"ok"}
    assert summary["unmatched_assets"] == ["PUMP-1"]
    assert summary["counts"]["ok"] == 5 and summary["counts"]["no baseline"] == 1
    night_alerts = summary["alerts"]
    assert {a["asset_id"] for a in night_alerts} == {"T-002"}

    # the table form of the same (nothing new to do now)
    status, out, _ = run(capsys, "--config", config, "run", "--as-of", as_of)
    assert status == 1
    assert "up to date" in out and "no baseline" in out and "PUMP-1" in out
    assert ("Coverage: 6 assets: 5 monitored and up to date; not monitored: 1 without "
            "baseline (T-009).") in " ".join(out.split())

    status, out, _ = run(capsys, "--config", config, "alerts", "--json")
    assert status == 0
    alerts = json.loads(out)
    assert [(a["asset_id"], a["tier"]) for a in alerts] == \
        [(a["asset_id"], a["tier"]) for a in night_alerts]
    status, out, _ = run(capsys, "--config", config, "alerts")
    assert status == 0 and "T-002" in out and "zeta/epsilon" in out
    status, out, _ = run(capsys, "--config", config, "alerts", "--since",
                         day(DAYS).isoformat(), "--json")
    assert status == 0 and json.loads(out) == []
    status, out, _ = run(capsys, "--config", config, "alerts", "--from-registry", "--json")
    assert status == 0
    assert {(a["asset_id"], a["tier"]) for a in json.loads(out)} == \
        {(a["asset_id"], a["tier"]) for a in night_alerts}

    # baseline list finds the store through fleet.toml (no --tracking-uri)
    status, out, _ = run(capsys, "--config", config, "baseline", "list", "--json")
    assert status == 0
    listed = {s["asset_id"]: s for s in json.loads(out)}
    assert listed["T-001"]["baseline"]["version"] == 1
    assert listed["T-001"]["watermark"].startswith(f"{day(BASELINE_DAYS + 1):%Y-%m-%d}")


def test_simulate_writes_a_fleet_and_its_config(tmp_path, capsys):
    from flows.config import load_config
    from graybox.telemetry import list_assets, list_dates

    out_dir = tmp_path / "telemetry"
    status, out, _ = run(capsys, "simulate", "--out", str(out_dir), "--vehicles", "2",
                         "--days", "2", "--sample-interval", "60", "--fault",
                         "T-002:bias:1:0.5", "--config-out", str(tmp_path / "fleet.toml"))
    assert status == 0
    assert list_assets(out_dir) == ["T-001", "T-002"]
    assert len(list_dates(out_dir, "T-001")) == 2
    truth = json.loads((out_dir / "fleet_truth.json").read_text())
    faults = {v["asset_id"]: v["faults"] for v in truth["vehicles"]}
    assert faults["T-001"] == [] and faults["T-002"][0]["kind"] == "bias"
    assert "T-002: bias 0.5 from day 1" in out
    assert load_config(tmp_path / "fleet.toml").telemetry_root == out_dir.resolve()


def test_serve_dry_run_lists_the_deployments(workspace, capsys):
    status, out, _ = run(capsys, "--config", str(workspace.config), "serve", "--dry-run")
    assert status == 0
    assert "fleet-health-nightly/nightly" in out and "cron '30 2 * * *' (UTC)" in out
    assert "flows.nightly.nightly" in out
    assert "fleet-health-baseline/baseline" in out and "on demand" in out


def test_options_after_the_command(workspace, capsys):
    parser = build_parser()
    args = parser.parse_args(["run", "--config", "x.toml", "--tracking-uri", "sqlite:///y.db"])
    assert args.config == "x.toml" and args.tracking_uri == "sqlite:///y.db"
    args = parser.parse_args(["--config", "a.toml", "run"])
    assert args.config == "a.toml"


def test_a_prefect_server_too_slow_to_start_is_one_clear_line_and_exit_3(tmp_path):
    """A start-up slower than allowed (here: no time at all) fails cleanly, without running."""
    (tmp_path / "telemetry").mkdir()
    (tmp_path / "fleet.toml").write_text(
        '[classes.turbine]\nmodel = "graybox.models:GasTurbineShaft"\nassets = ["T-*"]\n'
        'columns = { omega = "shaft_speed" }\n')
    env = {k: v for k, v in os.environ.items() if k != "PREFECT_API_URL"}
    env.update(PREFECT_HOME=str(tmp_path / ".prefect"),
               PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS="0")
    done = subprocess.run([sys.executable, "-m", "flows.cli", "run", "--config", "fleet.toml"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 3, done.stderr
    assert "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    # the line that says how to avoid the temporary server, then the one that says it failed
    assert len(lines) == 2 and lines[0] == TEMPORARY_SERVER_HINT
    assert "did not start within 0 s" in lines[1]
    assert "PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS" in lines[1]


def test_a_set_prefect_server_is_not_told_about_the_temporary_one(monkeypatch):
    from prefect.settings import PREFECT_API_URL, temporary_settings

    with temporary_settings(updates={PREFECT_API_URL: "http://127.0.0.1:4200/api"}):
        assert temporary_server_hint() is None
    with temporary_settings(restore_defaults={PREFECT_API_URL}):
        assert temporary_server_hint() == TEMPORARY_SERVER_HINT
        assert "prefect server start" in TEMPORARY_SERVER_HINT


def test_flows_on_a_temporary_server_send_no_heartbeats_and_on_a_server_set_prefects_own():
    from prefect.settings import (PREFECT_API_URL, PREFECT_FLOWS_HEARTBEAT_FREQUENCY,
                                  get_current_settings, temporary_settings)

    with temporary_settings(updates={PREFECT_API_URL: "http://127.0.0.1:4200/api",
                                     PREFECT_FLOWS_HEARTBEAT_FREQUENCY: 240}):
        with TemporaryServer().flow_settings():
            assert get_current_settings().flows.heartbeat_frequency == 240
        with temporary_settings(restore_defaults={PREFECT_API_URL}):
            with TemporaryServer().flow_settings():
                assert get_current_settings().flows.heartbeat_frequency is None
            assert get_current_settings().flows.heartbeat_frequency == 240


def test_the_command_line_allows_a_loaded_machine_time_to_start_prefect(monkeypatch):
    from flows.cli import EPHEMERAL_STARTUP_TIMEOUT, _prefect_environment

    monkeypatch.delenv("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS", raising=False)
    _prefect_environment(build_parser().parse_args(["run"]))
    assert os.environ["PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS"] == \
        str(EPHEMERAL_STARTUP_TIMEOUT) == "180"
    monkeypatch.setenv("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS", "600")
    _prefect_environment(build_parser().parse_args(["run"]))
    assert os.environ["PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS"] == "600"
