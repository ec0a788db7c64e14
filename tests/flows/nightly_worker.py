"""A nightly batch run as a plain process, as a worker on another host runs it (a script of
``test_postgres_flows.py``, not collected).

Usage: nightly_worker.py CONFIG AS_OF GO_FILE ASSET...

Imports everything, prints ``ready``, waits until GO_FILE exists (so that several workers
start together), processes the assets as one batch (a nightly
:class:`flows.batch_job.BatchJob`, as the batch task runs it) and prints the batch output as
JSON.
"""
from __future__ import annotations

import json
import pathlib
import sys
import time

from flows.batch_job import BatchJob


def main(config_path: str, as_of: str, go: pathlib.Path, assets: list[str]) -> int:
    from flows.config import load_config
    from flows.discovery import discover

    refs = [{"asset_id": r.asset_id, "vehicle_class": r.vehicle_class}
            for r in discover(load_config(config_path), assets).assets]
    print("ready", flush=True)
    deadline = time.monotonic() + 300
    while not go.exists():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{go} never appeared")
        time.sleep(0.01)
    job = BatchJob.from_dict({"flow": "nightly", "config_path": config_path, "refs": refs,
                              "options": {"as_of": as_of}})
    print(json.dumps(job.run().to_dict()))
    return 0


if __name__ == "__main__":
    config_path, as_of, go, *assets = sys.argv[1:]
    sys.exit(main(config_path, as_of, pathlib.Path(go), assets))
