"""Whether the store can be read and written: what ``fleet-health check`` asks of it.

The write probe leaves nothing of the fleet's records changed: a run of its own
experiment (:data:`registry.store.naming.PROBE_EXPERIMENT`) gets a tag and a small artifact, both
are read back, and the run is deleted.
"""
from __future__ import annotations

import pathlib
import tempfile

from registry.store import naming
from registry.store.backend import Backend

PROBE_TAG = "fleet-health.check"
PROBE_TEXT = "fleet-health check\n"


def probe_read(backend: Backend) -> None:
    """Read the store once: the list of the fleet's experiments (the store's error if it
    cannot)."""
    backend.experiment_ids()


def probe_write(backend: Backend) -> str:
    """A probe run in :data:`registry.store.naming.PROBE_EXPERIMENT`: a tag and an artifact
    written, read back, then the run deleted; returns the experiment's name.

    Raises
    ------
    OSError
        If the tag or the artifact read back differs from what was written.
    """
    client = backend.client
    name = naming.PROBE_EXPERIMENT
    experiment = client.get_experiment_by_name(name)
    experiment_id = (experiment.experiment_id if experiment is not None else
                     client.create_experiment(
                         name, artifact_location=backend.store.experiment_artifact_location(name)))
    run = client.create_run(experiment_id, run_name="fleet-health check probe")
    try:
        client.set_tag(run.info.run_id, PROBE_TAG, "probe")
        with tempfile.TemporaryDirectory(prefix="fleet-health-check-") as scratch:
            probe = pathlib.Path(scratch) / "probe.txt"
            probe.write_text(PROBE_TEXT)
            client.log_artifact(run.info.run_id, str(probe))
            back = client.download_artifacts(run.info.run_id, "probe.txt", scratch + "/back")
            if pathlib.Path(back).read_text() != PROBE_TEXT:
                raise OSError(f"the probe artifact read back differs ({back})")
        if client.get_run(run.info.run_id).data.tags.get(PROBE_TAG) != "probe":
            raise OSError("the probe run's tag did not read back")
    finally:
        client.set_terminated(run.info.run_id)
        client.delete_run(run.info.run_id)
    return name
