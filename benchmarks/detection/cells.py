"""Markdown cells and tables of the detection benchmark's report (:mod:`.report`) and of its
section per sampling interval (:mod:`.rates`)."""
from __future__ import annotations

import math


def percent(x: float | None, decimals: int = 0) -> str:
    """``x`` as a percentage with ``decimals`` decimals; ``–`` when it is None or NaN.

    >>> percent(0.123), percent(0.123, 1), percent(float("nan")), percent(None)
    ('12 %', '12.3 %', '–', '–')
    """
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    return f"{100 * x:.{decimals}f} %"


def markdown_table(header: list[str], rows: list[list]) -> str:
    """A markdown table: ``header``, its rule, one line per row (cells by ``str``)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    return "\n".join(lines + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows])
