"""The markdown report, its plots and CSV files, from the raw per-asset-night table."""
from __future__ import annotations

import json
import math
import pathlib
import re
from dataclasses import dataclass

import numpy as np
import pandas as pd

from benchmarks.detection import metrics
from benchmarks.detection.cells import markdown_table, percent
from benchmarks.detection.classic import DETECTORS
from benchmarks.detection.grid import KINDS, UNITS, UNRECORDED_CANDIDATE_NIGHTS, Grid

MAIN = DETECTORS + (metrics.GRAYBOX,)
TARGET_KINDS = ("friction", "nonlinear", "noise")
STYLE = {"redline": ("tab:red", "o", "-"), "adaptive": ("tab:orange", "s", "-"),
         "cusum_mean": ("tab:purple", "^", "-"), "cusum_var": ("tab:brown", "v", "-"),
         "glr": ("tab:gray", "D", "-"), "graybox": ("tab:blue", "*", "-"),
         "graybox.linear": ("tab:cyan", "", "--"), "graybox.nonlinear": ("tab:olive", "", "--"),
         "graybox.noise": ("tab:green", "", "--"), "graybox.level": ("tab:pink", "", "--")}


@dataclass
class Results:
    """Everything the report is made of."""

    table: pd.DataFrame          # raw per asset-night rows
    detection: pd.DataFrame      # metrics.detection
    false_alarms: pd.DataFrame   # metrics.false_alarms
    tiers: pd.DataFrame          # metrics.tier_of_first_alarm
    grid: Grid
    run: dict                    # command, wall time, load, timings, structures, versions


def summarize(table: pd.DataFrame, grid: Grid, run: dict) -> Results:
    within = grid.post_nights
    return Results(table, metrics.detection(table, within, grid.false_alarm_rate),
                   metrics.false_alarms(table, grid.false_alarm_rate),
                   metrics.tier_of_first_alarm(table, within), grid, run)


# ------------------------------------------------------------------------------------------
# formatting helpers
# ------------------------------------------------------------------------------------------
def _num(x: float, digits: int = 2) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def _err(e: float) -> str:
    return f"{100 * e:.0f} %"


# ------------------------------------------------------------------------------------------
# verdicts
# ------------------------------------------------------------------------------------------
def headline(results: Results) -> pd.DataFrame:
    """The target test: per model error and kind (a)-(c), the magnitudes where the redline
    detects <= 20 %, the gray box's detection rate within 3 nights there, and whether the target
    (>= 95 %, with <= 1 % realized false alarms) is met."""
    d = results.detection.set_index(["detector", "model_error", "kind", "magnitude"])
    fa = results.false_alarms.set_index(["detector", "model_error"])
    rows = []
    for error in results.grid.model_errors:
        gb_fa = fa.loc[(metrics.GRAYBOX, error), "rate"]
        for kind in TARGET_KINDS:
            for magnitude in results.grid.magnitudes.get(kind, ()):
                key = (error, kind, float(magnitude))
                redline = d.loc[("redline",) + key]
                gray = d.loc[(metrics.GRAYBOX,) + key]
                in_scope = redline["rate"] <= 0.20
                met = bool(in_scope and gray["rate"] >= 0.95 and gb_fa <= results.grid.false_alarm_rate)
                rows.append({"model_error": error, "kind": kind, "magnitude": float(magnitude),
                             "assets": int(gray["assets"]), "redline_rate": redline["rate"],
                             "in_scope": bool(in_scope), "graybox_rate": gray["rate"],
                             "graybox_delay": gray["median_delay"], "graybox_auc": gray["auc"],
                             "graybox_matched": gray["matched_rate"],
                             "graybox_false_alarms": gb_fa, "met": met})
    return pd.DataFrame(rows)


def _best_classic(results: Results, error: float, kind: str, magnitude: float) -> tuple[str, float]:
    d = results.detection
    cell = d[(d.model_error == error) & (d.kind == kind) & (d.magnitude == magnitude)
             & d.detector.isin(DETECTORS)]
    fa = results.false_alarms.set_index(["detector", "model_error"])["rate"]
    ok = cell[[fa.loc[(x, error)] <= results.grid.false_alarm_rate for x in cell.detector]]
    pool = ok if len(ok) else cell
    best = pool.loc[pool["rate"].idxmax()]
    return best["detector"], float(best["rate"])


