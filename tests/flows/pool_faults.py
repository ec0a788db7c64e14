"""Faults injected into a compute pool's workers (the test's own monkeypatch cannot reach
another process): chunk functions the pool runs instead of
:func:`flows.pooled_execute.compute_chunk`."""
from __future__ import annotations

import os

from flows.pooled_execute import compute_chunk

#: the asset whose worker dies (its process exits at once, as if killed)
DOOMED = "T-003"


def chunk_or_die(job: dict, processes: int):
    """:func:`~flows.pooled_execute.compute_chunk`, except that a worker given
    :data:`DOOMED` dies."""
    if any(ref["asset_id"] == DOOMED for ref in job["refs"]):
        os._exit(3)
    return compute_chunk(job, processes)
