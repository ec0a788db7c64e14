"""Which nights an alarmed night is diagnosed on: its candidate's, or its alert episode's.

An experiment for issue 19 (``python -m benchmarks.diagnosis --evidence since-alarm``), not
the product: the nightly flow diagnoses each alarmed candidate on the nights it was fitted
on (``candidate``) and keeps no alert episode. ``since-alarm`` diagnoses an alarmed night on
every night since its alert opened: the alert is open since the first night of the run of
consecutive alarmed nights that ends with this one, and the diagnosis starts at that first
alarmed candidate's span, capped at the last ``most`` nights (``Hypothesis.since`` then
picks each hypothesis' start within them, as on a candidate's span).
"""
from __future__ import annotations

from typing import Container

from benchmarks.detection.grid import trailing_nights

#: the diagnosis' evidence: the candidate's nights (the product, the default), or the alert
#: episode's
EVIDENCE = ("candidate", "since-alarm")
#: the alert episode's nights at most, by default
EPISODE_NIGHTS = 4


def alert_opened(night: int, alarmed: Container[int], first: int) -> int:
    """The first night of the run of consecutive alarmed nights that ends with ``night``
    (``night`` itself alarmed), none before ``first`` (the first night with a candidate).

    >>> alert_opened(7, {5, 6, 7}, 4), alert_opened(7, {5, 7}, 4), alert_opened(5, {3, 4, 5}, 4)
    (5, 7, 4)
    """
    opened = night
    while opened - 1 >= first and opened - 1 in alarmed:
        opened -= 1
    return opened


def diagnosed_nights(night: int, alarmed: Container[int], candidate_nights: int, first: int,
                     evidence: str = EVIDENCE[0], most: int = EPISODE_NIGHTS) -> range:
    """The nights ``night``'s diagnosis reads.

    Parameters
    ----------
    night : int
        The diagnosed night.
    alarmed : container of int
        The asset's nights whose candidate alarmed (the nights before ``night`` are read).
    candidate_nights : int
        Nights a candidate is fitted on (``[nightly] candidate_nights``).
    first : int
        The first night with a candidate (the baseline's end): no span starts before it.
    evidence : {"candidate", "since-alarm"}, default "candidate"
        ``candidate``: the candidate's span (:func:`trailing_nights`), what the nightly flow
        diagnoses. ``since-alarm``: an alarmed night's alert episode, from the span of the
        candidate that opened the alert (:func:`alert_opened`) to ``night``, its last
        ``most`` nights; a night that did not alarm reads its candidate's span.
    most : int, default :data:`EPISODE_NIGHTS` (4)
        The episode's cap, in nights; at least ``candidate_nights``.

    Returns
    -------
    range
        Consecutive nights, ending with ``night``.

    Raises
    ------
    ValueError
        If ``evidence`` is unknown or ``most`` is below ``candidate_nights``.

    Examples
    --------
    >>> alarms = {6, 7, 8}
    >>> [list(diagnosed_nights(n, alarms, 2, 4, "since-alarm")) for n in (6, 7, 8)]
    [[5, 6], [5, 6, 7], [5, 6, 7, 8]]
    >>> list(diagnosed_nights(8, alarms, 2, 4))
    [7, 8]
    """
    if evidence not in EVIDENCE:
        raise ValueError(f"evidence {evidence!r}: one of {', '.join(EVIDENCE)}")
    if most < candidate_nights:
        raise ValueError(f"an episode of at most {most} nights is shorter than a candidate's "
                         f"{candidate_nights}")
    span = trailing_nights(night, candidate_nights, first)
    if evidence == "candidate" or night not in alarmed:
        return span
    start = trailing_nights(alert_opened(night, alarmed, first), candidate_nights, first).start
    return range(max(start, night - most + 1), night + 1)
