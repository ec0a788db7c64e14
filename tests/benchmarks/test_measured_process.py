"""A benchmark told to stop runs its ``finally`` blocks (where it stops its servers)."""
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

CHILD = """
import pathlib, sys, time
from benchmarks.measured_process import stop_on_signals
stop_on_signals()
mark = pathlib.Path(sys.argv[1])
try:
    mark.write_text("started")
    time.sleep(60)
finally:
    mark.write_text("stopped")
"""


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_ends_the_benchmark_through_its_finally(tmp_path, signum):
    mark = tmp_path / "mark"
    root = pathlib.Path(__file__).resolve().parents[2]
    # SIGINT ignored, as a shell hands it to a job started in the background
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(mark)], cwd=root,
                             env={"PYTHONPATH": str(root), "PATH": ""},
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    deadline = time.monotonic() + 60
    while not (mark.exists() and mark.read_text() == "started"):
        assert child.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    child.send_signal(signum)
    child.wait(timeout=60)
    assert mark.read_text() == "stopped"
    assert child.returncode != 0


def test_orphans_are_reaped_and_earlier_children_left_alone():
    # a child that exits at once and leaves a grandchild behind, beside a long-lived child of
    # this process (a test's database server): only the grandchild is waited for and reaped
    from benchmarks.measured_process import become_subreaper, children_of, reap_orphans

    if not become_subreaper():
        pytest.skip("no PR_SET_CHILD_SUBREAPER here")
    server = subprocess.Popen(["sleep", "60"])
    try:
        earlier = children_of(os.getpid())
        assert server.pid in earlier
        parent = subprocess.Popen([sys.executable, "-c",
                                   "import subprocess; subprocess.Popen(['sleep', '0.3'])"])
        parent.wait(timeout=60)
        start = time.monotonic()
        reaped = reap_orphans(earlier, timeout=30.0)
        assert len(reaped) == 1
        assert time.monotonic() - start < 30.0          # did not wait for the server
        assert server.poll() is None                     # neither reaped nor stopped
    finally:
        server.kill()
        server.wait()
