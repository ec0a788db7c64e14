"""A nightly batch run as a plain process, as a worker on another host runs it (a script of
``test_postgres_flows.py``, not collected).

Usage: nightly_worker.py CONFIG AS_OF START_AT ASSET...

Waits until the epoch time START_AT (so that several workers start together), processes the
assets as one batch (:func:`flows.nightly.process_batch`) and prints the batch output as JSON.
"""
from __future__ import annotations

import json
import sys
import time

from flows.batching import batch_task_body
from flows.nightly import process_batch


def main(config_path: str, as_of: str, start_at: float, assets: list[str]) -> int:
    from flows.config import load_config
    from flows.fleet import discover

    refs = [{"asset_id": r.asset_id, "vehicle_class": r.vehicle_class}
            for r in discover(load_config(config_path), assets).assets]
    time.sleep(max(0.0, start_at - time.time()))
    print(json.dumps(batch_task_body(process_batch, config_path, None, refs, as_of)))
    return 0


if __name__ == "__main__":
    config_path, as_of, start_at, *assets = sys.argv[1:]
    sys.exit(main(config_path, as_of, float(start_at), assets))
