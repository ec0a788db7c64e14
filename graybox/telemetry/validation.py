"""Validation of raw telemetry rows: the first bad row, by file and row.

The rules: docs/design.md section 5.1.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Collection, Sequence

import numpy as np
import pandas as pd

from graybox.exceptions import TelemetryError
from graybox.telemetry.layout import NS_PER_SECOND, stamp
from graybox.telemetry.holds import drop_held_rows
from graybox.telemetry.resent import drop_resent_rows
from graybox.telemetry.policy import (HOLD_CAP, HOLD_FACTOR, MIN_STUCK_SAMPLES, GridPolicy,
                                      format_duration)
from graybox.telemetry.rows import Rows

_NAT = np.iinfo(np.int64).min
#: a coarse reading changes in at least this share of its steps (:func:`_steady_runs`)
COARSE_SHARE = 0.1
#: or, a slow one, makes at least this share of its changes by its smallest step
SLOW_STEP_SHARE = 0.9
#: a reading is on a grid (a sensor's resolution) if at least this share of its changes are
#: whole multiples of its smallest change, each within :data:`GRID_TOLERANCE` of a multiple
GRID_SHARE = 0.9
GRID_TOLERANCE = 0.05
#: a reading on a grid repeats by chance where its step-to-step change beside a run is at most
#: this many steps, and those readings scatter at most this many times that change
#: (:func:`_among_its_neighbours`)
STILL_SCATTER = 1.5
#: readings on each side of a run whose median a coarse reading's run lies within one step
#: of (:func:`_side_within`)
SIDE_SAMPLES = 3
#: a run held within this share of the channel's largest magnitude of 0 is at the channel's
#: zero (a meter's offset at rest; :func:`_at_rest`)
REST_SHARE = 0.01
#: samples a channel at rest most of the time must move in for its moving samples' span to
#: be its scale (one corrupt sample then lies beyond their 99th percentile;
#: :func:`_check_ranges`)
MIN_MOVING = 200
#: an input kicks the plant at a run's end where its step there is more than this many times
#: its largest step inside the run (:func:`_steady_runs`)
KICK_FACTOR = 2.0
#: steps before a run, or at its end, in which an input's kick explains it (the plant's lag)
KICK_LAG = 3


def validate(raw: pd.DataFrame, asset_id: str, policy: GridPolicy = GridPolicy(),
             inputs: Collection[str] = ()) -> None:
    """Check raw telemetry rows; raise at the first bad row.

    With ``policy.running``, the rows of a stopped machine are dropped first
    (:func:`running_rows`), and so are rows a logger held (:func:`data_rows`).

    Checks run in this order, each over the whole window, and the first failing check raises
    at its first offending row, naming the file and the 0-based row in that file. ``dt`` is
    the sample interval (``policy.sample_interval`` or the median raw step); times between
    rows and the limits count in whole intervals, rounded to the nearest (see
    :class:`GridPolicy`).

    1. ``"non_finite"``: Inf in a channel, or a missing timestamp;
    2. ``"duplicate_timestamp"`` / ``"backward_timestamp"``: a timestamp equal to / earlier
       than the previous row's (which may be in the previous file);
       a channel's missing values (NaN, a missed reading) are interpolated in time like a
       missing row; where the values around them lie more than ``policy.max_gap`` apart,
       their rows are missing rows (left out: a gap, below), and ``"gap"`` when no row is
       left with every channel's value; ``"silent_channel"``: a channel without any value
       in the window while the others have one (a dead sensor);
       ``"out_of_range"``: a value outside the channel's ``policy.ranges``, or (channels
       without ranges) implausibly far from the window's median (``policy.plausible_spread``);
    3. ``"stuck_channel"``: a channel other than ``inputs`` holds one value for at least its
       ``policy.stuck_after`` (two or more identical consecutive samples), reported at the
       first row of the run; a part at rest (:func:`_at_rest`) and a steady coarse reading
       (:func:`_steady_runs`) are not stuck;
    4. ``"too_few_samples"``: the rows' operating periods cover less than
       ``policy.min_duration`` (each period first to last row plus one interval), or there
       is one row and no ``sample_interval`` (no file or row).

    Two consecutive rows more than ``policy.max_gap`` apart (a logger's outage, an
    intermittent machine's pause) are not an error: they separate two operating periods,
    each gridded and analysed on its own, and a value held across the gap is not stuck
    (:func:`separations`); the reader of a continuous class's window says that it has
    more than one period (:attr:`TelemetryWindow.n_periods`).

    Parameters
    ----------
    raw : pandas.DataFrame
        As returned by :func:`read_raw`. Every column other than ``timestamp``, ``_file``
        and ``_row`` is a channel. Without ``_file``/``_row``, errors give the position.
    asset_id : str
        The asset (for the error).
    policy : GridPolicy, optional
        The limits.
    inputs : collection of str, optional
        Channels exempt from the stuck check: the model's inputs (commands, setpoints), which
        legitimately hold a value for a long time (``model.input_columns``). By default every
        channel is checked.

    Raises
    ------
    TelemetryError
        On the first problem found.
    """
    logged = Rows.from_frame(raw)
    validate_rows(data_rows(logged, asset_id, policy), asset_id, policy, inputs, logged.ts)


def validate_rows(rows: Rows, asset_id: str, policy: GridPolicy, inputs: Collection[str] = (),
                  logged: np.ndarray | None = None) -> tuple[Rows, int]:
    """:func:`validate` on :class:`Rows`; returns the rows with their missing values
    interpolated (``Rows.missing`` marks them) and the sample interval in ns (for gridding).
    ``logged``: the timestamps of every row read, before the running and held rows were
    left out (:func:`logged_interval_ns`)."""
    _check_finite(rows, asset_id)
    check_order(rows, asset_id)
    if len(rows) < 2 and policy.sample_interval is None:
        raise TelemetryError(asset_id, "too_few_samples",
                             f"{len(rows)} sample(s) in the window: two are needed to infer the "
                             f"sample interval")
    dt_ns = logged_interval_ns(rows.ts, logged, policy)
    rows = fill_missing(rows, asset_id, policy, dt_ns)
    _check_ranges(rows, asset_id, policy)
    _check_stuck(rows, asset_id, policy, dt_ns, set(inputs))
    check_duration(asset_id, operating_points(rows, dt_ns, policy), dt_ns, policy)
    return rows, dt_ns


def fill_missing(rows: Rows, asset_id: str, policy: GridPolicy, dt_ns: int) -> Rows:
    """The rows with each channel's missing values (NaN) interpolated in time between the
    values around them in their operating period (held at its ends). Where those lie further
    apart than ``policy.max_gap`` the rows are missing rows: they are left out, and the gap
    separates two operating periods (:func:`separations`), as a logger's outage does;
    ``"gap"`` if no row is left with every channel's value."""
    missing = np.isnan(rows.values)
    if not missing.any():
        return rows
    silent = missing.all(axis=1)
    if silent.all():
        raise TelemetryError(asset_id, "no_data", "no channel has a value in the window")
    for j in np.flatnonzero(silent):
        _fail_silent(rows, asset_id, rows.channels[j], dt_ns, policy)
    first = rows
    unread = np.zeros(len(rows.channels), dtype=int)
    while True:     # leaving rows out can widen another channel's gap: until none is left
        unbridged = _unbridged(rows, missing, policy, dt_ns)
        if not unbridged.any():
            break
        left_out = unbridged.any(axis=0)
        if left_out.all():
            gaps = ", ".join(repr(c) for c, m in zip(rows.channels, missing.any(axis=1)) if m)
            _fail(first, asset_id, "gap",
                  f"no row has every channel's value within max_gap="
                  f"{format_duration(policy.max_gap)} of it (missing: {gaps})", 0)
        unread += unbridged.sum(axis=1)
        rows = rows.take(~left_out)
        missing = np.isnan(rows.values)
    if unread.any():
        counts = dict(rows.unread)
        for c, k in zip(rows.channels, unread):
            counts[c] = counts.get(c, 0) + int(k)
        rows = replace(rows, unread=tuple((c, k) for c, k in counts.items() if k))
    if not missing.any():
        return rows
    values = rows.values.copy()
    bounds = np.append(period_starts(rows, policy, dt_ns), len(rows))
    for a, b in zip(bounds[:-1], bounds[1:]):
        ts = rows.ts[a:b]
        t = (ts - ts[0]).astype(np.float64)
        for j in np.flatnonzero(missing[:, a:b].any(axis=1)):
            lost, have = np.flatnonzero(missing[j, a:b]), np.flatnonzero(~missing[j, a:b])
            values[j, a + lost] = np.interp(t[lost], t[have], values[j, a + have])
    return replace(rows, values=values, missing=missing.any(axis=0))


def _unbridged(rows: Rows, missing: np.ndarray, policy: GridPolicy, dt_ns: int) -> np.ndarray:
    """Per channel and row, True where the channel's value is missing (``missing``, per
    channel and row) and its values around it in its operating period lie further apart than
    ``max_gap`` (the period's ends stand in for a value beyond them), or the channel has no
    value in that period at all."""
    out = np.zeros(missing.shape, dtype=bool)
    allowed = bridged_intervals(policy, dt_ns)
    bounds = np.append(period_starts(rows, policy, dt_ns), len(rows))
    for a, b in zip(bounds[:-1], bounds[1:]):
        ts = rows.ts[a:b]
        for j in np.flatnonzero(missing[:, a:b].any(axis=1)):
            lost, have = np.flatnonzero(missing[j, a:b]), np.flatnonzero(~missing[j, a:b])
            if not have.size:
                out[j, a:b] = True
                continue
            after = np.searchsorted(have, lost)
            before_ts = np.where(after > 0, ts[have[np.maximum(after - 1, 0)]], ts[0])
            after_ts = np.where(after < have.size, ts[have[np.minimum(after, have.size - 1)]],
                                ts[-1])
            out[j, a + lost[intervals(after_ts - before_ts, dt_ns) > allowed]] = True
    return out


def pauses(ts: np.ndarray, policy: GridPolicy, dt_ns: int) -> np.ndarray:
    """Per step between consecutive rows: True where it is longer than ``policy.max_gap``
    (a gap: a pause between operating periods, or a logger's outage)."""
    allowed = bridged_intervals(policy, dt_ns)
    # intervals(step) > allowed  <=>  step >= allowed * dt + ceil(dt / 2)
    return np.diff(ts) >= allowed * dt_ns + (dt_ns + 1) // 2


def bridged_intervals(policy: GridPolicy, dt_ns: int) -> int:
    """The longest step between rows that is bridged, in whole intervals (``max_gap``;
    consecutive samples are always fine)."""
    return max(1, limit_intervals(policy.max_gap, dt_ns))


def separations(rows: Rows, policy: GridPolicy, dt_ns: int) -> np.ndarray:
    """Per step between consecutive rows: True where it separates two operating periods,
    a time between rows longer than ``max_gap``: an intermittent machine's pause, a
    logger's outage (rows missing, or held: ``rows.after_hold``), a channel's missing
    values too long to bridge (:func:`fill_missing` leaves their rows out). A single held
    row is bridged at any rate: its neighbours are two samples apart, the mildest gap there
    is, where a 4-minute ``max_gap`` at 15-minute rows would bridge nothing."""
    if len(rows) < 2:
        return np.zeros(0, dtype=bool)
    long = pauses(rows.ts, policy, dt_ns)
    held = np.zeros_like(long) if rows.after_hold is None else rows.after_hold[1:]
    bridged = held & (intervals(np.diff(rows.ts), dt_ns) <= 2)
    return long & ~bridged


def period_starts(rows: Rows, policy: GridPolicy, dt_ns: int) -> np.ndarray:
    """First row of every operating period: 0, and each row after a :func:`separations`
    (continuous telemetry without a long hold is one period)."""
    return np.concatenate([[0], np.flatnonzero(separations(rows, policy, dt_ns)) + 1])


def operating_points(rows: Rows, dt_ns: int, policy: GridPolicy) -> int:
    """Grid points of the rows' operating periods (:func:`grid_points` of each)."""
    bounds = np.append(period_starts(rows, policy, dt_ns), len(rows))
    return sum(grid_points(rows.ts[a:b], dt_ns) for a, b in zip(bounds[:-1], bounds[1:]))


def data_rows(rows: Rows, asset_id: str, policy: GridPolicy,
              channels: Sequence[str] | None = None) -> Rows:
    """The rows that are data: without the rows a logger sent twice
    (:func:`graybox.telemetry.resent.drop_resent_rows`), :func:`running_rows` without the
    rows a logger held (:func:`graybox.telemetry.holds.drop_held_rows`)."""
    return drop_held_rows(running_rows(drop_resent_rows(rows), asset_id, policy, channels))


def running_rows(rows: Rows, asset_id: str, policy: GridPolicy,
                 channels: Sequence[str] | None = None) -> Rows:
    """The rows in which the machine runs (``policy.running``), with ``channels`` only.

    A row whose ``running`` channel has no value (NaN, a missed reading) is left out, as
    missing rows are (whether the machine ran then is unknown), and counted in
    ``Rows.unread``; a ``running`` channel without any value in the window while the other
    channels have one is ``"silent_channel"`` (a dead sensor would otherwise read as a
    machine that never ran); an Inf is ``"non_finite"`` at its row. Without
    ``policy.running``: every row.
    """
    keep = tuple(rows.channels if channels is None else channels)
    if not policy.running:
        return rows if keep == rows.channels else rows.take(slice(None), keep)
    on = np.ones(len(rows), dtype=bool)
    unread = []
    for name, low, high in policy.running:
        j = rows.channels.index(name)
        v = rows.values[j]
        if np.isinf(v).any():
            i = int(np.argmax(np.isinf(v)))
            _fail(rows, asset_id, "non_finite",
                  f"non-finite value in column {name!r}={float(v[i])!r} (a running channel)", i)
        lost = np.isnan(v)
        if lost.all() and not np.isnan(np.delete(rows.values, j, axis=0)).all():
            _fail_silent(rows, asset_id, name,
                         interval_ns(rows.ts, policy) if len(rows) > 1 else 0, policy,
                         " (a running channel)")
        if lost.any():
            unread.append((name, int(lost.sum())))
        on &= (v >= low) & (v <= high)        # NaN compares False: left out
    return replace(rows.take(on, keep), unread=rows.unread + tuple(unread))


def _fail_silent(rows: Rows, asset_id: str, channel: str, dt_ns: int, policy: GridPolicy,
                 what: str = "") -> None:
    """``"silent_channel"``: ``channel`` has no value in the window while the others have
    one, a sensor's fault (a dead sensor), not the data's: its excess is the window's
    seconds against ``max_gap``."""
    span = (int(rows.ts[-1] - rows.ts[0]) + dt_ns) / NS_PER_SECOND
    _fail(rows, asset_id, "silent_channel",
          f"channel {channel!r}{what} has no value in the window ({format_duration(span)}) "
          f"while the others have", 0, channel=channel, excess=(span, float(policy.max_gap)))


#: the kept rows' step is not the logger's where it is more than this many of all rows' steps
SCATTERED_ROWS = 1.5


def logged_interval_ns(ts: np.ndarray, logged: np.ndarray | None, policy: GridPolicy) -> int:
    """:func:`interval_ns` of the kept rows ``ts`` (running, not held), or of every row the
    logger wrote (``logged``) where the kept rows are too scattered to show its step: a
    turbine that produced in three separate 10-minute rows of a calm day has kept rows
    about 40 minutes apart, not 10, and a window gridded at that step cannot be compared
    with its baseline. Kept rows whose step is the logger's (an intermittent machine's
    operating periods, a historian's held rows left out) give it as before."""
    step = interval_ns(ts, policy)
    if policy.sample_interval is not None or logged is None or len(logged) <= len(ts):
        return step
    logged = np.unique(logged[logged != np.iinfo(np.int64).min])
    if len(logged) < 2:
        return step
    every = interval_ns(logged, policy)
    return every if step > SCATTERED_ROWS * every else step


def interval_ns(ts: np.ndarray, policy: GridPolicy) -> int:
    """The grid step in ns: the policy's, or the logger's nominal step (>= 2 rows).

    Regular timestamps give the median step exactly. When they jitter, each step counts as
    the whole number of median steps nearest to it (a missing row's double step is two; a
    step of more than 10 is a pause, which starts a new run of samples), and the nominal step
    is the slope of the timestamps over the sample numbers within each run (least squares),
    rounded to three significant digits. A logger's timestamps that wander around their
    nominal step (±0.2 s at 1 s, with 2 % of the rows missing) otherwise give each window a
    step of its own (a median of 1.003 s one day, 1.004 s the next), and windows gridded at
    different steps cannot be fitted together.
    """
    if policy.sample_interval is not None:
        return max(1, int(round(policy.sample_interval * NS_PER_SECOND)))
    steps = np.diff(ts)
    if len(steps) and steps.min() == steps.max():
        # every step alike (a logger's regular rows): the median without sorting, the same
        return max(1, int(round(float(steps[0]))))
    typical = float(np.median(steps))
    if typical <= 0:
        return 1
    counts = np.maximum(1.0, np.round(steps / typical))
    counted = counts <= 10
    if np.all(steps[counted] == typical * counts[counted]):
        return max(1, int(round(typical)))
    run = np.concatenate([[0], np.cumsum(~counted)])
    number = np.concatenate([[0.0], np.cumsum(np.where(counted, counts, 0.0))])
    t = (ts - ts[0]).astype(np.float64)
    size = np.bincount(run)
    dk = number - (np.bincount(run, number) / size)[run]
    dt = t - (np.bincount(run, t) / size)[run]
    step = float((dk * dt).sum() / (dk * dk).sum())
    return max(1, int(round(step, 2 - int(np.floor(np.log10(step))))))


def grid_points(ts: np.ndarray, dt_ns: int) -> int:
    """Points of the grid ``ts[0] + k * dt`` up to the last timestamp."""
    return int((ts[-1] - ts[0]) // dt_ns) + 1


def check_duration(asset_id: str, n_points: int, dt_ns: int, policy: GridPolicy) -> None:
    """``"too_few_samples"`` if ``n_points`` at ``dt`` cover less than ``min_duration``."""
    covered = n_points * dt_ns
    if n_points < limit_intervals(policy.min_duration, dt_ns):
        raise TelemetryError(
            asset_id, "too_few_samples",
            f"the window covers {format_duration(covered / NS_PER_SECOND)} ({n_points} samples "
            f"at {dt_ns / NS_PER_SECOND:g} s), need at least "
            f"min_duration={format_duration(policy.min_duration)}")


def intervals(steps: np.ndarray, dt_ns: int) -> np.ndarray:
    """Times in ns as whole intervals of ``dt_ns``, rounded to the nearest (half up)."""
    return (steps + dt_ns // 2) // dt_ns


def limit_intervals(seconds: float, dt_ns: int) -> int:
    """A limit as whole intervals, rounded to the nearest like the times it is compared with
    (so an inferred ``dt`` a little off the true one does not move the limit)."""
    return int(intervals(round(seconds * NS_PER_SECOND), dt_ns))


def _samples_needed(limit: float, dt_ns: int) -> int:
    """Intervals a hold must last to be stuck under a limit of ``limit`` seconds: the limit,
    and at least :data:`MIN_STUCK_SAMPLES`."""
    return max(limit_intervals(limit, dt_ns), MIN_STUCK_SAMPLES)


def _shortest_run(limit: float, dt_ns: int, share: float = 1.0) -> int:
    """Intervals a run must last to count: ``share`` of :func:`_samples_needed` (1 for the
    stuck check, 1 / :data:`HOLD_FACTOR` for what a baseline learns), rounded up."""
    return math.ceil(share * _samples_needed(limit, dt_ns))


def _fail(rows: Rows, asset_id: str, kind: str, message: str, i: int, **sensor):
    file, row = rows.where(i)
    raise TelemetryError(asset_id, kind, message, file=file, row=row, **sensor)


def _check_finite(rows: Rows, asset_id: str) -> None:
    ts, values = rows.ts, rows.values
    finite = ~np.isinf(values)   # a missing value (NaN) is interpolated (fill_missing)
    bad_values = not finite.all()
    bad_ts = bool((ts == _NAT).any())
    if not (bad_values or bad_ts):
        return
    first_ts = int(np.argmax(ts == _NAT)) if bad_ts else len(ts)
    first_val = int(np.argmax(~finite.all(axis=0))) if bad_values else len(ts)
    if first_ts <= first_val:
        _fail(rows, asset_id, "non_finite", "timestamp is missing (NaT)", first_ts)
    i = first_val
    names = [f"{rows.channels[j]!r}={float(values[j, i])!r}"
             for j in np.flatnonzero(~finite[:, i])]
    _fail(rows, asset_id, "non_finite", f"non-finite value in column {', '.join(names)}", i)


def _check_ranges(rows: Rows, asset_id: str, policy: GridPolicy) -> None:
    """``"out_of_range"`` at the first row (over all channels) with an implausible value."""
    first = None  # (row, channel index, message, (distance from the centre, allowed))
    for j, name in enumerate(rows.channels):
        v = rows.values[j]
        if not len(v):
            continue
        bounds = policy.value_range(name)
        if bounds is not None:
            low, high = bounds
            bad = (v < low) | (v > high)
            why = f"outside its range [{low:g}, {high:g}] (grid ranges)"
            centre, allowed = (low + high) / 2, (high - low) / 2
        elif policy.plausible_spread > 0:
            p1, median, p99 = np.percentile(v, [1, 50, 99])
            resting = v == median
            if resting.mean() >= 0.5 and len(v) - np.count_nonzero(resting) >= MIN_MOVING:
                # a part at rest most of the time (a lift's speed, 0 at 98 % of a Sunday's
                # samples): its scale is how far it moves when it moves
                p1, p99 = np.percentile(np.append(v[~resting], median), [1, 99])
            scale = (p99 - p1) or abs(median)
            if scale == 0:
                continue  # a channel all zero but for a few samples: only ranges can judge it
            limit = policy.plausible_spread * scale
            bad = np.abs(v - median) > limit
            centre, allowed = median, limit
            why = (f"implausibly far from the window's median {median:.6g} (more than "
                   f"plausible_spread={policy.plausible_spread:g} x its 1-99 % span "
                   f"{scale:.6g}; set the class's grid ranges to accept it)")
        else:
            continue
        if bad.any():
            i = int(np.argmax(bad))
            if first is None or i < first[0]:
                first = (i, j, f"value {float(v[i])!r} of channel {name!r} is {why}",
                         (abs(float(v[i]) - centre), float(allowed)))
    if first is not None:
        _fail(rows, asset_id, "out_of_range", first[2], first[0],
              channel=rows.channels[first[1]], excess=first[3])


def check_order(rows: Rows, asset_id: str) -> None:
    """``"duplicate_timestamp"``/``"backward_timestamp"`` at the first non-increasing row."""
    ts = rows.ts
    steps = np.diff(ts)
    if len(steps) == 0 or steps.min() > 0:
        return
    i = int(np.argmax(steps <= 0)) + 1
    kind = "duplicate_timestamp" if steps[i - 1] == 0 else "backward_timestamp"
    word = "equals" if kind == "duplicate_timestamp" else "is earlier than"
    prev_file, prev_row = rows.where(i - 1)
    file, _ = rows.where(i)
    previous = "the previous row's"
    if prev_file is not None and prev_file != file:
        previous = f"the previous row's (row {prev_row} of another file, {prev_file})"
    _fail(rows, asset_id, kind,
          f"timestamp {stamp(ts[i])} {word} {previous} timestamp {stamp(ts[i - 1])}", i)


def _check_stuck(rows: Rows, asset_id: str, policy: GridPolicy, dt_ns: int, inputs: set) -> None:
    best = None  # (first row, channel, samples, held ns, limit s, samples needed)
    for j, limit, needed, starts, ends, held in _unexplained_holds(rows, policy, dt_ns, inputs):
        long = np.flatnonzero(held >= needed)
        if long.size and (best is None or starts[long[0]] < best[0]):
            r = long[0]
            best = (int(starts[r]), j, int(ends[r] - starts[r] + 1), int(held[r]) * dt_ns,
                    limit, needed)
    if best is not None:
        i, j, count, held, limit, needed = best
        floor = needed > limit_intervals(limit, dt_ns)   # the samples, not the time, decided
        allowed = max(float(limit), needed * dt_ns / NS_PER_SECOND)
        _fail(rows, asset_id, "stuck_channel",
              f"channel {rows.channels[j]!r} stuck at {float(rows.values[j, i])!r} for {count} "
              f"consecutive samples ({format_duration(held / NS_PER_SECOND)}; "
              f"stuck_after={format_duration(limit)}" + (
                  f", and at least {MIN_STUCK_SAMPLES} samples" if floor else "") + ")"
              + ("" if policy.intermittent else (
                  "; if the machine stands still then (parked, switched off), declare its "
                  "operating periods in the class's grid (running = {channel = [low, high]}, "
                  "intermittent = true) so that a pause is not read as a stuck sensor"))
              + f"; if {rows.channels[j]!r} holds its value while the machine runs (a coarse "
                f"reading of a steady machine), give it a longer limit in the class's grid "
                f"(stuck_after = {{ {rows.channels[j]} = \"{_longer(held)}\" }})", i,
              channel=rows.channels[j], excess=(held / NS_PER_SECOND, allowed))


def _longer(held_ns: int) -> str:
    """The limit a stuck message suggests: 6 h, or twice the hold in whole hours where that is
    longer (a baseline's windows may already hold a value 6 h: :data:`HOLD_CAP`)."""
    hours = max(HOLD_CAP, 2.0 * held_ns / NS_PER_SECOND) / 3600.0
    return format_duration(3600.0 * math.ceil(hours))


def _unexplained_holds(rows: Rows, policy: GridPolicy, dt_ns: int, inputs: set,
                       share: float = 1.0, wandering: bool = True):
    """Per checked channel (measured, with a ``stuck_after`` limit), its runs of equal samples
    of at least ``share`` of the intervals its limit needs that neither the plant
    (:func:`_steady_runs`) nor a part at rest (:func:`_at_rest`) explains: tuples
    ``(channel index, limit s, samples needed, starts, ends, held intervals)``, the runs in
    time order."""
    n = len(rows)
    if n < 2:
        return
    paused = separations(rows, policy, dt_ns)
    if not paused.any():
        paused = None
    input_values = [rows.values[j] for j, name in enumerate(rows.channels) if name in inputs]
    measured = [j for j, name in enumerate(rows.channels) if name not in inputs]
    measured_moves = rows.values[measured, 1:] != rows.values[measured, :-1]
    ts = rows.ts
    for j, name in enumerate(rows.channels):
        limit = policy.stuck_limit(name)
        if name in inputs or limit == 0:
            continue
        v = rows.values[j]
        same = v[1:] == v[:-1]
        if paused is not None:
            same &= ~paused  # a value held across a pause is not stuck
        if not same.any():  # the usual sensor: no two equal neighbours
            continue
        # runs of True in ``same``: samples starts[r] .. ends[r] hold one value
        edges = np.diff(same.view(np.int8), prepend=0, append=0)
        starts = np.flatnonzero(edges == 1)
        ends = np.flatnonzero(edges == -1)
        # a value holds until the next sample (or the end of the last interval, or of its
        # operating period)
        nxt = np.minimum(ends + 1, n - 1)
        until = np.where(ends + 1 < n, ts[nxt], ts[-1] + dt_ns)
        if paused is not None:
            cut = (ends + 1 < n) & paused[np.minimum(ends, n - 2)]
            until = np.where(cut, ts[ends] + dt_ns, until)
        held = intervals(until - ts[starts], dt_ns)
        needed = _samples_needed(limit, dt_ns)
        long = np.flatnonzero(held >= _shortest_run(limit, dt_ns, share))
        if long.size:
            long = long[~_steady_runs(v, starts[long], ends[long], input_values, paused,
                                      wandering)]
        if long.size:  # j is measured: inputs were skipped above
            others = np.delete(measured_moves, measured.index(j), axis=0)
            long = long[~_at_rest(v, starts[long], ends[long], others)]
        if long.size:
            yield j, limit, needed, starts[long], ends[long], held[long]


def longest_holds(rows: Rows, policy: GridPolicy, dt_ns: int, inputs: Collection[str] = ()
                  ) -> tuple[tuple[str, float], ...]:
    """Per checked channel, the longest time it held one value that the plant does not
    explain (the runs :func:`_check_stuck` judges), in seconds, where that run is at least
    1 / :data:`~graybox.telemetry.policy.HOLD_FACTOR` of what ``policy``'s limit needs (a
    shorter one would not widen it): what a healthy baseline's windows teach about a coarse
    reading of a steady plant (:meth:`GridPolicy.with_holds`). Channels without such a run
    are left out.

    The readings on a grid (:func:`_on_a_grid`: a sensor's resolution) share their longest
    hold: a plant that stands still holds every coarse reading at once (a truck's tyre
    pressures and temperatures on the highway), and a day in which one of them happened to
    hold longest says how long any of them may. A reading at full precision keeps its own.
    """
    own = {}
    # a wandering input's kick does not take a hold out of what the baseline learns: it is
    # how long the reading holds on this plant (the night's check still counts the kick)
    for j, _, _, _, _, held in _unexplained_holds(rows, policy, dt_ns, set(inputs),
                                                   share=1.0 / HOLD_FACTOR, wandering=False):
        own[j] = float(held.max()) * dt_ns / NS_PER_SECOND
    coarse = [j for j, name in enumerate(rows.channels)
              if name not in inputs and policy.stuck_limit(name) and _coarse(rows.values[j])]
    shared = max((own[j] for j in coarse if j in own), default=0.0)
    for j in coarse:
        floor = (_shortest_run(policy.stuck_limit(rows.channels[j]), dt_ns, 1.0 / HOLD_FACTOR)
                 * dt_ns / NS_PER_SECOND)
        if shared >= floor:
            own[j] = shared
    return tuple((rows.channels[j], own[j]) for j in sorted(own))


def _coarse(v: np.ndarray) -> bool:
    """A reading on a grid: it changes at least :data:`MIN_STUCK_SAMPLES` times, by whole
    multiples of its smallest change (:func:`_on_a_grid`)."""
    changes = np.abs(np.diff(v))
    moved = changes[changes > 0]
    return bool(moved.size >= MIN_STUCK_SAMPLES and _on_a_grid(moved))


def _steady_runs(v: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                 inputs: list[np.ndarray], paused: np.ndarray | None = None,
                 wandering: bool = True) -> np.ndarray:
    """Per run of equal samples ``v[starts[r]] .. v[ends[r]]``: True where both ends of the
    run are explained by the plant, so that the hold is a steady reading, not a frozen sensor.

    An end is explained where an input kicks the plant there (:func:`_kicks`: it steps by
    more than :data:`KICK_FACTOR` times its largest step inside the run, so one that holds
    one value through the run changes at all, a fixed-speed pump switched on or off, and one
    that wanders moves as it never did during the hold, a cloud over a clipping solar array
    whose heat sink held a degree for an hour), or where the channel moves by its resolution,
    its smallest change (50.5 to 50.0 kW) if it is a coarse reading (it changes in at least
    :data:`COARSE_SHARE` of its steps, or, a slow process, at least
    :data:`MIN_STUCK_SAMPLES` times, :data:`SLOW_STEP_SHARE` of them by its smallest step),
    or at the edge of the window or of an operating period (``paused``, per step; not both
    ends). A frozen sensor freezes and recovers whenever it does and then jumps to wherever
    the process went: at a sensor's noise its smallest change is rare, and a setpoint held
    all day does not explain a run that neither starts nor ends with it.
    A reading on a grid (:func:`_on_a_grid`) also holds by chance where the process stands
    still between two of its steps (a room logged to 0.1 C with 0.05 C of noise holds 10
    minutes about once a year of 30-s samples): a run that sits among its neighbours'
    readings where they scatter no more than a step (:func:`_among_its_neighbours`) is
    steady.
    """
    n = len(v)
    changes = np.abs(np.diff(v))
    moved = changes[changes > 0]
    first, last = starts == 0, ends == n - 1
    if paused is not None:
        first |= (starts > 0) & paused[np.maximum(starts - 1, 0)]
        last |= (ends < n - 1) & paused[np.minimum(ends, n - 2)]
    entry = changes[np.maximum(starts - 1, 0)]
    leave = changes[np.minimum(ends, n - 2)]
    begins, closes = first.copy(), last.copy()
    if moved.size:
        step = 1.01 * moved.min()
        # a coarse reading of a moving process changes often; one of a slow process (a room
        # logged to 0.1 C every 30 s) rarely, but then by one step at a time: a sensor that
        # freezes and jumps, or a setpoint moved between levels, does not
        often = moved.size >= COARSE_SHARE * len(changes)
        stepwise = (moved.size >= MIN_STUCK_SAMPLES
                    and np.count_nonzero(moved <= step) >= SLOW_STEP_SHARE * moved.size)
        if often or stepwise:
            begins |= ~first & ((entry <= step)
                                | _side_within(v, starts - 1, -1, paused, step))
            closes |= ~last & ((leave <= step) | _side_within(v, ends + 1, 1, paused, step))
        if often and _on_a_grid(moved):
            still = _among_its_neighbours(v, starts, ends, moved.min()) & ~first & ~last
            begins |= still
            closes |= still
    for u in inputs:
        kick_in, kick_out = _kicks(u, starts, ends, wandering)
        begins |= ~first & kick_in
        closes |= ~last & kick_out
    return begins & closes & ~(first & last)


def _kicks(u: np.ndarray, starts: np.ndarray, ends: np.ndarray, wandering: bool = True
           ) -> tuple[np.ndarray, np.ndarray]:
    """Per run of a channel's equal samples ``starts[r] .. ends[r]``: whether the input ``u``
    kicked the plant into the run and out of it. Into it: a step in the :data:`KICK_LAG`
    steps before its first sample of more than :data:`KICK_FACTOR` times the input's largest
    step inside the run; out of it: such a step in its last :data:`KICK_LAG` steps or the one
    out of it, against the largest of the run's other steps (the plant follows an input
    with a lag: a heat sink cools a sample or two after the cloud). Missing values count as
    no step.

    ``wandering=False`` counts only an input that holds one value through the run and
    changes right at its edge (a pump switched on or off; a missing value counts as a
    change): what a baseline's learning of its holds takes as explained
    (:func:`longest_holds`), so that the holds it learns are those a wandering input's kick
    explains too, and its candidates are read with the limits it learned before kicks
    counted."""
    steps = np.abs(np.diff(u))              # steps[i]: from u[i] to u[i + 1]
    steps[~np.isfinite(steps)] = 0.0 if wandering else np.inf
    lag = KICK_LAG if wandering else 1
    into = np.zeros(len(starts), dtype=bool)
    out = np.zeros(len(starts), dtype=bool)
    for r, (s, e) in enumerate(zip(starts, ends)):
        inside = steps[s:e]
        top = inside.max() if inside.size else 0.0
        if not wandering and top > 0:
            continue
        before = steps[max(s - lag, 0):s]
        into[r] = before.size > 0 and before.max() > KICK_FACTOR * top
        turn = max(e - lag + 1, s)
        closing, rest = steps[turn:e + 1], steps[s:turn]
        out[r] = closing.size > 0 and closing.max() > KICK_FACTOR * (
            rest.max() if rest.size else 0.0)
    return into, out


def _side_within(v: np.ndarray, first: np.ndarray, direction: int, paused: np.ndarray | None,
                 step: float) -> np.ndarray:
    """Per run: True where the median of the :data:`SIDE_SAMPLES` readings beside it (from
    ``first``, going ``direction``; not across a pause nor past the window's edge) lies within
    ``step`` of the run's value: a coarse reading's noise can leave a run by two steps for one
    sample (a 0.4-kPa noise on a 1-kPa grid), while the readings around it stay where the run
    is. A frozen sensor recovers to wherever the process went meanwhile."""
    n = len(v)
    out = np.zeros(len(first), dtype=bool)
    for r, i in enumerate(first):
        held = v[i - direction]
        side = []
        while 0 <= i < n and len(side) < SIDE_SAMPLES:
            side.append(v[i])
            # the step from this reading to the next one out crosses a pause: stop
            gap = i if direction > 0 else i - 1
            if paused is not None and 0 <= gap < n - 1 and paused[gap]:
                break
            i += direction
        out[r] = len(side) == SIDE_SAMPLES and abs(np.median(side) - held) <= step
    return out


def _on_a_grid(moved: np.ndarray) -> bool:
    """True where the changes ``moved`` (all non-zero) are, but for :data:`GRID_SHARE`, whole
    multiples of the smallest: a reading rounded to a sensor's resolution, whose exact
    repeats are its noise falling within one step. A reading logged at full precision
    changes by amounts unrelated to its smallest change, and its exact repeat is a frozen
    sensor whatever the process does."""
    ratio = moved / moved.min()
    on_grid = np.abs(ratio - np.round(ratio)) <= GRID_TOLERANCE
    return bool(np.count_nonzero(on_grid) >= GRID_SHARE * moved.size)


def _among_its_neighbours(v: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                          resolution: float) -> np.ndarray:
    """Per run of equal samples ``v[starts[r]] .. v[ends[r]]`` (neither at an edge of
    ``v``) of a reading on a grid of ``resolution``: True where the run is the sensor's noise
    falling within one step while the process stood still. Beside the run (as many samples
    before it as it is long, and as many after) the reading changes by at most
    :data:`STILL_SCATTER` steps from one sample to the next (root mean square), so that it
    repeats by chance at all; each side scatters by at most :data:`STILL_SCATTER` times that
    change; and the run's value lies within the range of each side, or one step beyond it (a
    process standing still near a step's edge reads on either side of it). A sensor frozen
    while the process moves holds a value its later (or earlier) readings do not come near,
    one frozen amid an excursion sits among readings that scatter by more, and a reading
    whose noise spans many steps repeats only when frozen."""
    out = np.zeros(len(starts), dtype=bool)
    step = 1.01 * resolution
    for r, (s, e) in enumerate(zip(starts, ends)):
        if s == 0 or e == len(v) - 1:
            continue
        width = e - s + 1
        sides = (v[max(s - width, 0):s], v[e + 1:e + 1 + width])
        changes = np.concatenate([np.diff(side) for side in sides])
        if changes.size < 2:
            continue
        scatter = np.sqrt(np.nanmean(changes * changes))
        out[r] = scatter <= STILL_SCATTER * resolution and all(
            np.nanmin(side) - step <= v[s] <= np.nanmax(side) + step
            and np.nanstd(side) <= STILL_SCATTER * scatter for side in sides)
    return out


def _at_rest(v: np.ndarray, starts: np.ndarray, ends: np.ndarray, others_move: np.ndarray
             ) -> np.ndarray:
    """Per run of equal samples ``v[starts[r]] .. v[ends[r]]``: True where the run holds at
    the channel's zero while another measured channel moves: a part of the plant at rest (a
    stopped pump's flow and power while the tank it fills drains; a closed valve's leak,
    which a meter reads as 0.01 m^3/h), not a frozen sensor, which holds its last reading.
    The zero is 0, or for a channel that never changes sign (a flow, a power) a value within
    :data:`REST_SHARE` of its largest magnitude (a meter's zero offset); a signed reading
    (a position about 0) is at rest only at 0, and a sensor that fails to the end of its
    range (a broken wire's -50 C) is far from it. Where every measured channel holds, the
    machine is off (declare its ``running`` channel), and the run stays a stuck sensor."""
    finite = v[np.isfinite(v)]
    one_signed = finite.size and (finite.min() >= 0.0 or finite.max() <= 0.0)
    near = REST_SHARE * np.abs(finite).max() if one_signed else 0.0
    rest = np.abs(v[starts]) <= near
    if not rest.any() or not len(others_move):
        return np.zeros(len(starts), dtype=bool)
    moved = np.concatenate([[0], np.cumsum(others_move.any(axis=0))])  # steps moved before i
    return rest & (moved[ends] > moved[starts])
