"""The machine's load average, which the benchmarks' reports quote beside their timings (each
report in its own wording)."""
from __future__ import annotations

import os


def load_average() -> tuple[float, float, float]:
    """The machine's 1-, 5- and 15-minute load averages (``os.getloadavg``).

    Returns
    -------
    tuple of float
        Runnable and running processes averaged over 1, 5 and 15 minutes.

    Raises
    ------
    OSError
        Where the system does not keep a load average.
    """
    return os.getloadavg()