# ------------------------------------------------------------------------------------------
# plots
# ------------------------------------------------------------------------------------------
def plot_rates(results: Results, path: pathlib.Path, column: str, title: str,
               detectors=MAIN) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    errors = list(results.grid.model_errors)
    kinds = [k for k in KINDS if k in results.grid.magnitudes]
    fig, axes = plt.subplots(len(errors), len(kinds), figsize=(3.6 * len(kinds), 2.9 * len(errors)),
                             squeeze=False, sharey=True)
    d = results.detection
    flagged = set(map(tuple, results.false_alarms.loc[results.false_alarms.exceeds,
                                                      ["detector", "model_error"]].to_numpy()))
    for i, error in enumerate(errors):
        for j, kind in enumerate(kinds):
            ax = axes[i][j]
            mags = sorted(results.grid.magnitudes[kind])
            # small horizontal offsets keep coinciding lines visible; the gray box is drawn last
            order = [x for x in detectors if x != metrics.GRAYBOX] + [x for x in detectors
                                                                    if x == metrics.GRAYBOX]
            for n, det in enumerate(order):
                cell = d[(d.detector == det) & (d.model_error == error) & (d.kind == kind)]
                cell = cell.set_index("magnitude").reindex(mags)
                color, marker, line = STYLE[det]
                label = metrics.LABELS[det] + (" (FA > target)" if (det, error) in flagged else "")
                shift = 0.03 * (n - (len(order) - 1) / 2)
                ax.plot(np.arange(len(mags)) + shift, cell[column], color=color, marker=marker or "o",
                        linestyle=line if (det, error) not in flagged else ":",
                        linewidth=2.2 if det == metrics.GRAYBOX else 1.2,
                        markersize=8 if det == metrics.GRAYBOX else 4, label=label,
                        zorder=3 if det == metrics.GRAYBOX else 2)
            ax.axhline(0.95, color="black", linewidth=0.6, linestyle="--")
            ax.axhline(0.20, color="tab:red", linewidth=0.6, linestyle=":")
            ax.set_xticks(range(len(mags)), [f"{m:g}" for m in mags])
            ax.set_ylim(-0.03, 1.03)
            if i == 0:
                ax.set_title(KINDS[kind], fontsize=9)
            if i == len(errors) - 1:
                ax.set_xlabel(f"magnitude ({UNITS[kind]})", fontsize=8)
            if j == 0:
                ax.set_ylabel(f"model error {_err(error)}\ndetection rate", fontsize=9)
    handles, labels = [], []
    for ax in axes.ravel():
        for h, lab in zip(*ax.get_legend_handles_labels()):
            base = lab.replace(" (FA > target)", "")
            if base not in [x.replace(" (FA > target)", "") for x in labels]:
                handles.append(h)
                labels.append(base)
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 5), fontsize=8,
               frameon=False)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 0.97))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_false_alarms(results: Results, path: pathlib.Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fa = results.false_alarms
    detectors = list(MAIN + metrics.GRAYBOX_TIERS)
    errors = list(results.grid.model_errors)
    fig, ax = plt.subplots(figsize=(10, 3.6))
    width = 0.8 / len(errors)
    for k, error in enumerate(errors):
        sub = fa[fa.model_error == error].set_index("detector").reindex(detectors)
        x = np.arange(len(detectors)) + (k - (len(errors) - 1) / 2) * width
        ax.bar(x, 100 * sub["rate"], width, label=f"model error {_err(error)}")
        ax.errorbar(x, 100 * sub["rate"], yerr=[100 * (sub["rate"] - sub["ci_low"]),
                                                100 * (sub["ci_high"] - sub["rate"])],
                    fmt="none", ecolor="black", elinewidth=0.7, capsize=2)
    ax.axhline(100 * results.grid.false_alarm_rate, color="black", linestyle="--", linewidth=0.8,
               label="target 1 % per asset-night")
    ax.set_xticks(range(len(detectors)), [metrics.LABELS[d] for d in detectors], rotation=25,
                  ha="right", fontsize=8)
    ax.set_ylabel("false alarms per healthy asset-night (%)")
    ax.set_title("Realized false-alarm rate on healthy nights (95 % Clopper-Pearson intervals)",
                 fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ------------------------------------------------------------------------------------------
# markdown
# ------------------------------------------------------------------------------------------
def _fa_table(results: Results) -> str:
    fa = results.false_alarms.set_index(["detector", "model_error"])
    header = ["detector", "target"] + [f"model error {_err(e)}" for e in results.grid.model_errors]
    rows = []
    for det in MAIN + metrics.GRAYBOX_TIERS:
        target = metrics.target_rate(det, results.grid.false_alarm_rate)
        row = [metrics.LABELS[det], percent(target, 1)]
        for error in results.grid.model_errors:
            r = fa.loc[(det, error)]
            flag = (" **⚠ significantly above target**" if r["significant"] else
                    " ⚠ above target (within the CI)" if r["exceeds"] else "")
            row.append(f"{percent(r['rate'], 1)} ({int(r['alarms'])}/{int(r['nights'])}, "
                       f"CI {percent(r['ci_low'], 1)}–{percent(r['ci_high'], 1)}){flag}")
        rows.append(row)
    return markdown_table(header, rows)


def _main_table(results: Results, error: float, detectors=MAIN) -> str:
    d = results.detection.set_index(["detector", "model_error", "kind", "magnitude"])
    fa = results.false_alarms.set_index(["detector", "model_error"])
    header = ["fault", "magnitude", "assets"]
    for det in detectors:
        mark = " ⚠" if fa.loc[(det, error), "exceeds"] else ""
        header.append(metrics.LABELS[det] + mark)
    rows = []
    for kind in KINDS:
        for magnitude in sorted(results.grid.magnitudes.get(kind, ())):
            key = (error, kind, float(magnitude))
            first = d.loc[(detectors[0],) + key]
            row = [KINDS[kind], f"{magnitude:g}", str(int(first["assets"]))]
            for det in detectors:
                c = d.loc[(det,) + key]
                delay = "" if math.isnan(c["median_delay"]) else f", d {c['median_delay']:.0f}"
                cell = f"{percent(c['rate'])}{delay}, AUC {_num(c['auc'])}"
                if det == metrics.GRAYBOX:
                    cell = f"**{cell}**"
                row.append(cell)
            rows.append(row)
    return markdown_table(header, rows)


def _matched_table(results: Results) -> str:
    d = results.detection.set_index(["detector", "model_error", "kind", "magnitude"])
    header = ["model error", "fault", "magnitude"] + [metrics.LABELS[x] for x in MAIN]
    rows = []
    for error in results.grid.model_errors:
        for kind in KINDS:
            for magnitude in sorted(results.grid.magnitudes.get(kind, ())):
                key = (error, kind, float(magnitude))
                rows.append([_err(error), KINDS[kind], f"{magnitude:g}"]
                            + [percent(d.loc[(x,) + key, "matched_rate"]) for x in MAIN])
    return markdown_table(header, rows)


def _tier_table(results: Results) -> str:
    d = results.detection.set_index(["detector", "model_error", "kind", "magnitude"])
    fa = results.false_alarms.set_index(["detector", "model_error"])
    header = ["model error", "fault", "magnitude"] + [metrics.LABELS[t] for t in
                                                      (metrics.GRAYBOX,) + metrics.GRAYBOX_TIERS]
    rows = []
    for error in results.grid.model_errors:
        row = [_err(error), "**healthy (false alarms)**", ""]
        for t in (metrics.GRAYBOX,) + metrics.GRAYBOX_TIERS:
            row.append(f"{percent(fa.loc[(t, error), 'rate'], 1)} "
                       f"(target {percent(fa.loc[(t, error), 'target'], 1)})")
        rows.append(row)
        for kind in KINDS:
            for magnitude in sorted(results.grid.magnitudes.get(kind, ())):
                key = (error, kind, float(magnitude))
                row = [_err(error), KINDS[kind], f"{magnitude:g}"]
                for t in (metrics.GRAYBOX,) + metrics.GRAYBOX_TIERS:
                    c = d.loc[(t,) + key]
                    row.append(f"{percent(c['rate'])}, AUC {_num(c['auc'])}")
                rows.append(row)
    return markdown_table(header, rows)


def _structure_table(results: Results) -> str:
    s = pd.DataFrame(results.run.get("structures", []))
    if s.empty:
        return "(no gray-box baselines)"
    rows = []
    for error, g in s.groupby("model_error"):
        ok = g[g.get("error").isna()] if "error" in g else g
        failures = len(g) - len(ok)
        orders = ok.groupby(["diff_order", "seasonal_order", "period"]).size()
        differencing = ", ".join(f"(1-B)^{a} (1-B^{p})^{b}: {n}" if b else f"(1-B)^{a}: {n}"
                                 for (a, b, p), n in orders.items())
        rows.append([_err(error), str(len(g)), str(failures), differencing,
                     f"{ok.ar_order.median():.0f} ({ok.ar_order.min()}–{ok.ar_order.max()})",
                     f"{ok.embedding_dim.median():.0f}", f"{100 * ok.nonlinear_needed.mean():.0f} %",
                     " / ".join(_num(ok[f'epsilon_{t}'].median(), 4) for t in metrics.TIERS),
                     " / ".join(_num(ok[f'dof_{t}'].median(), 1) for t in metrics.TIERS)])
    return markdown_table(["model error", "baselines", "failed", "differencing (count)",
                           "AR order median (range)", "embedding m", "network needed",
                           "median epsilon lin / nonlin / noise",
                           "median dof h lin / nonlin / noise"], rows)


def _top_changes(results: Results) -> str:
    t = results.table
    faulty = t[(t.kind != "healthy") & (t.night - t.onset < results.grid.post_nights)]
    if "gb_top" not in faulty:
        return ""
    ratio = metrics.ratio(faulty, metrics.GRAYBOX)
    alarmed = faulty[ratio > 1]
    rows = []
    for (error, kind), g in alarmed.groupby(["model_error", "kind"]):
        counts = g["gb_top"].value_counts(normalize=True).head(3)
        rows.append([_err(error), KINDS[kind], str(len(g)),
                     ", ".join(f"{k} {100 * v:.0f} %" for k, v in counts.items())])
    healthy = t[t.kind == "healthy"]
    hr = metrics.ratio(healthy, metrics.GRAYBOX)
    for error, g in healthy[hr > 1].groupby("model_error"):
        counts = g["gb_top"].value_counts(normalize=True).head(3)
        rows.append([_err(error), "healthy (false alarms)", str(len(g)),
                     ", ".join(f"{k} {100 * v:.0f} %" for k, v in counts.items())])
    return markdown_table(["model error", "fault", "alarmed nights",
                           "largest zeta/epsilon: tier:top parameter"], rows)


def _healthy_ratio_quantiles(results: Results) -> str:
    t = results.table[results.table.kind == "healthy"]
    rows = []
    for error, g in t.groupby("model_error"):
        for det in (metrics.GRAYBOX,) + metrics.GRAYBOX_TIERS:
            r = metrics.ratio(g, det).dropna()
            if r.empty:
                continue
            q = np.quantile(r, [0.5, 0.9, 0.99])
            rows.append([_err(error), metrics.LABELS[det], _num(q[0]), _num(q[1]), _num(q[2]),
                         _num(r.max())])
    return markdown_table(["model error", "statistic", "median", "90 %", "99 %", "max"], rows)


def _bias_table(results: Results) -> str:
    d = results.detection.set_index(["detector", "model_error", "kind", "magnitude"])["rate"]
    rows = []
    for error in results.grid.model_errors:
        for magnitude in results.grid.magnitudes["bias"]:
            key = (error, "bias", float(magnitude))
            best, best_rate = _best_classic(results, error, "bias", float(magnitude))
            level, gray = d.loc[("graybox.level",) + key], d.loc[(metrics.GRAYBOX,) + key]
            rows.append([_err(error), f"{magnitude:g}",
                         f"{metrics.LABELS[best]} {percent(best_rate)}",
                         percent(level), f"**{percent(gray)}**",
                         "**matched**" if gray >= best_rate else "below"])
    return markdown_table(["model error", "bias (rad/s)", "best classic (FA ≤ target)",
                           "gray box: level tier", "gray box (any tier)", "vs best classic"], rows)


def _verdict_lines(results: Results, head: pd.DataFrame) -> list[str]:
    lines = []
    fa = results.false_alarms.set_index(["detector", "model_error"])
    for error in results.grid.model_errors:
        h = head[(head.model_error == error) & head.in_scope]
        gb_fa = fa.loc[(metrics.GRAYBOX, error)]
        met = h[h.met]
        missed = h[~h.met]
        text = (f"- **Model error {_err(error)}**: gray-box false alarms "
                f"{percent(gb_fa['rate'], 1)} ({int(gb_fa['alarms'])}/{int(gb_fa['nights'])} "
                "healthy "
                f"asset-nights; target ≤ 1 %). In scope (redline ≤ 20 %): {len(h)} of "
                f"{len(head[head.model_error == error])} (kind, magnitude) cells; target met in "
                f"{len(met)}.")
        if len(missed):
            text += " Missed: " + "; ".join(
                f"{r.kind} {r.magnitude:g} ({percent(r.graybox_rate)})"
                for r in missed.itertuples()) + "."
        lines.append(text)
    return lines


def _jsonable(value):
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating,)):
        return float(value)
    if isinstance(value, (np.bool_,)):
        return bool(value)
    raise TypeError(f"not JSON serializable: {type(value).__name__}")


