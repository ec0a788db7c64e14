"""A zoo family exported for ``fleet-health``: its fleet.toml is the product's own (parsed by
the flows' loader, every asset in the family's class with its white box, columns and grid),
its telemetry reads back through the store layout, and a faulty asset is its vehicle up to
the onset."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import graybox as gb
from benchmarks.zoo.export import export_fleet, main
from benchmarks.zoo.families import discover
from flows.config import load_config

ROOM = discover()["thermal_room"]


def test_an_exported_family_is_a_fleet_the_product_reads_with_its_defaults(tmp_path):
    written = export_fleet(ROOM, tmp_path, assets=2, baseline_days=2, nights=1,
                           faults=(("sensor_bias", "large"),), seed=4)
    assert written["baseline"] == ("2026-01-05", "2026-01-07")
    assert written["as_of"] == "2026-01-08"
    config = load_config(written["config"])
    assert config.telemetry_root == tmp_path / "telemetry"
    assert config.tracking_uri.endswith("mlflow.db")
    vehicle = config.classes["thermal_room"]
    assert vehicle.model == ROOM.spec and dict(vehicle.columns) == dict(ROOM.columns)
    assert vehicle.grid == gb.GridPolicy(**dict(ROOM.grid))
    assert len(written["assets"]) == 3
    faulty = next(a for a in written["assets"] if a.endswith("-sensor_bias-large"))
    assert all(config.class_of(asset) is vehicle for asset in written["assets"])

    model = gb.load_model(vehicle.model, dict(vehicle.parameters), dict(vehicle.columns))
    day = pd.Timestamp("2026-01-05", tz="UTC")
    own, twin = (gb.read_window(config.telemetry_root, asset, model.required_columns, day,
                                day + pd.Timedelta(days=3), policy=vehicle.grid,
                                inputs=model.input_columns)
                 for asset in (faulty, faulty.rsplit("-", 2)[0]))
    night = pd.Timestamp("2026-01-07", tz="UTC")
    before = own.frame.index < night
    pd.testing.assert_frame_equal(own.frame[before], twin.frame[before])
    # the bias is on the room's air sensor from an onset inside the night
    after = own.frame.index >= night + pd.Timedelta(hours=20)
    assert not np.allclose(own.frame["air_temp"][after], twin.frame["air_temp"][after])


def test_an_unknown_fault_is_a_usage_error_naming_the_family_s_faults(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--family", "thermal_room", "--out", str(tmp_path), "--fault", "rust:large"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "thermal_room has no fault ['rust']" in err and "sensor_bias" in err
    assert not (tmp_path / "fleet.toml").exists()
