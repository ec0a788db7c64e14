"""A white box whose prediction diverges (a wrong sign) through the command line: its assets
end with an error naming the model and what to check, exit 1, nothing is recorded as their
baseline, and the other class's assets are baselined as if it were not there."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd

from flowtest_config import config_text
from plant_telemetry import PUMPS, pump_period

START = pd.Timestamp("2026-05-01", tz="UTC")
LAGS = '''[classes.lag]
model = "contract_models:WrongSign"
assets = ["L-*"]'''


def _lag_days(days: int, dt: float, rng) -> pd.DataFrame:
    n = int(days * 86_400 / dt)
    u = 10 + np.cumsum(rng.normal(0, 0.05, n))
    return pd.DataFrame({"timestamp": START + pd.to_timedelta(np.arange(n) * dt, unit="s"),
                         "x": u + rng.normal(0, 0.1, n), "u": u})


def test_a_diverging_white_box_fails_its_assets_loudly_and_no_other(harness, tmp_path, capsys):
    from flows.cli import main
    from graybox.models import PumpLoop
    from graybox.telemetry import write_telemetry

    root = tmp_path / "telemetry"
    rng = np.random.default_rng(11)
    write_telemetry(root, "P-001", pd.concat(
        [pump_period(PumpLoop(), START + pd.Timedelta(days=k), 86_400.0, 5.0, rng)
         for k in range(3)], ignore_index=True))
    write_telemetry(root, "L-001", _lag_days(3, 5.0, rng))
    config = tmp_path / "fleet.toml"
    config.write_text(config_text(root, tmp_path / "mlflow.db", retries=0,
                                  classes=PUMPS + "\n" + LAGS))
    status = main(["--config", str(config), "baseline", "fit", "--all", "--start", START.isoformat(),
                   "--end", (START + pd.Timedelta(days=3)).isoformat(), "--promote",
                   "--reason", "first baselines", "--json"])
    out = capsys.readouterr()
    assert status == 1, out.err
    assets = {a["asset_id"]: a for a in json.loads(out.out)["assets"]}
    assert assets["P-001"]["status"] == "ok"
    assert assets["L-001"]["status"] != "ok"
    message = json.dumps(assets["L-001"])
    assert "WrongSign" in message and "'x'" in message and "signs" in message

    status = main(["--config", str(config), "baseline", "list", "--json"])
    out = capsys.readouterr()
    listed = json.loads(out.out)
    assert "P-001" in json.dumps(listed) and "L-001" not in json.dumps(listed)