def load_results(assets_dir: pathlib.Path) -> Results:
    """Rebuild the results from a report's raw CSV and run record (to re-render a report)."""
    assets_dir = pathlib.Path(assets_dir)
    record = json.loads((assets_dir / "detection_run.json").read_text())
    grid_data = dict(record["grid"])
    grid_data["magnitudes"] = {k: tuple(v) for k, v in grid_data["magnitudes"].items()}
    grid_data["model_errors"] = tuple(grid_data["model_errors"])
    grid_data["seeds"] = tuple(grid_data["seeds"])
    grid_data["estimate"] = tuple(grid_data.get("estimate", ()))
    grid_data.setdefault("candidate_nights", UNRECORDED_CANDIDATE_NIGHTS)
    table = pd.read_csv(assets_dir / "detection_nights.csv")
    for column in ("model_error", "magnitude", "onset"):
        table[column] = table[column].astype(float)
    return summarize(table, Grid(**grid_data), record["run"])


KEPT_SECTION = re.compile(r"<!-- (?P<name>[a-z0-9-]+):begin -->.*?<!-- (?P=name):end -->\n?", re.S)


def kept_sections(page: pathlib.Path) -> list[str]:
    """The sections other benchmark scripts wrote into ``page`` between their
    ``<!-- name:begin -->`` / ``<!-- name:end -->`` markers (e.g.
    ``benchmarks/detection/progpy_false_alarms.py``): a rewrite of the page keeps them."""
    if not page.exists():
        return []
    return [m.group(0).rstrip("\n") + "\n" for m in KEPT_SECTION.finditer(page.read_text())]


