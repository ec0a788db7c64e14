"""What the flow tests read back from a store: record counts and the committed state."""
from __future__ import annotations

from flowtest_fleet import ASSETS


def count_records(registry) -> dict:
    """Active runs, model versions and registry alerts of a store."""
    client = registry.backend.client
    experiments = registry.backend.experiment_ids()
    runs = (list(registry.backend.paged(client.search_runs, experiments, ""))
            if experiments else [])
    versions = list(registry.backend.paged(client.search_model_versions, ""))
    return {"runs": len(runs), "versions": len(versions), "alerts": len(registry.alerts())}


def committed_state(registry, assets=ASSETS) -> dict:
    """Everything a run commits: watermarks, baseline aliases, and the alerts."""
    # each baseline loaded (and its artifacts verified) once: a load reads its files
    baselines = {a: registry.baseline(a) for a in assets}
    return {"watermarks": {a: registry.watermark(a) for a in assets},
            "baselines": {a: (b.version if b else None) for a, b in baselines.items()},
            "alerts": sorted((a.asset_id, a.window_start, a.channel, a.tier)
                             for a in registry.alerts())}
