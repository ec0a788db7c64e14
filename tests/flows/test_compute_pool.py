"""The compute pool's workers come from one forkserver, which a command starts early."""
from __future__ import annotations

import os

import pytest


def test_a_forkserver_started_early_is_the_one_the_pools_workers_fork_from():
    from multiprocessing import forkserver

    from flows.compute_pool import ComputePool, start_forkserver

    start_forkserver()
    server = forkserver._forkserver._forkserver_pid      # noqa: SLF001 - the known answer
    assert server is not None and server != os.getpid()
    start_forkserver()                                     # already running: the same server
    assert forkserver._forkserver._forkserver_pid == server   # noqa: SLF001
    with ComputePool(2) as pool:
        parents = {pool.submit(os.getppid).result(timeout=300) for _ in range(4)}
    assert parents == {server}


@pytest.mark.parametrize("processes, assets, started", [
    (2, None, True),                 # the whole fleet, a pool of 2
    (2, ["T-001", "T-002"], True),   # two named assets
    (2, ["T-001"], False),           # one named asset: no pool
    (1, None, False),                # no pool configured
])
def test_a_command_starts_the_forkserver_only_where_its_run_has_a_pool(
        tmp_path, monkeypatch, processes, assets, started):
    import flows.compute_pool
    from flows.commands.plumbing import start_pool_early
    from flows.config import load_config

    from flowtest_config import write_config

    calls = []
    monkeypatch.setattr(flows.compute_pool, "start_forkserver", lambda: calls.append(1))
    config = load_config(write_config(tmp_path / "fleet.toml", tmp_path, tmp_path / "m.db",
                                      processes=processes))
    start_pool_early(config, assets)
    assert calls == ([1] if started else [])
