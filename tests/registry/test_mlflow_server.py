"""The same registry against a real ``mlflow server`` process on loopback."""
from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request

import pandas as pd
import pytest
from mlflow_loading import load_by_models_uri

from registry import Registry

pytestmark = pytest.mark.slow


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture(scope="module")
def server(tmp_path_factory, template_db):
    root = tmp_path_factory.mktemp("mlflow-server")
    shutil.copy(template_db, root / "mlflow.db")     # schema already created: faster start
    port = _free_port()
    log = open(root / "server.log", "w")
    process = subprocess.Popen(
        [sys.executable, "-m", "mlflow", "server",
         "--backend-store-uri", f"sqlite:///{root}/mlflow.db",
         "--artifacts-destination", str(root / "artifacts"),
         "--host", "127.0.0.1", "--port", str(port), "--workers", "1"],
        stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
        # the registry runs no server jobs: without them no huey consumers start (eight
        # processes, each importing MLflow: about 25 s of CPU)
        env=dict(os.environ, MLFLOW_SERVER_ENABLE_JOB_EXECUTION="false"))
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 120
        while True:
            if process.poll() is not None:
                log.flush()
                pytest.fail("mlflow server exited:\n" + (root / "server.log").read_text()[-3000:])
            try:
                with urllib.request.urlopen(url + "/health", timeout=2) as response:
                    if response.status == 200:
                        break
            except OSError:
                pass
            if time.monotonic() > deadline:
                pytest.fail("mlflow server did not answer /health within 120 s:\n"
                            + (root / "server.log").read_text()[-3000:])
            time.sleep(0.5)
        yield url
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGTERM)
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait(timeout=10)
        log.close()


def test_record_promote_load_round_trip_through_a_server(server, fits, monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))   # the host-local locks
    registry = Registry(server, user="tester")
    assert registry.tracking_uri == server
    record = registry.record_fit("S-01", "turbine", fits.baseline, role="baseline",
                                 calibration=fits.calibration, window=fits.days)
    assert record.created and record.version == 1
    again = registry.record_fit("S-01", "turbine", fits.baseline, role="baseline",
                                calibration=fits.calibration, window=fits.days)
    assert not again.created and again.version == 1
    registry.promote("S-01", reason="initial baseline")
    loaded = registry.baseline("S-01")
    assert loaded.signature == fits.baseline and loaded.calibration == fits.calibration
    night = registry.record_fit("S-01", "turbine", fits.candidate, role="candidate",
                                drift=fits.alarmed, window=fits.night)
    assert night.version == 2 and night.alarm
    assert registry.commit_watermark("S-01", night.window_end) == pd.Timestamp(night.window_end)
    assert registry.watermark("S-01") == pd.Timestamp(night.window_end)
    assert {a.asset_id for a in registry.alerts()} == {"S-01"}
    assert {a.version for a in registry.alerts()} == {night.version}
    assert len(registry.zeta_history("S-01")) == 4          # one channel, four tiers
    plots = {a.path for a in registry.backend.client.list_artifacts(night.run_id, "plots")}
    assert {"plots/residual_acf.png", "plots/tier_fits.png", "plots/zeta_trend.png"} <= plots
    model = load_by_models_uri(server, "models:/fleet-health.S-01@baseline")
    result = model.predict(fits.night)
    expected = {(e.channel, e.tier): e.zeta for e in fits.drift.entries}
    assert {(r.channel, r.tier): r.zeta for r in result.itertuples()} == pytest.approx(expected)
    assert [s.asset_id for s in registry.list_baselines()] == ["S-01"]