def write_report(results: Results, out: pathlib.Path, discussion: str | None = None) -> list[pathlib.Path]:
    """Write ``out`` (markdown), its PNG plots and CSV files under ``out`` without suffix."""
    out = pathlib.Path(out)
    assets_dir = out.with_suffix("")
    assets_dir.mkdir(parents=True, exist_ok=True)
    rel = assets_dir.name
    files = {"rates": assets_dir / "detection_rate.png",
             "matched": assets_dir / "detection_rate_matched.png",
             "tiers": assets_dir / "detection_rate_graybox_tiers.png",
             "fa": assets_dir / "false_alarms.png",
             "nights": assets_dir / "detection_nights.csv",
             "summary": assets_dir / "detection_summary.csv",
             "falsealarms": assets_dir / "detection_false_alarms.csv",
             "run": assets_dir / "detection_run.json"}
    plot_rates(results, files["rates"], "rate",
               "Detection rate within 3 nights of onset, each detector at its own calibrated "
               "threshold (dotted: realized false alarms above target)")
    plot_rates(results, files["matched"], "matched_rate",
               "Detection rate within 3 nights at a matched 1 % false-alarm rate "
               "(common threshold level set on the healthy nights)")
    plot_rates(results, files["tiers"], "rate",
               "Gray box: detection rate within 3 nights, any tier and each tier alone",
               (metrics.GRAYBOX,) + metrics.GRAYBOX_TIERS)
    plot_false_alarms(results, files["fa"])
    results.table.to_csv(files["nights"], index=False, float_format="%.9g")
    files["run"].write_text(json.dumps({"grid": results.grid.to_dict(), "run": results.run},
                                       indent=1, default=_jsonable) + "\n")
    results.detection.to_csv(files["summary"], index=False, float_format="%.6g")
    results.false_alarms.to_csv(files["falsealarms"], index=False, float_format="%.6g")

    grid, run = results.grid, results.run
    head = headline(results)
    n_vehicles = len(grid.seeds) * grid.vehicles
    healthy_nights = n_vehicles * (grid.days - grid.baseline_days)
    md = []
    md.append("# Detection benchmark: does the gray box beat thresholds?\n")
    commit = run["commit"]
    if run.get("commit_at_end") and run["commit_at_end"] != commit:
        commit += f"; `{run['commit_at_end']}` was checked out by the time it finished"
    md.append(f"Generated by `{run['command']}` on {run['date']} (commit `{commit}`). "
              f"Wall time **{run['wall_seconds'] / 60:.1f} min** with {run['workers']} worker "
              f"process(es) x {run['threads']} torch thread(s) on {run['cpus']} CPU(s); "
              f"{run['load_note']}. Raw per-asset-night results: "
              f"[`{rel}/{files['nights'].name}`]({rel}/{files['nights'].name}); metrics: "
              f"[`{rel}/{files['summary'].name}`]({rel}/{files['summary'].name}), "
              f"[`{rel}/{files['falsealarms'].name}`]({rel}/{files['falsealarms'].name}).\n")
    md.append("Reproduce with (the seeds and grid are in the command's defaults, listed under "
              "Protocol; results are deterministic for a given commit):\n\n```sh\n"
              + run["command"] + "\n```\n\nRe-render this page from the saved raw results "
              f"(after editing `benchmarks/detection/discussion.md`) with `python -m "
              f"benchmarks.detection --rerender --out {out.as_posix()}`.\n")

    md.append("## Headline\n")
    md.append("Target: the gray box detects ≥ 95 % of faults of kinds (a)-(c) within 3 nights of "
              "onset at magnitudes where the 3-sigma redline detects ≤ 20 %, with ≤ 1 % false "
              "alarms per asset-night, even with the white box 20 % off.\n")
    rows = []
    for r in head.itertuples():
        best, best_rate = _best_classic(results, r.model_error, r.kind, r.magnitude)
        rows.append([_err(r.model_error), KINDS[r.kind], f"{r.magnitude:g}", str(r.assets),
                     percent(r.redline_rate) + ("" if r.in_scope else " (out of scope)"),
                     f"**{percent(r.graybox_rate)}**", _num(r.graybox_delay, 0),
                     _num(r.graybox_auc),
                     f"{metrics.LABELS[best]} {percent(best_rate)}",
                     percent(r.graybox_matched), percent(r.graybox_false_alarms, 1),
                     ("**met**" if r.met else ("not met" if r.in_scope else "n/a"))])
    md.append(markdown_table(["model error", "fault", "magnitude", "assets", "redline detects",
                              "gray box detects (≤ 3 nights)", "median delay (nights)",
                              "gray box AUC", "best classic (FA ≤ target)",
                              "gray box at matched 1 % FA", "gray box FA / asset-night",
                              "target"], rows) + "\n")
    md.append("\n".join(_verdict_lines(results, head)) + "\n")
    overall = head[head.in_scope]
    md.append(f"\nOverall: target met in {int(overall.met.sum())} of {len(overall)} in-scope cells "
              f"(model error 20 %: {int(overall[overall.model_error == max(grid.model_errors)].met.sum())} of "
              f"{len(overall[overall.model_error == max(grid.model_errors)])}).\n")

    if "bias" in grid.magnitudes:
        md.append("### Bias steps: the level tier against the classic detectors\n")
        md.append("A sensor bias step is invisible to the one-step residual's linear, nonlinear "
                  "and noise tiers; the level tier (`graybox/level_tier.py`) is there for it. "
                  "Target: at every model error, the gray box detects bias steps at least as "
                  "often as the best classic detector (among those within their false-alarm "
                  "target).\n")
        md.append(_bias_table(results) + "\n")
    md.append("## Realized false-alarm rates\n")
    md.append(f"Alarmed healthy asset-nights over all healthy asset-nights ({healthy_nights} per "
              "model error: every night after the baseline of every healthy asset; the faulty "
              "assets' pre-onset nights are the same telemetry, see Protocol). 95 % "
              "Clopper-Pearson intervals. A gray-box tier is calibrated to its Bonferroni share "
              f"(1 % / {len(metrics.TIERS)} tiers); the gray box's asset-level alarm is any tier.\n")
    md.append(_fa_table(results) + "\n")
    md.append(f"![false alarms]({rel}/{files['fa'].name})\n")

    md.append("## Results: detector x fault x magnitude\n")
    md.append("Each cell: detection rate within 3 nights of onset (each detector at its own "
              "per-asset calibrated threshold), `d` = median delay in nights after onset among "
              "the detected (0 = the onset night), AUC of faulty-night vs healthy-night "
              "statistics. ⚠ marks a detector whose realized false-alarm rate at that model "
              "error is above its target: its detection rates are flattered.\n")
    for error in grid.model_errors:
        md.append(f"### Model error {_err(error)}\n")
        md.append(_main_table(results, error) + "\n")
    md.append(f"![detection rate]({rel}/{files['rates'].name})\n")

    md.append("### At a matched false-alarm rate\n")
    md.append("Detection rate within 3 nights when every detector's ratio (statistic / per-asset "
              "threshold) is compared with one common level per model error, set so that at most "
              "1 % of the healthy asset-nights alarm. This removes calibration error from the "
              "comparison (the level is tuned on the scored healthy nights: an oracle, not a "
              "deployable threshold).\n")
    md.append(_matched_table(results) + "\n")
    md.append(f"![matched detection rate]({rel}/{files['matched'].name})\n")

    md.append("## Gray box by tier (for tuning the gray box)\n")
    md.append("Detection rate within 3 nights and AUC per tier (each tier alone against its "
              "epsilon), and the realized false-alarm rate of each tier against its Bonferroni "
              "target.\n")
    md.append(_tier_table(results) + "\n")
    md.append(f"![gray box tiers]({rel}/{files['tiers'].name})\n")
    md.append("Healthy-night zeta/epsilon quantiles (an alarm is a ratio above 1):\n")
    md.append(_healthy_ratio_quantiles(results) + "\n")
    md.append("What the gray box's alarms are made of (tier and parameter with the largest "
              "zeta/epsilon on alarmed nights within 3 nights of onset):\n")
    md.append(_top_changes(results) + "\n")
    md.append("Baseline structures chosen (per model error, over all vehicles):\n")
    md.append(_structure_table(results) + "\n")

    from benchmarks.detection.rates import section

    rates = section(assets_dir)   # present once ``python -m benchmarks.detection.rates`` ran
    if rates:
        md.append(rates)

    md.extend(kept_sections(out))

    if discussion:
        md.append(discussion.strip() + "\n")

    md.append("## Protocol\n")
    md.append(protocol_text(results) + "\n")
    md.append("## Run\n")
    md.append(run_text(results) + "\n")
    out.write_text("\n".join(md))
    return [out] + list(files.values())


