"""Run one baseline batch in a fresh process and print its peak resident size.

Usage: memory_worker.py TELEMETRY WORKDIR BUDGET_ABOVE_START_MB ASSET...

Fits the assets' baselines (days 2026-01-01 .. 03) in one batch with ``[nightly]
memory_budget`` set to the process's resident size after start-up plus the given megabytes,
and prints one JSON line: start and peak resident bytes, the budget, the groups fitted. The
telemetry is made by the caller, so that its making does not count in this process's peak.
"""
import json
import pathlib
import sys

import flows.baseline
from flows.baseline import process_baseline_batch
from flows.config import load_config
from flows.fleet import AssetRef
from flows.memory import peak_resident_bytes, resident_bytes


def main(telemetry: str, workdir: str, above_mb: str, *assets: str) -> int:
    work = pathlib.Path(workdir)
    work.mkdir(parents=True)
    import torch  # noqa: F401 - part of start-up, not of the batch's working memory

    start = resident_bytes()
    budget = start + int(float(above_mb) * 2 ** 20)
    (work / "fleet.toml").write_text(f'''
[telemetry]
root = "{telemetry}"
[mlflow]
tracking_uri = "sqlite:///{work / 'mlflow.db'}"
[nightly]
plots = "none"
memory_budget = {budget}
[classes.turbine]
model = "graybox.models:GasTurbineShaft"
assets = ["T-*"]
columns = {{ omega = "shaft_speed" }}
''')
    config = load_config(work / "fleet.toml")
    groups = []
    original = flows.baseline.memory_groups

    def counting(*args, **kwargs):
        for group in original(*args, **kwargs):
            groups.append(len(group))
            yield group

    flows.baseline.memory_groups = counting
    refs = [AssetRef(asset, "turbine") for asset in assets]
    results = process_baseline_batch(config, refs, "2026-01-01", "2026-01-04")
    print(json.dumps({"start": start, "peak": peak_resident_bytes(), "budget": budget,
                      "groups": groups, "statuses": [r.status for r in results]}))
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
