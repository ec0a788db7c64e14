"""The benchmarks' command-line type for a list of numbers: ``--model-errors 0,0.2``."""
from __future__ import annotations


def comma_floats(text: str) -> tuple[float, ...]:
    """Comma-separated numbers as a tuple of floats; empty parts are skipped.

    Parameters
    ----------
    text : str
        E.g. ``"0,0.1,0.2"`` (an argparse ``type``).

    Returns
    -------
    tuple of float

    >>> comma_floats("0,0.1, 0.2,")
    (0.0, 0.1, 0.2)
    """
    return tuple(float(x) for x in text.split(",") if x.strip())