def protocol_text(results: Results) -> str:
    g = results.grid
    mags = "; ".join(f"{KINDS[k]}: {', '.join(f'{m:g}' for m in sorted(v))} ({UNITS[k]})"
                     for k, v in g.magnitudes.items())
    return f"""\
- **Fleet** (`graybox.simulation`, true plant `GasTurbineShaft` with default parameters, AR(2)
  random moment, sensor noise 0.3 rad/s, daily load cycle): seeds {list(g.seeds)}; per seed
  {g.vehicles} vehicles, vehicle `i` of seed `s` has vehicle seed `1000 s + i`. Every vehicle
  appears as one healthy asset and as one faulty asset per (kind, magnitude): {len(g.scenarios())}
  faulty assets per vehicle, {len(g.seeds) * g.vehicles} faulty assets per (kind, magnitude,
  model error) cell. Sample interval {g.sample_interval:g} s, {g.days} days.
- **Faults** (onset at the start of day {g.onset_day}, full magnitude from the onset): {mags}.
- **Nights**: days 0..{g.baseline_days - 1} are the healthy baseline (K = {g.baseline_days}); every
  later UTC day is one nightly window. Healthy assets: nights {g.baseline_days}..{g.days - 1}
  measure false alarms. Faulty assets: nights {g.onset_day}..{g.days - 1} (onset, +1, +2); "within
  3 nights" = an alarm on one of them. The simulator draws every random stream of a vehicle from
  its seed independently of its faults, so a faulty asset's telemetry equals its healthy twin's
  before the onset (checked on every run): the twin's baseline fit and pre-onset nights are
  shared, not refitted.
- **White box**: `GasTurbineShaft(white_box_parameters(e), columns={{"omega": "shaft_speed"}})`,
  e = {', '.join(_err(e) for e in g.model_errors)} (the loss parameters off by e). Every detector
  sees the residual of `graybox.residual.residual_frame(model, night)` (one-step, Eqs. 2-3); the
  gray box computes the same residual inside `fit_baselines` / `fit_signatures`.
- **Gray box**: `fit_baselines` (default `GrayBoxSettings`, false-alarm rate
  {g.false_alarm_rate:g} per asset-night: epsilon per tier from the baseline days cut into
  pieces, predictive F quantile, Bonferroni over tiers x channels) on the K baseline days of all
  of a seed's vehicles in one call; every night a candidate with the baseline's frozen structure
  (`fit_signatures`, all of a seed's nights in one call), fitted on
  {_candidate_span(g.candidate_nights)}; `compute_drift` gives zeta and epsilon
  per tier. The asset alarms when any tier's zeta > epsilon (the roll-up the nightly flow
  reports); its ROC statistic is the largest zeta/epsilon.
- **Classic detectors** (`benchmarks/detection/classic.py`), on 5-minute batches of the same
  residual: fixed 3-sigma redline (fraction of samples outside the baseline mean ± 3 sigma);
  adaptive threshold (fraction outside the trailing 1-hour rolling mean ± 3 rolling sigma);
  two-sided Page CUSUM (k = 0.5) on the standardized batch means and on the standardized log
  batch mean squares (variance); GLR for a shift of (batch mean, log batch mean square) at an
  unknown time (at least 1 hour before the night's end). Each statistic is one number per night.
- **Calibration of the classic detectors**, per asset on the same K baseline days, to the same
  1 % per asset-night: batch-level features of each baseline day are computed with reference
  values from the other K - 1 days; each feature series is modelled as a James-Stein-shrunk
  time-of-day profile plus Gaussian AR noise (order by AIC, variance inflated for the profile's
  estimation error, plus a per-night level offset for the baseline mean's error and the
  day-to-day variation, and a per-night variance drawn for the variance estimate's error);
  4000 such predictive nights are simulated and the threshold is the 99 % quantile of each
  statistic. (Recombining pieces of the baseline days into pseudo-nights was
  tried first and rejected: a CUSUM or GLR night maximum can never exceed the worst baseline
  piece, so the thresholds were the baseline maxima and 10-17 % of healthy nights alarmed.)
- **Metrics**: detection rate within 3 nights at each detector's own threshold (a failed fit
  counts as no alarm); median delay in nights after onset among the detected (so 0-2); ROC AUC of
  the statistic/threshold ratio of faulty nights (onset..onset+2) against all healthy nights of
  the same model error (ties count half); realized false-alarm rate on healthy nights with 95 %
  Clopper-Pearson intervals; detection rate at a matched 1 % false-alarm rate (oracle level)."""


