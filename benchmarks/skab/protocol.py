"""Which healthy data each SKAB experiment is judged against, and how its windows are labelled.

SKAB's 34 test experiments come in four sessions of the one testbed, each at its own operating
point: ``other/5-14`` on 2020-02-08 (right after the anomaly-free file), ``other/1-4`` on
2020-03-01, ``valve1/0-15`` and ``valve2/0-3`` on 2020-03-09. Every experiment is one asset
of the benchmark's fleet (``other-5``, ``valve1-3``; the experiments of a session overlap in
time, so one asset per experiment keeps each one's rows its own), and its baseline is fitted
on healthy rows of its own session that are not part of it:

the session's healthy rows *before* the experiment, as an engineer who has watched the testbed
so far would have them: the *healthy prefixes* (the rows before the first labelled anomaly) of
the session's earlier experiments, and for ``other/5-14`` the anomaly-free file first (its
last 572 rows, which are the first rows of ``other/5``, cut). Only whole windows are taken
(rows spanning at least the class grid's ``min_duration``). No row of the judged experiment is
ever in its baseline; rows of *earlier* test experiments are, where they precede those
experiments' faults (without them only ``other/5-14`` could be baselined). An experiment whose
earlier healthy rows do not fill :data:`MIN_BASELINE_WINDOWS` windows cannot be baselined and
is reported as such (never scored).

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

#: the sessions: folder, the first-row date that picks its experiments, the session's name
SESSIONS = (("other", "2020-02-08", "other-feb08"), ("other", "2020-03-01", "other-mar01"),
            ("valve1", None, "valve1"), ("valve2", None, "valve2"))
#: whole windows of healthy rows a baseline needs (flows.baseline.MIN_WINDOWS)
MIN_BASELINE_WINDOWS = 3
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

    @property
    def usable(self) -> bool:
        return not self.reason


def baseline_plan(experiment: Experiment, every: list[Experiment], healthy: pd.DataFrame,
                  window: pd.Timedelta, min_cover: pd.Timedelta) -> BaselinePlan:
    """The healthy data of ``experiment``'s session that is not in it (module docstring):
    only the rows of windows they cover for at least ``min_cover`` (the class grid's
    ``min_duration``), as an engineer picks the whole healthy windows to fit on."""
    candidates = [] if experiment.session != "other-feb08" else [("anomaly-free", healthy)]
    for e in every:
        if e.session == experiment.session and e.start < experiment.start:
            prefix = e.prefix()
            if len(prefix) and prefix["timestamp"].iloc[-1] < experiment.start:
                candidates.append((f"{e.name} prefix", prefix))
    kept = [(source, whole) for source, rows in candidates
            if len(whole := _whole_windows(rows, window, min_cover))]
    sources, parts = tuple(s for s, _ in kept), tuple(p for _, p in kept)
    if not parts:
        return BaselinePlan((), (), None, None, "no earlier healthy rows in its session")
    start = min(p["timestamp"].iloc[0] for p in parts).floor(window)
    end = min(max(p["timestamp"].iloc[-1] for p in parts).floor(window) + window,
              experiment.start.floor(window))
    covered = len({t for p in parts for t in p["timestamp"].dt.floor(window)
                   if start <= t < end})
    if covered < MIN_BASELINE_WINDOWS:
        return BaselinePlan(sources, parts, None, None,
                            f"its session's earlier healthy rows cover {covered} whole "
                            f"window(s) of {window}; a baseline needs {MIN_BASELINE_WINDOWS}")
    return BaselinePlan(sources, parts, start, end)


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
