"""The compute pool's workers come from one forkserver, which a command starts early."""
from __future__ import annotations

import os


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
