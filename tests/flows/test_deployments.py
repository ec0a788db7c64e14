"""Deployments (prefect.yaml and `serve`) and the notification hook."""
from __future__ import annotations

import pathlib
from types import SimpleNamespace

import yaml

from flows.config import ScheduleSettings, load_config

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_prefect_yaml_is_valid_and_its_entrypoints_are_flows():
    from prefect.cli.deploy._models import PrefectYamlModel
    from prefect.flows import Flow, load_flow_from_entrypoint

    data = yaml.safe_load((ROOT / "prefect.yaml").read_text())
    model = PrefectYamlModel.model_validate(data)
    by_name = {d.name: d for d in model.deployments}
    assert set(by_name) == {"nightly", "baseline", "reanalyze"}
    assert by_name["nightly"].entrypoint == "flows/nightly.py:nightly"
    (schedule,) = by_name["nightly"].schedules
    # YAML cannot read the Python default: the one default it repeats is held to it here
    default = ScheduleSettings()
    assert (schedule.cron, schedule.timezone) == (default.cron, default.timezone) \
        == ("30 2 * * *", "UTC")
    for deployment in model.deployments:
        assert deployment.parameters["config_path"] == "fleet.toml"
        path, name = deployment.entrypoint.split(":")
        flow = load_flow_from_entrypoint(str(ROOT / path) + ":" + name)
        assert isinstance(flow, Flow) and flow.name.startswith("fleet-health-")
        assert "config_path" in flow.parameters.properties


def test_serve_builds_the_deployments_from_the_configuration(tmp_path):
    from flows.serve import build_deployments

    (tmp_path / "fleet.toml").write_text('''
[schedule]
cron = "15 1 * * *"
timezone = "Europe/Berlin"
[classes.turbine]
model = "graybox.models:GasTurbineShaft"
assets = ["T-*"]
columns = { omega = "shaft_speed" }
''')
    config = load_config(tmp_path / "fleet.toml")
    nightly, baseline, reanalyze = build_deployments(config)
    assert nightly.name == "nightly" and nightly.entrypoint == "flows.nightly.nightly"
    (schedule,) = nightly.schedules
    assert schedule.schedule.cron == "15 1 * * *"
    assert schedule.schedule.timezone == "Europe/Berlin"
    assert nightly.parameters == {"config_path": str(config.path)}
    assert not baseline.schedules and not reanalyze.schedules
    assert reanalyze.entrypoint == "flows.reanalyze.reanalyze"



def test_served_runs_start_their_process_ahead_of_time(monkeypatch):
    import flows.serve
    from prefect.runner import Runner

    seen = {}
    monkeypatch.setattr(flows.serve, "serve", lambda *deployments, **options: seen.update(options))
    from prefect.settings import PREFECT_RUNNER_POLL_FREQUENCY, temporary_settings

    with temporary_settings(updates={PREFECT_RUNNER_POLL_FREQUENCY: 7}):
        flows.serve.serve_deployments([])
    # runs due within the poll interval plus the margin are taken: each is picked up at least
    # SPAWN_AHEAD_SECONDS before it is due, whenever the runner polls
    assert seen["query_seconds"] == 7.0
    assert seen["prefetch_seconds"] == 7.0 + flows.serve.SPAWN_AHEAD_SECONDS
    assert flows.serve.SPAWN_AHEAD_SECONDS >= 10
    runner = Runner(**seen)                    # Prefect's runner takes these options
    assert runner.query_seconds == 7.0

def test_notification_message():
    from flows.hooks import compose_message

    quiet = {"alerts": [], "assets": [{"asset_id": "T-1", "status": "ok"}]}
    assert compose_message("nightly", quiet, "Completed", None) is None
    summary = {"alerts": [{"asset_id": "T-2", "window_start": "2026-01-05T00:00:00+00:00",
                           "channel": "omega", "tier": "noise", "ratio": 7.5,
                           "severity": "critical"}],
               "assets": [{"asset_id": "T-3", "status": "failed",
                           "error": {"message": "asset 'T-3', file f, row 9: NaN"}}]}
    subject, body = compose_message("nightly", summary, "Failed", "1 of 3 assets failed")
    assert "1 alert(s), 1 failure(s)" in subject
    assert "T-2 2026-01-05 omega/noise: zeta/epsilon 7.50 (critical)" in body
    assert "T-3: asset 'T-3', file f, row 9: NaN" in body
    subject, body = compose_message("nightly", None, "Crashed", "killed")
    assert "crashed" in subject and "killed" in body
    # an asset left unmonitored for a reason that fails the run is said, one that did not
    # operate (nothing to monitor) is not
    calm = {"alerts": [], "assets": [{"asset_id": "T-4", "status": "not operating"}]}
    assert compose_message("nightly", calm, "Completed", None) is None
    dormant = {"alerts": [], "assets": [
        {"asset_id": "T-4", "status": "not operating"},
        {"asset_id": "T-5", "status": "dormant", "note": "not operating for 9.0 days"},
        {"asset_id": "T-6", "status": "no baseline"}]}
    subject, body = compose_message("nightly", dormant, "Failed", "2 assets not monitored")
    assert subject == "fleet-health nightly: 0 alert(s), 0 failure(s), 2 not monitored"
    assert body.splitlines() == ["2 asset(s) not monitored:",
                                 "  T-5 (dormant): not operating for 9.0 days",
                                 "  T-6 (no baseline)"]


def test_notify_hook_sends_to_the_configured_block(tmp_path, monkeypatch):
    from prefect.blocks.core import Block

    from flows.hooks import notify_hook

    (tmp_path / "fleet.toml").write_text('''
[notifications]
block = "slack-webhook/fleet"
[classes.turbine]
model = "graybox.models:GasTurbineShaft"
assets = ["T-*"]
columns = { omega = "shaft_speed" }
''')
    sent = []

    class FakeBlock:
        def notify(self, body, subject=None):
            sent.append((subject, body))

    monkeypatch.setattr(Block, "load", classmethod(lambda cls, slug, **kw: FakeBlock()))
    summary = {"alerts": [], "assets": [{"asset_id": "T-3", "status": "failed",
                                         "error": {"message": "bad"}}]}
    state = SimpleNamespace(name="Failed", message="1 failed",
                            result=lambda raise_on_failure=False: summary)
    run = SimpleNamespace(parameters={"config_path": str(tmp_path / "fleet.toml")})
    notify_hook(SimpleNamespace(name="fleet-health-nightly"), run, state)
    assert len(sent) == 1 and "T-3: bad" in sent[0][1]
    # a broken notification never raises
    monkeypatch.setattr(Block, "load", classmethod(lambda cls, slug, **kw: 1 / 0))
    notify_hook(SimpleNamespace(name="fleet-health-nightly"), run, state)
