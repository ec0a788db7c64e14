"""Bounds the command line reads from the environment, in seconds."""
from __future__ import annotations

import os


def env_seconds(name: str, default: float, error: type[Exception] = ValueError) -> float:
    """``$name`` as seconds (at least 0), or ``default`` when unset or empty.

    Raises
    ------
    error
        When the variable is not a number, naming it and its value.
    """
    text = os.environ.get(name)
    try:
        return default if not text else max(0.0, float(text))
    except ValueError:
        raise error(f"${name} must be a number of seconds, got {text!r}") from None
