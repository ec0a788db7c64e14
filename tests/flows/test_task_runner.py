"""How many assets a batch gets: ``[nightly] batch_size``, or fewer so that every task slot
of a cluster has several batches."""
from flows.config.settings import DaskSettings
from flows.task_runner import (BATCHES_PER_SLOT, DaskBatches, SequentialBatches,
                               batch_size_for)
from flows.discovery import batches


def test_one_slot_keeps_the_configured_batch_size():
    assert SequentialBatches.slots == 1
    assert batch_size_for(96, 64, 1) == 64
    assert [len(b) for b in batches(list(range(96)), batch_size_for(96, 64, 1))] == [64, 32]


def test_each_slot_of_a_cluster_gets_several_batches():
    assert BATCHES_PER_SLOT == 4
    # two workers: 96 assets at 64 were 64 + 32, so the night lasted 64 assets' time; now
    # eight batches of 12, four for each worker
    size = batch_size_for(96, 64, 2)
    assert size == 12
    assert [len(b) for b in batches(list(range(96)), size)] == [12] * 8
    # a fleet large enough keeps batch_size; a small one never goes below one asset
    assert batch_size_for(1000, 64, 2) == 64
    assert batch_size_for(97, 64, 2) == 13
    assert batch_size_for(3, 64, 4) == 1
    assert batch_size_for(0, 64, 4) == 1


def test_a_local_cluster_has_workers_times_threads_slots_and_a_remote_one_keeps_batch_size():
    assert DaskBatches(DaskSettings(workers=3, threads_per_worker=2)).slots == 6
    assert DaskBatches(DaskSettings(workers=None)).slots >= 1
    assert DaskBatches(DaskSettings(address="tcp://s:8786", workers=8)).slots == 1