def _candidate_span(nights: int) -> str:
    if nights == 1:
        return "the night alone (`[nightly] candidate_nights = 1`)"
    return (f"the night and the {nights - 1} night(s) before it, never before the baseline's end "
            f"(`[nightly] candidate_nights = {nights}`; epsilon scaled to the span's length by "
            "`graybox.epsilon_scaling`; the classic detectors see the night alone)")


def run_text(results: Results) -> str:
    run = results.run
    t = pd.DataFrame(run.get("timings", []))
    lines = [f"- Command: `{run['command']}`",
             f"- Grid: seeds {list(results.grid.seeds)}, {results.grid.vehicles} vehicles per seed, "
             f"model errors {list(results.grid.model_errors)}, magnitudes "
             f"{ {k: list(v) for k, v in results.grid.magnitudes.items()} }",
             f"- Wall time: {run['wall_seconds']:.0f} s ({run['wall_seconds'] / 60:.1f} min); "
             f"{run['workers']} worker process(es), {run['threads']} torch thread(s) each; "
             f"{run['load_note']}",
             f"- Versions: {run.get('versions', '')}"]
    if not t.empty:
        sums = {c: t[c].sum() for c in t.columns if "seconds" in c}
        sim = sums.get("simulate_seconds", 0.0)
        classic = sum(v for k, v in sums.items() if k.startswith("classic_seconds"))
        base = sum(v for k, v in sums.items() if k.startswith("gb_baseline_seconds"))
        cand = sum(v for k, v in sums.items() if k.startswith("gb_candidate_seconds"))
        n_cand = sum(t[c].sum() for c in t.columns if c.startswith("gb_candidates"))
        n_base = len(results.grid.seeds) * results.grid.vehicles * len(results.grid.model_errors)
        lines.append(f"- Work (summed over workers): simulation {sim:.0f} s; residuals + classic "
                     f"detectors {classic:.0f} s; gray-box baselines {base:.0f} s for {n_base} "
                     f"baselines ({base / max(n_base, 1):.1f} s each, calibration included); "
                     f"gray-box candidates {cand:.0f} s for {int(n_cand)} asset-nights "
                     f"({cand / max(n_cand, 1):.2f} s each)" + (
                         f"; CPU time of the workers {t['cpu_time'].sum():.0f} s"
                         if "cpu_time" in t else ""))
    return "\n".join(lines)
