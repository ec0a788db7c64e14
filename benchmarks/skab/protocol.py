"""Which healthy data each SKAB experiment is judged against, and how its windows are labelled.

SKAB's 34 test experiments come in three sessions of the one testbed (one day's log each),
each at its own operating point: ``other/5-14`` on 2020-02-08 (right after the anomaly-free
file; flow 126 l/min), ``other/1-4`` on 2020-03-01 (77 l/min), and ``valve1/0-15`` then
``valve2/0-3`` on 2020-03-09 (32 l/min). The two valve folders are one session: one log from
07:14 to 14:14 UTC, the files back to back but for a 22-minute pause after ``valve1/15``, the
same operating point (flow 32 l/min, vibration 0.027 and 0.040 g, motor 68-70 C); only the
valve the fault closes differs (inlet, outlet). Every experiment is one asset of the
benchmark's fleet (``other-5``, ``valve1-3``; the experiments of a session overlap in time, so
one asset per experiment keeps each one's rows its own), and its baseline is fitted on healthy
rows of its own session that are not part of it:

the session's healthy rows *before* the experiment, as an engineer who has watched the testbed
so far would have them: the *healthy prefixes* (the rows before the first labelled anomaly) of
the session's earlier experiments, and for ``other/5-14`` the anomaly-free file first (its
last 572 rows, which are the first rows of ``other/5``, cut). Only whole windows are taken
(rows spanning at least the class grid's ``min_duration``). With ``recent`` (an integer), only
the most recent ``recent`` of those whole windows are kept: the engineer re-baselines on the
last stretch of healthy running, as after a maintenance or a test that changed the plant
(:func:`baseline_plan`). No row of the judged experiment is ever in its baseline; rows of
*earlier* test experiments are, where they precede those experiments' faults (without them
only ``other/5-14`` could be baselined). An experiment whose earlier healthy rows do not fill
:data:`MIN_BASELINE_WINDOWS` windows cannot be baselined and is reported as such (never
scored); with ``later`` (an option, off by default) it is baselined on the *earliest* whole
healthy windows of its session after it instead (the prefixes of later experiments, after
its last window): none of its own rows, the same operating point, but not what an engineer
watching the testbed live could have had, so the report lists such experiments.

Windows are the product's analysis windows (``[nightly] window``, aligned to UTC). A window
is *fault* when it holds a labelled anomaly row, *overlap* when it holds none of its own but
rows another file labels anomalous (the files of a session were cut from one log and overlap:
other/13's first 7 minutes are other/12's cavitation, labelled 1 there and 0 in other/13),
*healthy* when all its rows come before the experiment's first anomaly, and *after* otherwise
(rows after the anomaly ended). Overlap windows are scored neither way, and no baseline takes
a row any file labels anomalous. The point-wise scores keep each file's own labels, as SKAB's
leaderboard does.
"""
from __future__ import annotations

import pathlib
from dataclasses import dataclass

import numpy as np
import pandas as pd

from benchmarks.skab.data import HEALTHY_FILE, HEALTHY_OVERLAP_ROWS, read_skab_csv
from graybox.telemetry.policy import format_duration

#: the sessions: folder, the first-row date that picks its experiments, the session's name
#: (valve1 and valve2 are one log of 2020-03-09 at one operating point: module docstring)
SESSIONS = (("other", "2020-02-08", "other-feb08"), ("other", "2020-03-01", "other-mar01"),
            ("valve1", None, "valve-mar09"), ("valve2", None, "valve-mar09"))
#: whole windows of healthy rows a baseline needs (flows.baseline.MIN_WINDOWS)
MIN_BASELINE_WINDOWS = 3
#: whole healthy windows a baseline takes, the latest before the experiment (None: all); see
#: :func:`baseline_plan`. One hour of 5-minute windows, chosen before any run with it;
#: docs/benchmarks.md ("SKAB") shows 6, 9 and all beside it
RECENT_WINDOWS: int | None = 12
#: the rows' column marking rows another file labels anomalous at the same time
FOREIGN = "foreign_anomaly"


