"""Run one baseline batch in a fresh process and print its peak anonymous resident size.

Usage: memory_worker.py TELEMETRY WORKDIR BUDGET_ABOVE_START_MB ASSET...

Fits the assets' baselines (days 2026-01-01 .. 03) in one batch with ``[nightly]
memory_budget`` set to the process's resident size after start-up plus the given megabytes,
and prints one JSON line: the anonymous resident size at the start and its peak during the
batch (sampled every 2 ms from /proc: file-backed pages such as shared libraries faulted in
are reclaimable and vary with the machine's page cache; the data and fits are anonymous),
the budget and the groups fitted. The telemetry is made by the caller, so that its making
does not count here.
"""
import json
import pathlib
import sys
import threading

import flows.pipeline
from flows.baseline import plan_baseline_batch
from flows.config import load_config
from flows.discovery import AssetRef
from flows.memory import resident_bytes


def anonymous_bytes() -> int:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("RssAnon:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no RssAnon in /proc/self/status")


class PeakSampler(threading.Thread):
    """The largest anonymous resident size seen while running."""

    def __init__(self):
        super().__init__(daemon=True)
        self.peak, self.done = anonymous_bytes(), threading.Event()

    def run(self):
        while not self.done.wait(0.002):
            self.peak = max(self.peak, anonymous_bytes())


def main(telemetry: str, workdir: str, above_mb: str, *assets: str) -> int:
    work = pathlib.Path(workdir)
    work.mkdir(parents=True)
    config_text = f'''
[telemetry]
root = "{telemetry}"
[mlflow]
tracking_uri = "sqlite:///{work / 'mlflow.db'}"
[nightly]
plots = "none"
memory_budget = {{budget}}
[classes.turbine]
model = "graybox.models:GasTurbineShaft"
assets = ["T-*"]
columns = {{{{ omega = "shaft_speed" }}}}
# the trained need test (PyTorch, batched over the group's assets): the workload whose
# memory grows with the group, as every default fit's did before issue 18
settings = {{{{ needed_network = "trained" }}}}
'''
    # start-up, not the batch's working memory: imports, torch, the store's creation
    import torch  # noqa: F401
    (work / "fleet.toml").write_text(config_text.format(budget=10 ** 12))
    load_config(work / "fleet.toml").registry().watermark(assets[0])

    start, start_anonymous = resident_bytes(), anonymous_bytes()
    budget = start + int(float(above_mb) * 2 ** 20)
    (work / "fleet.toml").write_text(config_text.format(budget=budget))
    config = load_config(work / "fleet.toml")
    groups = []
    original = flows.pipeline.memory_groups

    def counting(*args, **kwargs):
        for group in original(*args, **kwargs):
            groups.append(len(group))
            yield group

    flows.pipeline.memory_groups = counting
    refs = [AssetRef(asset, "turbine") for asset in assets]
    sampler = PeakSampler()
    sampler.start()
    results = flows.pipeline.execute(
        config, plan_baseline_batch(config, refs, "2026-01-01", "2026-01-04"))
    sampler.done.set()
    sampler.join()
    print(json.dumps({"start": start_anonymous, "peak": sampler.peak,
                      "above": budget - start, "groups": groups,
                      "statuses": [r.status for r in results]}))
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
