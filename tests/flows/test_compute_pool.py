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


@pytest.mark.parametrize("processes, assets, fleet, started", [
    (2, None, 2, True),                  # the whole fleet, a pool of 2
    (2, ["T-001", "T-002"], 2, True),    # two named assets
    (2, ["T-001"], 2, False),            # one named asset: no pool
    (1, None, 2, False),                 # no pool configured
    ("auto", None, 64, True),            # the default: a fleet of 64 on two cores
    ("auto", None, 63, False),           # one asset fewer: no pool
    ("auto", ["T-001", "T-002"], 64, False),   # two of the 64 named
])
def test_a_command_starts_the_forkserver_only_where_its_run_has_a_pool(
        tmp_path, monkeypatch, processes, assets, fleet, started):
    import flows.compute_pool
    from flows.commands.plumbing import start_pool_early
    from flows.config import load_config

    from flowtest_config import write_config

    calls = []
    monkeypatch.setattr(flows.compute_pool, "start_forkserver", lambda: calls.append(1))
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    telemetry = tmp_path / "telemetry"
    for number in range(1, fleet + 1):
        (telemetry / f"asset_id=T-{number:03d}").mkdir(parents=True)
    config = load_config(write_config(tmp_path / "fleet.toml", telemetry, tmp_path / "m.db",
                                      processes=processes))
    start_pool_early(config, assets)
    assert calls == ([1] if started else [])