@dataclass(frozen=True)
class Experiment:
    """One SKAB test file: its asset, session and labelled rows (UTC)."""

    name: str                 # "valve1/3"
    path: pathlib.Path
    session: str
    rows: pd.DataFrame        # read_skab_csv: timestamp, channels, anomaly, changepoint

    @property
    def asset(self) -> str:
        return self.name.replace("/", "-")

    @property
    def start(self) -> pd.Timestamp:
        return self.rows["timestamp"].iloc[0]

    @property
    def end(self) -> pd.Timestamp:
        """Just after the last row."""
        return self.rows["timestamp"].iloc[-1] + pd.Timedelta(seconds=1)

    @property
    def onset(self) -> pd.Timestamp | None:
        """The first labelled anomaly row, or None."""
        anomalous = self.rows["anomaly"].to_numpy() > 0
        return self.rows["timestamp"][anomalous].iloc[0] if anomalous.any() else None

    def prefix(self) -> pd.DataFrame:
        """The rows before the first anomaly, its own or another file's at the same time (the
        whole file if none)."""
        flagged = (self.rows["anomaly"].to_numpy() > 0) | self.foreign()
        if not flagged.any():
            return self.rows
        return self.rows[self.rows["timestamp"] < self.rows["timestamp"][flagged].iloc[0]]

    def foreign(self) -> np.ndarray:
        """Rows another experiment's file labels anomalous at the same time (other/13's first
        minutes are other/12's cavitation: the files were cut from one log)."""
        if FOREIGN not in self.rows:
            return np.zeros(len(self.rows), bool)
        return self.rows[FOREIGN].to_numpy() > 0


def _number(path: pathlib.Path) -> int:
    return int(path.stem)


def experiments(data_dir) -> list[Experiment]:
    """Every test experiment of the dataset at ``data_dir``, by session and number; each
    one's rows carry :data:`FOREIGN` (labelled anomalous by another file at that time)."""
    data = pathlib.Path(data_dir) / "data"
    found = []
    for folder, date, session in SESSIONS:
        for path in sorted((data / folder).glob("*.csv"), key=_number):
            rows = read_skab_csv(path, asset_id=f"{folder}-{path.stem}")
            if date is None or rows["timestamp"].iloc[0].strftime("%Y-%m-%d") == date:
                found.append(Experiment(f"{folder}/{path.stem}", path, session, rows))
    return with_foreign_labels(found)


def with_foreign_labels(found: list[Experiment]) -> list[Experiment]:
    """The experiments with :data:`FOREIGN` set on rows another file labels anomalous."""
    out = []
    for experiment in found:
        others = [e.rows.loc[e.rows["anomaly"] > 0, "timestamp"] for e in found
                  if e is not experiment]
        flagged = pd.concat(others) if others else pd.Series([], dtype=object)
        rows = experiment.rows.copy()
        rows[FOREIGN] = rows["timestamp"].isin(flagged).astype(float)
        out.append(Experiment(experiment.name, experiment.path, experiment.session, rows))
    return out


def healthy_file_rows(data_dir) -> pd.DataFrame:
    """The anomaly-free file's rows without the tail it shares with ``other/5``."""
    return read_skab_csv(pathlib.Path(data_dir) / HEALTHY_FILE, "anomaly-free",
                         drop_last=HEALTHY_OVERLAP_ROWS)


@dataclass(frozen=True)
class BaselinePlan:
    """The healthy rows an experiment's baseline is fitted on, and the whole windows
    ``[start, end)`` that cover them; ``reason`` says why there is none (rows empty)."""

    sources: tuple[str, ...]           # "anomaly-free" or "valve1/0 prefix", ...
    parts: tuple[pd.DataFrame, ...]
    start: pd.Timestamp | None
    end: pd.Timestamp | None
    reason: str = ""
    later: bool = False                # on windows after the experiment (baseline_plan)

    @property
    def usable(self) -> bool:
        return not self.reason


def baseline_plan(experiment: Experiment, every: list[Experiment], healthy: pd.DataFrame,
                  window: pd.Timedelta, min_cover: pd.Timedelta,
                  recent: int | None = None, later: bool = False) -> BaselinePlan:
    """The healthy data of ``experiment``'s session that is not in it (module docstring):
    only the rows of windows they cover for at least ``min_cover`` (the class grid's
    ``min_duration``), as an engineer picks the whole healthy windows to fit on; with
    ``recent``, only the latest ``recent`` of those windows (all of them when None).

    With ``later``, an experiment whose earlier healthy rows are too few is baselined on the
    *earliest* whole healthy windows of its session after it instead (up to ``recent``): the
    prefixes of later experiments, none of its own rows, but not what a user watching the
    testbed live could have had; the plan says so (``later``)."""
    candidates = [] if experiment.session != "other-feb08" else [("anomaly-free", healthy)]
    for e in every:
        if e.session == experiment.session and e.start < experiment.start:
            prefix = e.prefix()
            if len(prefix) and prefix["timestamp"].iloc[-1] < experiment.start:
                candidates.append((f"{e.name} prefix", prefix))
    plan = _plan(_recent(_whole(candidates, window, min_cover), window, recent, latest=True),
                 window, end=experiment.start.floor(window))
    if plan.usable or not later:
        return plan
    after = experiment.end.ceil(window)
    candidates = [(f"{e.name} prefix", prefix[prefix["timestamp"] >= after])
                  for e in every if e.session == experiment.session and e is not experiment
                  and len(prefix := e.prefix()) and prefix["timestamp"].iloc[-1] >= after]
    found = _plan(_recent(_whole(candidates, window, min_cover), window, recent, latest=False),
                  window, later=True)
    return found if found.usable else plan


