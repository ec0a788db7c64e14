import io
import logging

from flows import progress
from flows.progress import LineReporter


def test_progress_lines_count_failures_beside_the_done():
    stream = io.StringIO()
    with progress.reporting(LineReporter(stream)):
        progress.start("baseline fits", 3)
        progress.advance(1, "PX-01 ok")
        progress.advance(1, "PX-02 failed", failed=1)
        progress.advance(1, "PX-03 failed", failed=1)
    lines = stream.getvalue().splitlines()
    assert lines == ["baseline fits: 3 to do",
                     "baseline fits: 1/3 done (PX-01 ok)",
                     "baseline fits: 2/3 done, 1 failed (PX-02 failed)",
                     "baseline fits: 3/3 done, 2 failed (PX-03 failed)"]


def test_all_failed_never_reads_as_all_done_well():
    stream = io.StringIO()
    with progress.reporting(LineReporter(stream)):
        progress.start("baseline fits", 2)
        progress.advance(1, "A failed", failed=1)
        progress.advance(1, "B failed", failed=1)
    assert stream.getvalue().splitlines()[-1] == "baseline fits: 2/2 done, 2 failed (B failed)"


def _count_to_twenty() -> None:
    progress.start("demo", 20)
    for n in range(1, 21):
        failed = n == 7
        progress.advance(1, f"A-{n} {'FAILED' if failed else 'ok'}", failed=int(failed))
    progress.note("done here")


#: what the default reporter logs of twenty items, the seventh failed: the count each tenth of
#: the work (every 2 items) and every failure at once
TWENTY_LOGGED = ["demo: 20 to do", "demo: 2/20 done (A-2 ok)", "demo: 4/20 done (A-4 ok)",
                 "demo: 6/20 done (A-6 ok)", "demo: 7/20 done, 1 failed (A-7 FAILED)",
                 "demo: 9/20 done, 1 failed (A-9 ok)", "demo: 11/20 done, 1 failed (A-11 ok)",
                 "demo: 13/20 done, 1 failed (A-13 ok)", "demo: 15/20 done, 1 failed (A-15 ok)",
                 "demo: 17/20 done, 1 failed (A-17 ok)", "demo: 19/20 done, 1 failed (A-19 ok)",
                 "demo: 20/20 done, 1 failed (A-20 ok)", "done here"]


def test_the_default_reporter_logs_each_tenth_and_every_failure(caplog):
    caplog.set_level(logging.INFO, logger="flows.progress")
    with progress.reporting(progress.Reporter()):
        _count_to_twenty()
    records = [r for r in caplog.records if r.name == "flows.progress"]
    assert [r.getMessage() for r in records] == TWENTY_LOGGED
    assert [r.levelname for r in records].count("WARNING") == 1


def test_a_served_run_shows_its_progress_on_the_runs_own_log(harness):
    """A deployment's flow run has no terminal: its progress goes to the run's log, which
    Prefect's UI shows on the run's page (read back here from the server)."""
    import asyncio

    from prefect import flow, get_client
    from prefect.client.schemas.filters import LogFilter, LogFilterFlowRunId
    from prefect.client.schemas.sorting import LogSort
    from prefect.logging.handlers import APILogHandler

    @flow
    def counting():
        _count_to_twenty()

    state = counting(return_state=True)

    async def logs():
        await APILogHandler.aflush()
        async with get_client() as client:
            found = await client.read_logs(
                log_filter=LogFilter(flow_run_id=LogFilterFlowRunId(
                    any_=[state.state_details.flow_run_id])), sort=LogSort.TIMESTAMP_ASC)
        return [log.message for log in found]

    messages = asyncio.run(logs())
    assert [m for m in messages if m.startswith(("demo", "done here"))] == TWENTY_LOGGED
