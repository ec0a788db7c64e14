"""Faults injected into Dask worker processes (a worker plugin: the test's own monkeypatch
cannot reach another process)."""
from __future__ import annotations

from distributed.diagnostics.plugin import WorkerPlugin


class BrokenWatermarks(WorkerPlugin):
    """In every worker, ``Registry.commit_watermark`` raises ConnectionError ("registry
    unreachable", a transient error) for the assets of ``always``, and only on its first
    call in that worker for the assets of ``once``."""

    def __init__(self, always: tuple[str, ...] = (), once: tuple[str, ...] = ()):
        self.always, self.once = tuple(always), tuple(once)

    def setup(self, worker) -> None:
        from registry.registry import Registry

        self.original = original = Registry.commit_watermark
        failed_once: set[str] = set()
        always, once = self.always, self.once

        def commit_watermark(registry, asset_id, end):
            if asset_id in always or (asset_id in once and asset_id not in failed_once):
                failed_once.add(asset_id)
                raise ConnectionError("registry unreachable")
            return original(registry, asset_id, end)

        Registry.commit_watermark = commit_watermark

    def teardown(self, worker) -> None:
        from registry.registry import Registry

        Registry.commit_watermark = self.original
