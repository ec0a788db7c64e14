"""What the command line prints on and returns: its exit statuses, the console it writes tables
to and its error line."""
from __future__ import annotations

import sys

#: every monitored asset processed (or the command did what it was asked)
EXIT_OK = 0
#: an asset that should be monitored was not, an operation failed, or check found a problem
EXIT_FAILED = 1
#: bad usage or configuration
EXIT_USAGE = 2
#: Prefect's API server could not be started or reached
EXIT_UNAVAILABLE = 3


def rich_console(stream=None):
    """A rich ``Console`` on ``stream`` (stdout): the terminal's width, 200 columns when piped."""
    from rich.console import Console

    stream = stream or sys.stdout
    width = None if stream.isatty() else 200
    return Console(file=stream, width=width, highlight=False, soft_wrap=False)


def print_error(message: str) -> None:
    """``fleet-health: error: MESSAGE`` on stderr."""
    print(f"fleet-health: error: {message}", file=sys.stderr)
