"""Validation of the simulator's numeric fields (finite numbers, integers, known keys)."""
from __future__ import annotations

import math
from typing import Mapping

import numpy as np


def finite(value, what: str) -> float:
    """``value`` as a finite float; ``ValueError`` naming ``what`` otherwise."""
    if isinstance(value, bool):
        raise ValueError(f"{what} must be a number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{what} must be finite, got {value!r}")
    return number


def integer(value, what: str, low: int) -> int:
    """``value`` as an int ``>= low`` (bools refused); ``ValueError`` naming ``what`` otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ValueError(f"{what} must be an integer >= {low}, got {value!r}")
    return int(value)


def unknown_keys(d: Mapping, known, what: str) -> None:
    """``ValueError`` naming the keys of ``d`` that are not in ``known``."""
    extra = set(d) - set(known)
    if extra:
        raise ValueError(f"{what}: unknown key(s) {sorted(extra)}; known: {sorted(known)}")
