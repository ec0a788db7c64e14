"""Progress of long work, reported by the plain functions and shown by the command line.

The flows' functions call :func:`start`, :func:`advance` and :func:`note`; by default these
log on the Prefect run's own log (a served deployment's runs show their progress on the run's
page in Prefect's UI). The command line installs a reporter (a rich progress bar on a terminal, plain
lines otherwise) with :func:`reporting`. A module-level reporter (not a context variable) is
used on purpose: Prefect may run a task in another thread.
"""
from __future__ import annotations

import contextlib
import logging
import sys
import threading
from typing import Iterator

from rich.console import Console
from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                           TimeElapsedColumn)

from flows.run_logger import run_logger

logger = logging.getLogger("flows.progress")

#: the default reporter logs the count each time another tenth of the work is done
LOGGED_STEPS = 10


class Reporter:
    """The default reporter, in effect where no command line shows progress (a flow run of a
    served deployment): log lines on the flow or task run's own log, which Prefect's UI shows
    beside the run, or on the ``flows.progress`` logger outside a run. The count is logged
    each tenth of the work, each failure at once, so that a 1,000-asset night writes tens of
    lines, not a thousand."""

    def __init__(self):
        self.description, self.total, self.done, self.failed, self.logged = "", 0, 0, 0, 0

    def start(self, description: str, total: int) -> None:
        self._begin(description, total)
        run_logger(logger).info("%s: %d to do", description, total)

    def advance(self, count: int = 1, text: str | None = None, failed: int = 0) -> None:
        self._count(count, failed)
        if failed or self.done >= self.total or self.done >= self.logged + self.total / LOGGED_STEPS:
            self.logged = self.done
            log = run_logger(logger)
            (log.warning if failed else log.info)("%s", self._done_line(text))

    def note(self, text: str) -> None:
        run_logger(logger).info("%s", text)

    def stop(self) -> None:
        pass

    def _begin(self, description: str, total: int) -> None:
        self.description, self.total, self.done, self.failed, self.logged = (
            description, total, 0, 0, 0)

    def _count(self, count: int, failed: int) -> None:
        self.done += count
        self.failed += failed

    def _done_line(self, text: str | None) -> str:
        # "8/8" alone would read as eight successes: the failures are counted beside it
        failures = f", {self.failed} failed" if self.failed else ""
        suffix = f" ({text})" if text else ""
        return f"{self.description}: {self.done}/{self.total} done{failures}{suffix}"


class LineReporter(Reporter):
    """Plain progress lines on a stream (logs, CI, pipes)."""

    def __init__(self, stream=None):
        super().__init__()
        self.stream = stream or sys.stderr

    def start(self, description: str, total: int) -> None:
        self._begin(description, total)
        print(f"{description}: {total} to do", file=self.stream, flush=True)

    def advance(self, count: int = 1, text: str | None = None, failed: int = 0) -> None:
        self._count(count, failed)
        print(self._done_line(text), file=self.stream, flush=True)

    def note(self, text: str) -> None:
        print(text, file=self.stream, flush=True)


class RichReporter(Reporter):
    """A rich progress bar on a terminal."""

    def __init__(self, console):
        self.console = console
        self.progress = Progress(TextColumn("{task.description}"), BarColumn(),
                                 MofNCompleteColumn(), TimeElapsedColumn(),
                                 TextColumn("{task.fields[failures]}"),
                                 TextColumn("{task.fields[last]}"), console=console,
                                 transient=False)
        self.task = None
        self.progress.start()

    def start(self, description: str, total: int) -> None:
        if self.task is not None:
            self.progress.update(self.task, visible=True)
        self.failed = 0
        self.task = self.progress.add_task(description, total=max(total, 1), last="",
                                           failures="")

    def advance(self, count: int = 1, text: str | None = None, failed: int = 0) -> None:
        if self.task is not None:
            self.failed += failed
            self.progress.update(self.task, advance=count, last=text or "",
                                 failures=f"{self.failed} failed" if self.failed else "")

    def note(self, text: str) -> None:
        self.progress.console.print(text)

    def stop(self) -> None:
        self.progress.stop()


_lock = threading.Lock()
_current: Reporter = Reporter()


def current() -> Reporter:
    return _current


def start(description: str, total: int) -> None:
    with _lock:
        _current.start(description, total)


def advance(count: int = 1, text: str | None = None, failed: int = 0) -> None:
    """``count`` more done, ``failed`` of them failed; ``text`` says about the last."""
    with _lock:
        _current.advance(count, text, failed)


def note(text: str) -> None:
    with _lock:
        _current.note(text)


@contextlib.contextmanager
def reporting(reporter: Reporter) -> Iterator[Reporter]:
    """Install ``reporter`` for the duration of the block."""
    global _current
    previous = _current
    _current = reporter
    try:
        yield reporter
    finally:
        try:
            reporter.stop()
        finally:
            _current = previous


def for_stream(stream=None) -> Reporter:
    """A rich bar when ``stream`` (default stderr) is a terminal, else plain lines."""
    stream = stream or sys.stderr
    if getattr(stream, "isatty", lambda: False)():
        return RichReporter(Console(file=stream))
    return LineReporter(stream)
