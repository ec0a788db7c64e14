"""A curve as a white-box parameter: breakpoints and values, interpolated linearly.

An open-circuit-voltage curve over state of charge, a pump curve or an efficiency map along
one axis is written once in the model's ``default_parameters`` and overridden like any other
parameter, in fleet.toml as an inline table::

    [classes.pack.parameters]
    ocv = { breakpoints = [0.0, 0.5, 1.0], values = [330.0, 370.0, 400.0] }
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from graybox.exceptions import ModelSpecError


@dataclass(frozen=True)
class Table:
    """A piecewise-linear curve ``y(x)``; constant beyond its first and last breakpoint.

    Attributes
    ----------
    breakpoints : tuple of float
        Strictly increasing, at least two.
    values : tuple of float
        One value per breakpoint.

    Examples
    --------
    >>> ocv = Table((0.0, 1.0), (3.0, 4.0))
    >>> float(ocv(0.25))
    3.25
    """

    breakpoints: tuple[float, ...]
    values: tuple[float, ...]

    def __post_init__(self):
        x = tuple(_finite(v, "breakpoint") for v in self.breakpoints)
        y = tuple(_finite(v, "value") for v in self.values)
        if len(x) < 2 or len(x) != len(y):
            raise ValueError(f"a table needs at least 2 breakpoints and one value per "
                             f"breakpoint, got {len(x)} breakpoints and {len(y)} values")
        if any(b <= a for a, b in zip(x, x[1:])):
            raise ValueError(f"table breakpoints must increase strictly, got {list(x)}")
        object.__setattr__(self, "breakpoints", x)
        object.__setattr__(self, "values", y)

    def __call__(self, x):
        """The curve at ``x`` (any array shape)."""
        return np.interp(x, self.breakpoints, self.values)

    def to_dict(self) -> dict:
        """``{"breakpoints": [...], "values": [...]}``, as fleet.toml and records write it."""
        return {"breakpoints": list(self.breakpoints), "values": list(self.values)}


def as_table(value, what: str) -> Table:
    """A :class:`Table` from a Table or a ``{breakpoints, values}`` mapping.

    Raises
    ------
    ModelSpecError
        Naming ``what`` when the value is not a valid table.
    """
    if isinstance(value, Table):
        return value
    if not isinstance(value, Mapping) or set(value) != {"breakpoints", "values"}:
        raise ModelSpecError(f"{what} is a table: give {{breakpoints = [...], values = [...]}}, "
                             f"got {value!r}")
    try:
        return Table(tuple(value["breakpoints"]), tuple(value["values"]))
    except (TypeError, ValueError) as error:
        raise ModelSpecError(f"{what}: {error}") from None


def _finite(value, what: str) -> float:
    if isinstance(value, bool):
        raise ValueError(f"table {what} must be a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"table {what} must be finite, got {value!r}")
    return number