def _whole(candidates, window, min_cover) -> list[tuple[str, pd.DataFrame]]:
    return [(source, whole) for source, rows in candidates
            if len(whole := _whole_windows(rows, window, min_cover))]


def _recent(kept, window, recent, latest: bool) -> list[tuple[str, pd.DataFrame]]:
    return kept if recent is None else _latest_windows(kept, window, recent, latest)


def _plan(kept: list[tuple[str, pd.DataFrame]], window: pd.Timedelta,
          end: pd.Timestamp | None = None, later: bool = False) -> BaselinePlan:
    """The plan of the whole windows ``kept`` (source, rows), ending at ``end`` at the
    latest."""
    sources, parts = tuple(s for s, _ in kept), tuple(p for _, p in kept)
    where = "later" if later else "earlier"
    if not parts:
        return BaselinePlan((), (), None, None, f"no {where} healthy rows in its session",
                            later)
    start = min(p["timestamp"].iloc[0] for p in parts).floor(window)
    stop = max(p["timestamp"].iloc[-1] for p in parts).floor(window) + window
    stop = stop if end is None else min(stop, end)
    covered = len({t for p in parts for t in p["timestamp"].dt.floor(window)
                   if start <= t < stop})
    if covered < MIN_BASELINE_WINDOWS:
        return BaselinePlan(sources, parts, None, None,
                            f"its session's {where} healthy rows cover {covered} whole "
                            f"window(s) of {format_duration(window.total_seconds())}; a "
                            f"baseline needs {MIN_BASELINE_WINDOWS}",
                            later)
    return BaselinePlan(sources, parts, start, stop, later=later)


def _latest_windows(parts: list[tuple[str, pd.DataFrame]], window: pd.Timedelta, count: int,
                    latest: bool = True) -> list[tuple[str, pd.DataFrame]]:
    """The rows of the latest (``latest``, else the earliest) ``count`` windows ``parts``
    (source, rows) fall in; a part left without rows is dropped."""
    if count < 1:
        raise ValueError(f"recent must be at least 1 window, not {count}")
    starts = sorted({t for _, rows in parts for t in rows["timestamp"].dt.floor(window)})
    kept = set(starts[-count:] if latest else starts[:count])
    out = []
    for source, rows in parts:
        inside = rows["timestamp"].dt.floor(window).isin(list(kept)).to_numpy()
        if inside.any():
            out.append((source, rows[inside]))
    return out


def _whole_windows(rows: pd.DataFrame, window: pd.Timedelta, min_cover: pd.Timedelta
                   ) -> pd.DataFrame:
    """The rows of the windows whose rows span at least ``min_cover``."""
    starts = rows["timestamp"].dt.floor(window)
    span = rows.groupby(starts)["timestamp"].agg(lambda t: t.iloc[-1] - t.iloc[0])
    keep = span.index[span >= min_cover]
    return rows[starts.isin(keep).to_numpy()]


def window_starts(experiment: Experiment, window: pd.Timedelta) -> pd.DatetimeIndex:
    """The analysis windows the experiment's rows fall in."""
    return pd.date_range(experiment.start.floor(window), experiment.end.ceil(window) - window,
                         freq=window)


def window_labels(experiment: Experiment, window: pd.Timedelta) -> pd.Series:
    """``fault``, ``healthy``, ``overlap`` or ``after`` per window start (module docstring)."""
    rows = experiment.rows
    starts = rows["timestamp"].dt.floor(window)
    anomalous = rows["anomaly"].to_numpy() > 0
    foreign = experiment.foreign()
    onset = experiment.onset
    labels = {}
    for begin in window_starts(experiment, window):
        inside = (starts == begin).to_numpy()
        if anomalous[inside].any():
            labels[begin] = "fault"
        elif foreign[inside].any():
            labels[begin] = "overlap"
        elif onset is None or begin + window <= onset:
            labels[begin] = "healthy"
        else:
            labels[begin] = "after" if begin >= onset else "healthy"
    return pd.Series(labels, dtype=object)


def point_labels(experiment: Experiment) -> np.ndarray:
    """SKAB's point labels (``anomaly``) as 0/1."""
    return (experiment.rows["anomaly"].to_numpy() > 0).astype(int)
