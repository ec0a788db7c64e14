"""benchmarks.dask_scale: the fleet.toml it writes, its cost model on known numbers, and
(slow) one small run end to end (SQLite, Prefect's temporary server, one Dask worker)."""
from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import pytest

from benchmarks.dask_scale import (cost_model, model_table, parse_args, projection, set_line,
                                   set_runner)
from flows.config import load_config, render_config

REPO = pathlib.Path(__file__).resolve().parents[2]


def test_the_runner_and_store_lines_of_a_rendered_config(tmp_path):
    config = tmp_path / "fleet.toml"
    config.write_text(render_config(batch_size=64))
    set_runner(config, 2)
    set_line(config, "batch_size", "4")
    set_line(config, "tracking_uri", '"postgresql+psycopg://postgres@127.0.0.1:5999/night"')
    loaded = load_config(config)
    assert loaded.nightly.task_runner == "dask" and loaded.nightly.batch_size == 4
    assert (loaded.dask.workers, loaded.dask.threads_per_worker) == (2, 1)
    assert loaded.tracking_uri.endswith("@127.0.0.1:5999/night")
    set_runner(config, None)                       # and back, with no [dask] left behind
    loaded = load_config(config)
    assert loaded.nightly.task_runner == "sequential"
    assert "\n[dask]\n" not in config.read_text()
    with pytest.raises(RuntimeError):
        set_line(config, "no_such_key", "1")


def _run(runner: str, wall: float, idle: bool = False, registry: float = 0.0,
         compute: float = 0.0) -> dict:
    stages = {"registry": {"wall": registry, "cpu": registry},
              "residual": {"wall": compute, "cpu": compute}}
    return {"runner": runner, "wall": wall, "idle": idle, "stages": stages,
            "batch_wall": registry + compute, "user": 1.0, "system": 0.0, "load": [0.5]}


def test_the_cost_model_on_known_numbers():
    # 8 assets in 4 batches: per asset 1.5 s of compute and 0.5 s of registry; a sequential
    # night of 30 s and an idle one of 10 s leave 1 s per batch
    runs = [_run("sequential", 30.0, registry=4.0, compute=12.0), _run("sequential", 10.0, True),
            _run("dask-1", 40.0, registry=4.0, compute=12.0), _run("dask-1", 18.0, True),
            _run("dask-2", 28.0, registry=4.0, compute=12.0), _run("dask-2", 19.0, True)]
    model = cost_model({"assets": 8, "batch_size": 2, "runs": runs})
    assert model["compute_per_asset"] == pytest.approx(1.5)
    assert model["registry_per_asset"] == pytest.approx(0.5)
    assert (model["fixed"], model["per_batch"]) == (pytest.approx(10.0), pytest.approx(1.0))
    assert model["worker_start"] == {1: pytest.approx(8.0), 2: pytest.approx(9.0)}
    # 10 + 8 + 20 / 1 and 10 + 9 + 20 / 2
    assert model["check"][1] == {"predicted": pytest.approx(38.0), "measured": 40.0}
    assert model["check"][2] == {"predicted": pytest.approx(29.0), "measured": 28.0}
    assert "| 2 | 29.0 | 28.0 | 0.97 |" in model_table(model)
    # 10,000 assets in 5,000 batches: 20,000 s of assets and 5,000 s of batches over 10
    # machines, after the start-up and one worker's start
    assert projection(model, 10_000, 10) == pytest.approx(10 + 8 + 2500)
    # a PostgreSQL server spending 0.5 s of CPU per asset on its one core is the bound
    assert projection({**model, "postgres_cpu_per_asset": 0.5}, 10_000, 100) == \
        pytest.approx(10 + 8 + 5000)
    # without the sequential runner's idle run there is no model
    assert cost_model({"assets": 8, "batch_size": 2, "runs": runs[2:]}) is None


def test_options():
    args = parse_args(["--family", "hydraulic_level", "--mlflow-postgres", "--workers", "1,2"])
    assert (args.family, args.mlflow_postgres, args.workers) == ("hydraulic_level", True, [1, 2])
    with pytest.raises(SystemExit):
        parse_args(["--family", "no_such_plant"])


@pytest.mark.slow
def test_one_small_run_end_to_end(tmp_path):
    """One gas-turbine asset at 60-s samples: baseline, then the sequential and the
    one-worker night (the idle runs and the cost model they feed are checked on known numbers
    above: each run here is a child process, all of them on one Prefect server the benchmark
    starts; each child's own temporary server is benchmarks.nightly_scale's smoke run)."""
    out = tmp_path / "runs.json"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    done = subprocess.run([sys.executable, "-m", "benchmarks.dask_scale", "--assets", "1",
                           "--batch-size", "1", "--workers", "1", "--repeats", "1",
                           "--sample-interval", "60", "--prefect-server",
                           "--workdir", str(tmp_path / "work"),
                           "--json", str(out)],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(out.read_text())
    assert [r["runner"] for r in result["runs"]] == ["sequential", "dask-1"]
    assert all(r["windows"] == 1 and not r.get("idle") for r in result["runs"])
    assert result.get("model") is None                       # it needs the idle runs
    assert result["prefect"] == "server on sqlite"
    assert all(r["prefect_cpu"] > 0 for r in result["runs"])  # the runs used that server
    assert "| dask-1 | 1 |" in done.stdout
