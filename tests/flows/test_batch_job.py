"""A batch job: what the one batch task of every flow is given, and the names its runs bear."""
from __future__ import annotations

import json

import pytest

from flows.batch_job import BATCH_FLOWS, BatchJob
from flows.batching import batch_task
from flows.config import load_config
from flows.discovery import AssetRef

FLEET = '''
[classes.turbine]
model = "graybox.models:GasTurbineShaft"
assets = ["T-*"]
columns = { omega = "shaft_speed" }
'''


def test_a_job_travels_as_json_and_comes_back_equal(tmp_path):
    (tmp_path / "fleet.toml").write_text(FLEET)
    config = load_config(tmp_path / "fleet.toml")
    job = BatchJob.for_fleet("baseline", config, None, start="2026-01-01T00:00:00+00:00",
                             end="2026-01-04T00:00:00+00:00", promote=True, reason="healthy")
    # absolute locations: a worker may run elsewhere; the store only when overridden
    assert job.config_path == str(config.path) and job.tracking_uri is None
    assert BatchJob.for_fleet("nightly", config, "x", as_of="2026-01-05").tracking_uri == \
        config.tracking_uri
    batch = job.for_batch([AssetRef("T-001", "turbine"), AssetRef("T-002", "turbine")])
    again = BatchJob.from_dict(json.loads(json.dumps(batch.to_dict())))
    assert again == batch and again.refs[1] == AssetRef("T-002", "turbine")
    assert job.refs == () and again.options["promote"] is True


def test_an_unknown_flow_is_refused(tmp_path):
    (tmp_path / "fleet.toml").write_text(FLEET)
    with pytest.raises(ValueError, match="no batch flow 'nighty'"):
        BatchJob.for_fleet("nighty", load_config(tmp_path / "fleet.toml"), None)


@pytest.mark.parametrize("flow, task_name, run_name", [
    ("nightly", "nightly-batch", "nightly {label}"),
    ("baseline", "baseline-batch", "baseline {label}"),
    ("reanalysis", "reanalysis-batch", "reanalyze {label}"),
])
def test_each_flow_names_its_batch_task_and_plans_its_batches(flow, task_name, run_name):
    task = batch_task(flow)
    assert (task.name, task.task_run_name) == (task_name, run_name)
    assert task.__name__ == f"{flow}_batch"     # Dask's task keys start with it
    assert callable(BatchJob(flow, "fleet.toml").planner())
    assert set(BATCH_FLOWS) == {"nightly", "baseline", "reanalysis"}
