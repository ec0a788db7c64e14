"""Faults injected into Dask worker processes (a worker plugin: the test's own monkeypatch
cannot reach another process)."""
from __future__ import annotations

from distributed.diagnostics.plugin import WorkerPlugin


class BrokenWatermarks(WorkerPlugin):
    """In every worker, ``Registry.commit_watermarks`` (a group's watermarks) raises
    ConnectionError ("registry unreachable", a transient error) when the group holds an
    asset of ``always``, or one of ``once`` on its first call in that worker."""

    def __init__(self, always: tuple[str, ...] = (), once: tuple[str, ...] = ()):
        self.always, self.once = tuple(always), tuple(once)

    def setup(self, worker) -> None:
        from registry.registry import Registry

        self.original = original = Registry.commit_watermarks
        failed_once: set[str] = set()
        always, once = self.always, self.once

        def commit_watermarks(registry, ends):
            broken = [a for a in ends if a in always or (a in once and a not in failed_once)]
            if broken:
                failed_once.update(broken)
                raise ConnectionError("registry unreachable")
            return original(registry, ends)

        Registry.commit_watermarks = commit_watermarks

    def teardown(self, worker) -> None:
        from registry.registry import Registry

        Registry.commit_watermarks = self.original
