"""Metrics of the benchmark, from the raw per-asset-night table.

* ``ratio``: a detector's statistic over its per-asset threshold (alarm when > 1). For the gray
  box it is zeta / epsilon of one tier, and the roll-up is the largest tier ratio (an asset
  alarms when any tier does, as the nightly flow reports it).
* realized false-alarm rate: alarmed healthy asset-nights / healthy asset-nights, with a
  Clopper-Pearson 95 % interval.
* detection rate: faulty assets with an alarm within ``within`` nights of the onset (nights
  onset .. onset + within - 1) / faulty assets; a failed fit counts as no alarm.
* delay: first alarmed night minus the onset, median over the detected assets.
* AUC: probability that a faulty night's ratio exceeds a healthy night's (Mann-Whitney, ties
  count one half), faulty nights = the evaluated nights from the onset on.
* matched detection rate: the detection rate when every asset's ratio is compared with one
  common level chosen so that at most ``target`` of the healthy nights (of that detector and
  model error) alarm. It removes calibration error from the comparison (an oracle: the level
  is tuned on the very healthy nights it is scored on).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from benchmarks.detection.classic import DETECTORS

TIERS = ("linear", "nonlinear", "noise", "level")
GRAYBOX = "graybox"
GRAYBOX_TIERS = tuple(f"graybox.{t}" for t in TIERS)
ALL_DETECTORS = DETECTORS + (GRAYBOX,) + GRAYBOX_TIERS
LABELS = {"redline": "3-sigma redline", "adaptive": "adaptive (rolling) threshold",
          "cusum_mean": "CUSUM mean", "cusum_var": "CUSUM variance", "glr": "GLR mean/variance",
          GRAYBOX: "gray box (any tier)", "graybox.linear": "gray box: linear tier",
          "graybox.nonlinear": "gray box: nonlinear tier", "graybox.noise": "gray box: noise tier",
          "graybox.level": "gray box: level tier"}


def ratio(table: pd.DataFrame, detector: str) -> pd.Series:
    """Statistic / threshold of ``detector`` for every row (NaN where the fit failed)."""
    if detector in DETECTORS:
        stat, thr = table[f"{detector}_stat"], table[f"{detector}_thr"]
        out = stat / thr
        return out.where(thr > 0, np.where(stat > 0, np.inf, 0.0))
    if detector == GRAYBOX:
        parts = [ratio(table, t) for t in GRAYBOX_TIERS]
        return pd.concat(parts, axis=1).max(axis=1, skipna=False)
    tier = detector.split(".", 1)[1]
    if f"gb_{tier}_zeta" not in table:
        return pd.Series(np.nan, index=table.index)
    zeta, eps = table[f"gb_{tier}_zeta"], table[f"gb_{tier}_eps"]
    out = zeta / eps
    return out.where(eps > 0, np.where(zeta > 0, np.inf, 0.0)).where(zeta.notna())


def target_rate(detector: str, false_alarm_rate: float) -> float:
    """The false-alarm rate a detector is calibrated to (a gray-box tier gets its Bonferroni
    share: the target over tiers x channels)."""
    return false_alarm_rate / len(TIERS) if detector in GRAYBOX_TIERS else false_alarm_rate


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) interval of a binomial rate: ``k`` events in ``n`` trials."""
    if n == 0:
        return (np.nan, np.nan)
    a = (1 - level) / 2
    low = 0.0 if k == 0 else float(stats.beta.ppf(a, k, n - k + 1))
    high = 1.0 if k == n else float(stats.beta.ppf(1 - a, k + 1, n - k))
    return low, high


def rate(alarms: int, trials: int) -> dict:
    """Alarms, trials, the rate and its 95 % Clopper-Pearson interval."""
    nan = float("nan")
    return {"alarms": alarms, "asset_nights": trials, "rate": alarms / trials if trials else nan,
            "interval": clopper_pearson(alarms, trials) if trials else (nan, nan)}


def auc(negatives: np.ndarray, positives: np.ndarray) -> float:
    """P(positive > negative) + P(tie) / 2 (Mann-Whitney U / (n_pos n_neg))."""
    negatives = np.asarray(negatives, dtype=float)
    positives = np.asarray(positives, dtype=float)
    negatives, positives = negatives[~np.isnan(negatives)], positives[~np.isnan(positives)]
    if len(negatives) == 0 or len(positives) == 0:
        return np.nan
    ranks = stats.rankdata(np.concatenate([negatives, positives]))
    n_pos, n_neg = len(positives), len(negatives)
    return float((ranks[n_neg:].sum() - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg))


