"""The Prefect client against its own server: guards the fastapi pin (constraints.txt).

prefect 3.8.8's client sends explicit nulls in filter bodies (``limit: null``, ``sort: null``,
``artifacts: null``, ...) when a call gives no limit or filter. With fastapi 0.151 to 0.154
the server answers those with HTTP 422 (so ``prefect deploy --all`` stopped after the first
deployment and ``read_artifacts()`` failed); with fastapi>=0.155 the server does not start.
"""
from __future__ import annotations

import asyncio

import pytest


@pytest.fixture
def own_server(tmp_path, monkeypatch):
    """A Prefect test server of this test's own, with PREFECT_HOME in tmp_path."""
    import prefect.settings
    from prefect.testing.utilities import prefect_test_harness

    home = tmp_path / "prefect-home"
    home.mkdir()
    monkeypatch.setenv("PREFECT_HOME", str(home))
    monkeypatch.setenv("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
    with prefect.settings.temporary_settings(updates={
            prefect.settings.PREFECT_HOME: home,
            prefect.settings.PREFECT_SERVER_ANALYTICS_ENABLED: False}):
        with prefect_test_harness(server_startup_timeout=120):
            yield home


def test_client_reads_without_limits_and_lists_created_deployments(tmp_path, own_server):
    from prefect.client.orchestration import get_client

    from flows.config import load_config
    from flows.serve import build_deployments

    (tmp_path / "fleet.toml").write_text('''
[classes.turbine]
model = "graybox.models:GasTurbineShaft"
assets = ["T-*"]
columns = { omega = "shaft_speed" }
''')
    deployments = build_deployments(load_config(tmp_path / "fleet.toml"))
    assert {d.name for d in deployments} >= {"nightly", "baseline"}

    async def exercise():
        async with get_client() as client:
            # no limit, offset, sort or filter: the client sends them as null
            assert await client.read_artifacts() == []
            assert await client.read_deployments() == []
            ids = [await deployment.apply() for deployment in deployments]
            assert len(set(ids)) == len(deployments)
            listed = await client.read_deployments()
            flows = await client.read_flows()
            return ids, listed, flows

    ids, listed, flows = asyncio.run(exercise())
    assert len(listed) == len(deployments) >= 2
    assert {d.id for d in listed} == set(ids)
    assert {d.name for d in listed} == {d.name for d in deployments}
    assert {f.name for f in flows} >= {"fleet-health-nightly", "fleet-health-baseline"}
