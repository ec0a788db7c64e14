"""Run a command as a child process and measure it from outside: wall seconds, the kernel's
CPU accounting and peak resident size (``os.wait4``), the peak summed resident size of its
process tree (sampled from ``/proc``) and the 1-minute load average while it ran; and let a
benchmark that starts servers stop them when it is told to stop (:func:`stop_on_signals`).
"""
from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import time
from dataclasses import asdict, dataclass, field


SAMPLE_SECONDS = 0.25


@dataclass
class Measured:
    """One finished child process.

    Attributes
    ----------
    wall : float
        Seconds from start to reaping.
    user, system : float
        CPU seconds of the child and its descendants (``wait4``): those it waited for, and
        those it left behind (a ``forkserver``, and through it the workers it forked,
        outlive the child for a moment: this process is their subreaper, reaps them and
        counts them).
    max_rss : int
        Bytes: the largest resident size of any single process among those (``ru_maxrss``).
    tree_rss : int
        Bytes: the largest sum of resident sizes of the child's process tree, sampled every
        :data:`SAMPLE_SECONDS` (0 where ``/proc`` is missing).
    load : list of float
        1-minute load averages sampled while it ran.
    """

    command: list[str]
    returncode: int
    wall: float
    user: float
    system: float
    max_rss: int
    tree_rss: int
    load: list[float] = field(default_factory=list)
    stdout: str = ""
    stderr_tail: str = ""

    @property
    def cpu(self) -> float:
        return self.user + self.system

    def to_dict(self) -> dict:
        return asdict(self)


def run_measured(command: list[str], cwd, env: dict, log_dir, name: str) -> Measured:
    """Run ``command`` to completion; its output goes to ``log_dir/<name>.out`` and ``.err``
    (stdout is returned too, and stderr's last 3,000 characters)."""
    log_dir = pathlib.Path(log_dir)
    log_dir.mkdir(parents=True, exist_ok=True)
    out_path, err_path = log_dir / f"{name}.out", log_dir / f"{name}.err"
    load, tree_peak = [], 0
    with open(out_path, "w") as out, open(err_path, "w") as err:
        become_subreaper()
        earlier_children = children_of(os.getpid())
        start = time.perf_counter()
        child = subprocess.Popen(command, cwd=cwd, env=env, stdout=out, stderr=err,
                                 stdin=subprocess.DEVNULL)
        while True:
            pid, status, usage = os.wait4(child.pid, os.WNOHANG)
            if pid:
                wall = time.perf_counter() - start
                break
            tree_peak = max(tree_peak, tree_resident_bytes(child.pid))
            load.append(os.getloadavg()[0])
            time.sleep(SAMPLE_SECONDS)
    child.returncode = os.waitstatus_to_exitcode(status)   # keep Popen from waiting again
    user, system, max_rss = usage.ru_utime, usage.ru_stime, usage.ru_maxrss
    for orphan in reap_orphans(earlier_children):
        user, system = user + orphan.ru_utime, system + orphan.ru_stime
        max_rss = max(max_rss, orphan.ru_maxrss)
    return Measured(command, child.returncode, wall, user, system, max_rss * 1024, tree_peak,
                    load, out_path.read_text(), err_path.read_text()[-3000:])


def become_subreaper() -> bool:
    """Make this process the reaper of its orphaned descendants (Linux ``prctl``
    ``PR_SET_CHILD_SUBREAPER``), so that :func:`reap_orphans` can count their CPU; False
    where that is not possible."""
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def reap_orphans(earlier_children: set[int], timeout: float = 30.0) -> list:
    """Wait for the descendants a finished child left to this process (see
    :func:`become_subreaper`) and return their ``rusage`` (they end once the child has: a
    ``forkserver`` when its parent's pipe closes).

    Only processes that became this process's children since ``earlier_children`` was taken
    are waited for: a caller's own long-lived children (a test's database or Prefect server)
    are neither reaped nor waited on until the timeout."""
    found, deadline = [], time.monotonic() + timeout
    while time.monotonic() < deadline:
        orphans = children_of(os.getpid()) - earlier_children
        if not orphans:
            break
        for orphan in orphans:
            try:
                pid, _, usage = os.wait4(orphan, os.WNOHANG)
            except ChildProcessError:
                continue
            if pid:
                found.append(usage)
        time.sleep(0.05)
    return found


def process_parents() -> dict[int, int]:
    """Every process's parent id, from ``/proc`` (empty without it)."""
    parents: dict[int, int] = {}
    try:
        entries = os.listdir("/proc")
    except OSError:
        return parents
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as stat:
                fields = stat.read().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        parents[int(entry)] = int(fields[1])        # after "pid (comm)": state, ppid
    return parents


def children_of(parent: int) -> set[int]:
    """The ids of ``parent``'s children now, zombies included."""
    return {pid for pid, ppid in process_parents().items() if ppid == parent}


def tree_resident_bytes(root: int) -> int:
    """Summed resident bytes of ``root`` and its descendants now (0 without ``/proc``)."""
    parents = process_parents()
    page = os.sysconf("SC_PAGE_SIZE")
    tree, frontier = {root}, [root]
    while frontier:
        parent = frontier.pop()
        children = [pid for pid, ppid in parents.items() if ppid == parent and pid not in tree]
        tree.update(children)
        frontier += children
    total = 0
    for pid in tree:
        try:
            with open(f"/proc/{pid}/statm") as statm:
                total += int(statm.read().split()[1]) * page
        except (OSError, IndexError, ValueError):
            continue
    return total


def stop_on_signals() -> None:
    """End this process through its ``finally`` blocks on SIGTERM and SIGINT.

    A benchmark that starts a PostgreSQL or Prefect server stops it in a ``finally``; a
    plain ``kill`` ends Python without running one, and a shell started in the background
    hands its children SIGINT ignored, so Ctrl-C did not reach them either. Both now raise
    ``KeyboardInterrupt`` in the main thread."""
    def interrupt(signum, frame):
        raise KeyboardInterrupt(f"stopped by signal {signal.Signals(signum).name}")

    signal.signal(signal.SIGTERM, interrupt)
    signal.signal(signal.SIGINT, interrupt)