def matched_level(healthy: np.ndarray, target: float) -> float:
    """Smallest level ``c`` such that at most ``floor(target n)`` healthy ratios exceed it."""
    values = np.sort(np.asarray(healthy, dtype=float)[~np.isnan(healthy)])[::-1]
    if len(values) == 0:
        return np.nan
    allowed = int(np.floor(target * len(values) + 1e-9))
    return float(values[allowed]) if allowed < len(values) else -np.inf


def with_ratios(table: pd.DataFrame, detectors=ALL_DETECTORS) -> pd.DataFrame:
    out = table.copy()
    for d in detectors:
        out[f"ratio.{d}"] = ratio(table, d)
    return out


def false_alarms(table: pd.DataFrame, false_alarm_rate: float = 0.01,
                 detectors=ALL_DETECTORS) -> pd.DataFrame:
    """Realized false-alarm rate per detector and model error, on the healthy assets' nights."""
    healthy = table[table["kind"] == "healthy"]
    rows = []
    for error, group in healthy.groupby("model_error"):
        for d in detectors:
            r = ratio(group, d)
            valid = r.dropna()
            k, n = int((valid > 1).sum()), int(len(valid))
            low, high = clopper_pearson(k, n)
            target = target_rate(d, false_alarm_rate)
            rows.append({"detector": d, "model_error": error, "nights": n, "alarms": k,
                         "rate": k / n if n else np.nan, "ci_low": low, "ci_high": high,
                         "target": target, "failed": int(r.isna().sum()),
                         "exceeds": bool(n and k / n > target),
                         "significant": bool(n and low > target)})
    return pd.DataFrame(rows)


def detection(table: pd.DataFrame, within: int = 3, false_alarm_rate: float = 0.01,
              detectors=ALL_DETECTORS) -> pd.DataFrame:
    """Per detector, model error, fault kind and magnitude: detection rate within ``within``
    nights, median delay, AUC and the detection rate at a matched false-alarm rate."""
    rows = []
    for error, by_error in table.groupby("model_error"):
        healthy = by_error[by_error["kind"] == "healthy"]
        faulty = by_error[by_error["kind"] != "healthy"]
        for d in detectors:
            h = ratio(healthy, d).to_numpy()
            level = matched_level(h, target_rate(d, false_alarm_rate))
            r_all = ratio(faulty, d)
            for (kind, magnitude), cell in faulty.groupby(["kind", "magnitude"]):
                r = r_all.loc[cell.index]
                delay_nights = cell["night"] - cell["onset"]
                early = delay_nights < within
                per_asset = pd.DataFrame({"asset": cell["asset_id"], "seed": cell["seed"],
                                          "delay": delay_nights, "alarm": (r > 1) & early,
                                          "matched": (r > level) & early})
                assets = per_asset.groupby(["seed", "asset"])
                detected = assets["alarm"].any()
                first = per_asset[per_asset["alarm"]].groupby(["seed", "asset"])["delay"].min()
                matched = assets["matched"].any()
                rows.append({"detector": d, "model_error": error, "kind": kind,
                             "magnitude": magnitude, "assets": int(len(detected)),
                             "detected": int(detected.sum()),
                             "rate": float(detected.mean()) if len(detected) else np.nan,
                             "median_delay": float(first.median()) if len(first) else np.nan,
                             "auc": auc(h, r[early].to_numpy()),
                             "matched_rate": float(matched.mean()) if len(matched) else np.nan,
                             "matched_level": level,
                             "failed": int(r.isna().sum())})
    return pd.DataFrame(rows)


def tier_of_first_alarm(table: pd.DataFrame, within: int = 3) -> pd.DataFrame:
    """For the gray box: which tiers alarm on faulty nights (share of alarmed nights per tier)."""
    faulty = table[(table["kind"] != "healthy") & (table["night"] - table["onset"] < within)]
    rows = []
    for (error, kind, magnitude), cell in faulty.groupby(["model_error", "kind", "magnitude"]):
        row = {"model_error": error, "kind": kind, "magnitude": magnitude, "nights": len(cell)}
        for t in TIERS:
            row[t] = float((ratio(cell, f"graybox.{t}") > 1).mean())
        rows.append(row)
    return pd.DataFrame(rows)
