import io

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
