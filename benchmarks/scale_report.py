"""Tables of :mod:`benchmarks.nightly_scale`: per-stage seconds per asset-night, the
extrapolation to 1,000 assets, the targets and the compute floor, as text or Markdown.

Everything is derived from the raw results (``nightly_scale.json``), so a saved run renders
again without being repeated.
"""
from __future__ import annotations

import pathlib
import statistics

GB = 10 ** 9
#: hand-written observations appended to the Markdown report (kept apart so a rerun keeps them)
NOTES = pathlib.Path(__file__).with_name("nightly_scale_notes.md")
#: the hand-written section on Dask workers (benchmarks.dask_scale), appended after the notes
DASK_NOTES = pathlib.Path(__file__).with_name("dask_scale_notes.md")
FLEET = 1000
#: (stage key in a run summary's ``extra["stages"]``, label)
STAGES = (("read", "read + validate + grid"), ("residual", "residual"),
          ("stationarize_ar", "stationarize + AR"), ("network", "network"),
          ("noise", "noise"), ("drift", "drift"),
          ("registry", "registry (look-ups, record, watermark)"), ("alerts", "alerts file"))
COMPUTE = ("residual", "stationarize_ar", "network", "noise", "drift")

#: name -> (limit, unit, description)
TARGETS = {
    "nightly": (0.25, "s", "nightly wall per asset-night (1,000 assets: fixed start-up + "
                           "1,000 x the per-asset wall)"),
    "fleet": (240.0, "s", "1,000-asset night end to end (extrapolated)"),
    "startup": (15.0, "s", "fixed start-up (a run with nothing to do)"),
    "baseline": (2.0, "s", "baseline with calibration, wall per asset-day (end to end)"),
    "memory": (4.0, "GB", "peak resident size of any run (its whole process tree)"),
    "registry": (20.0, "ms", "registry on the nightly path per asset-night"),  # issue 22
}


def _total(stages: dict, key: str) -> float:
    return sum(s[key] for s in stages.values())


def derive(size: dict) -> dict:
    """The figures of one fleet size (seconds unless named otherwise)."""
    n, nightly, startup, baseline = size["n"], size["nightly"], size["startup"], size["baseline"]
    nights = max(1, nightly["windows"])
    stages = nightly["stages"]
    rest_wall = nightly["wall"] - _total(stages, "wall")
    rest_cpu = nightly["user"] + nightly["system"] - _total(stages, "cpu")
    fixed_rest = startup["wall"] - _total(startup["stages"], "wall")
    per_asset = (nightly["wall"] - startup["wall"]) / nights
    asset_days = n * size["baseline_days"]
    return {
        "n": n, "nights": nights,
        "stages": {key: {"cpu": stages.get(key, {}).get("cpu", 0.0) / nights,
                         "wall": stages.get(key, {}).get("wall", 0.0) / nights}
                   for key, _ in STAGES},
        "rest": {"cpu": rest_cpu / nights, "wall": rest_wall / nights},
        "total": {"cpu": (nightly["user"] + nightly["system"]) / nights,
                  "wall": nightly["wall"] / nights},
        "compute_cpu": sum(stages.get(k, {}).get("cpu", 0.0) for k in COMPUTE) / nights,
        "startup": startup["wall"], "startup_cpu": startup["user"] + startup["system"],
        "startup_rest": fixed_rest,
        "prefect_per_asset": (rest_wall - fixed_rest) / nights,
        "per_asset": per_asset,
        "fleet": startup["wall"] + FLEET * per_asset,
        "registry_ms": 1000 * stages.get("registry", {}).get("wall", 0.0) / nights,
        "nightly_wall": nightly["wall"],
        "nightly_rss": nightly["max_rss"], "nightly_tree_rss": nightly["tree_rss"],
        "baseline_wall": baseline["wall"],
        "baseline_cpu": baseline["user"] + baseline["system"],
        "baseline_per_day": baseline["wall"] / asset_days,
        "baseline_marginal": (baseline["wall"] - startup["wall"]) / asset_days,
        "baseline_stages": {k: v["wall"] / asset_days for k, v in baseline["stages"].items()},
        "baseline_rss": baseline["max_rss"], "baseline_tree_rss": baseline["tree_rss"],
        "peak_tree_rss": max(r["tree_rss"] for r in (nightly, startup, baseline)),
        "peak_rss": max(r["max_rss"] for r in (nightly, startup, baseline)),
        "load": [x for r in (baseline, nightly, startup) for x in r["load"]],
    }


def target_checks(results: dict) -> list[tuple[str, float, bool]]:
    """(target name, measured value, met) at the largest fleet size measured."""
    d = derive(max(results["sizes"], key=lambda s: s["n"]))
    measured = {"nightly": d["per_asset"], "fleet": d["fleet"], "startup": d["startup"],
                "baseline": d["baseline_per_day"],
                "memory": max(derive(s)["peak_tree_rss"] for s in results["sizes"]) / GB,
                "registry": d["registry_ms"]}
    return [(name, measured[name], measured[name] <= TARGETS[name][0]) for name in TARGETS]


def floor(results: dict, size: dict) -> dict:
    """Compute floor of one size: FLOPs per asset-night and seconds at the matmul rates."""
    flops = size["flops"]
    return {"flops": flops, "float64": flops["total"] / results["matmul"]["float64"],
            "float32": flops["total"] / results["matmul"]["float32"]}


# -- tables ----------------------------------------------------------------------------------

def stage_table(size: dict) -> tuple[list[str], list[list[str]]]:
    """Per asset-night CPU and wall seconds of each stage of one size's nightly run."""
    d = derive(size)
    total_wall = d["total"]["wall"]
    rows = []
    for key, label in STAGES:
        s = d["stages"][key]
        rows.append([label, f"{s['cpu']:.4f}", f"{s['wall']:.4f}",
                     f"{100 * s['wall'] / total_wall:.1f} %"])
    rows.append(["Prefect and start-up (the rest of the process)", f"{d['rest']['cpu']:.4f}",
                 f"{d['rest']['wall']:.4f}", f"{100 * d['rest']['wall'] / total_wall:.1f} %"])
    rows.append(["total (the process, end to end)", f"{d['total']['cpu']:.4f}",
                 f"{total_wall:.4f}", "100 %"])
    return ["stage", "CPU s / asset-night", "wall s / asset-night", "share of wall"], rows


def summary_table(results: dict) -> tuple[list[str], list[list[str]]]:
    """One row per fleet size: growth of every headline figure."""
    rows = []
    for size in results["sizes"]:
        d = derive(size)
        rows.append([str(d["n"]), f"{d['nightly_wall']:.1f}", f"{d['startup']:.1f}",
                     f"{d['per_asset']:.3f}", f"{d['prefect_per_asset']:.3f}",
                     f"{d['registry_ms']:.0f}", f"{d['fleet'] / 60:.1f}",
                     f"{d['baseline_wall']:.1f}", f"{d['baseline_per_day']:.2f}",
                     f"{d['baseline_marginal']:.2f}",
                     f"{d['peak_rss'] / GB:.2f} / {d['peak_tree_rss'] / GB:.2f}",
                     _load_text(d["load"])])
    return ["N", "nightly wall s", "start-up s (nothing to do)", "per asset-night s",
            "of which Prefect s", "registry ms / asset-night", "1,000 assets (min)",
            "baseline wall s", "baseline s / asset-day", "baseline s / asset-day after "
            "start-up", "peak RSS GB (process / tree)", "load (1-min, mean max)"], rows


def baseline_table(results: dict) -> tuple[list[str], list[list[str]]]:
    """Baseline stages in wall seconds per asset-day, one column per size."""
    sizes = [derive(s) for s in results["sizes"]]
    keys = [k for k, _ in STAGES if any(k in d["baseline_stages"] for d in sizes)]
    labels = dict(STAGES)
    rows = [[labels[k]] + [f"{d['baseline_stages'].get(k, 0.0):.3f}" for d in sizes]
            for k in keys]
    rows.append(["rest (Prefect, start-up)"] + [
        f"{d['baseline_per_day'] - sum(d['baseline_stages'].values()):.3f}" for d in sizes])
    rows.append(["total"] + [f"{d['baseline_per_day']:.3f}" for d in sizes])
    return ["stage (wall s / asset-day)"] + [f"N = {d['n']}" for d in sizes], rows


def floor_table(results: dict) -> tuple[list[str], list[list[str]]]:
    size = max(results["sizes"], key=lambda s: s["n"])
    f = floor(results, size)
    d = derive(size)
    rows = [[key, f"{value / 1e6:.2f}", f"{1e3 * value / results['matmul']['float64']:.3f}",
             f"{1e3 * d['stages'].get(key, {}).get('cpu', 0.0):.1f}"]
            for key, value in f["flops"].items() if key != "total"]
    rows.append(["total", f"{f['flops']['total'] / 1e6:.2f}", f"{1e3 * f['float64']:.3f}",
                 f"{1e3 * d['compute_cpu']:.1f}"])
    return ["tier", "MFLOP / asset-night", "floor ms at float64 matmul rate",
            f"measured CPU ms (N = {d['n']})"], rows


def _load_text(load: list[float]) -> str:
    return f"{statistics.fmean(load):.1f} {max(load):.1f}" if load else "n/a"


def _markdown(header, rows) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rows])


def _text(header, rows) -> str:
    widths = [max(len(str(c)) for c in column) for column in zip(header, *rows)]
    line = lambda cells: "  ".join(str(c).ljust(w) for c, w in zip(cells, widths))  # noqa: E731
    return "\n".join([line(header), line(["-" * w for w in widths])] + [line(r) for r in rows])


def _format_target(name: str, value: float, met: bool) -> list[str]:
    limit, unit, text = TARGETS[name]
    return [text, f"<= {limit:g} {unit}", f"{value:.3g} {unit}", "met" if met else "NOT MET"]


# -- documents -------------------------------------------------------------------------------

def _sections(results: dict, table) -> list[str]:
    out = []
    if results.get("quick"):
        out.append("QUICK RUN (smoke test: not 1 Hz, not comparable with the targets)")
    out.append("Per fleet size:")
    out.append(table(*summary_table(results)))
    for size in results["sizes"]:
        d = derive(size)
        out.append(f"N = {d['n']}: nightly run, per asset-night ({d['nights']} asset-nights, "
                   f"{size['sample_interval']:g}-s samples; fixed start-up {d['startup']:.1f} s "
                   f"wall, {d['startup_cpu']:.1f} s CPU):")
        out.append(table(*stage_table(size)))
    out.append("Baseline with calibration, per asset-day:")
    out.append(table(*baseline_table(results)))
    out.append("Targets (at the largest N):")
    out.append(table(["target", "limit", "measured", "verdict"],
                     [_format_target(*check) for check in target_checks(results)]))
    m = results["matmul"]
    size = max(results["sizes"], key=lambda s: s["n"])
    s = size["structure"]
    out.append(f"Compute floor per asset-night (numpy matmul {m['float64'] / 1e9:.1f} GFLOP/s "
               f"float64, {m['float32'] / 1e9:.1f} GFLOP/s float32; candidates: "
               f"{s['samples']:.0f} analysis samples, AR order {s['ar_order']:.0f}, m = "
               f"{s['embedding_dim']:.1f}, J = {s['hidden_units']:.0f}, "
               f"{100 * s['trained_share']:.0f} % trained networks, "
               f"{s['iterations']:.0f} L-BFGS iterations):")
    out.append(table(*floor_table(results)))
    return out


def render_text(results: dict) -> str:
    """The tables for a terminal."""
    return "\n\n".join(_sections(results, _text)) + "\n"


def render_markdown(results: dict) -> str:
    """``docs/performance.md``."""
    big = max(results["sizes"], key=lambda s: s["n"])
    d = derive(big)
    f = floor(results, big)
    m = results["matmul"]
    load = [x for s in results["sizes"] for x in derive(s)["load"]]
    checks = target_checks(results)
    misses = [TARGETS[name][2] for name, _, met in checks if not met]
    worst = max(STAGES, key=lambda st: d["stages"][st[0]]["wall"])
    parts = [
        "# Performance: a nightly run at 1 Hz, at scale",
        f"Generated by `{results['command']}` on {results['date']} (commit "
        f"`{results['commit']}`) on {results['cpus']} CPU(s); wall time of the whole "
        f"benchmark {results.get('wall_seconds', 0) / 60:.1f} min. 1-minute load average "
        f"while the runs ran: mean {statistics.fmean(load):.1f}, max {max(load):.1f} "
        f"(other work shared the machine: above {results['cpus']} the runs got less than "
        f"the whole machine, and wall times are longer than on an idle one)."
        if load else f"Generated by `{results['command']}` on {results['date']}.",
        "Reproduce:\n\n```sh\npython -m benchmarks.nightly_scale --sizes "
        + ",".join(str(s["n"]) for s in results["sizes"])
        + " --out docs/performance.md\n```",
        "Each N is a fresh work directory: N healthy gas-turbine vehicles simulated at "
        f"{big['sample_interval']:g}-s samples over {big['baseline_days']} + 1 days, "
        "`fleet-health baseline fit --all --promote` on the first "
        f"{big['baseline_days']} days, then `fleet-health run --json --as-of <end of the "
        "night>` (Prefect's ephemeral server, MLflow on SQLite, `[nightly] batch_size = "
        f"{results['batch_size']}`, `memory_budget = \"{results['memory_budget']}\"`), then "
        "the same command again with nothing left to do (the fixed start-up). Each command "
        "is a child process measured from outside (`os.wait4`: CPU of the process and the "
        "children it reaped, largest single resident size; the process tree's summed "
        "resident size sampled every 0.25 s). Stage seconds are the run summary's "
        "`extra[\"stages\"]` (CPU is the whole process's CPU while the stage ran, all "
        "threads); \"Prefect and start-up\" is the rest of the process: interpreter and "
        "imports, Prefect's server start, flow and task orchestration, discovery, the "
        "summary. The extrapolation to 1,000 assets is the fixed start-up plus 1,000 x "
        "the per-asset wall (nightly wall minus the start-up run's wall, per asset-night).",
        "## Targets",
        _markdown(["target", "limit", f"measured (N = {d['n']})", "verdict"],
                  [_format_target(*c) for c in checks]),
        ("Missed: " + "; ".join(misses) + "." if misses else "Every target is met.")
        + f" The largest stage of the nightly run is {worst[1]} "
          f"({d['stages'][worst[0]]['wall']:.3f} s wall per asset-night); Prefect and "
          f"start-up take {d['rest']['wall'] * d['nights']:.1f} s of the "
          f"{d['nightly_wall']:.1f} s run.",
        "## Growth with the fleet",
        _markdown(*summary_table(results)),
        "\"Of which Prefect\" is the per-asset share of the process's time outside the stages "
        "beyond the start-up run's (a difference of two single runs: within their noise it "
        "can come out negative). Peak RSS: the largest single process (`ru_maxrss`) / the "
        "sampled sum over the process tree (the CLI and Prefect's server).",
        "## Where a night's time goes",
    ]
    for size in results["sizes"]:
        dd = derive(size)
        parts.append(f"N = {dd['n']} ({dd['nights']} asset-nights; fixed start-up "
                     f"{dd['startup']:.1f} s wall, {dd['startup_cpu']:.1f} s CPU):")
        parts.append(_markdown(*stage_table(size)))
    parts += [
        "## Baseline with calibration",
        _markdown(*baseline_table(results)),
        "## The floor",
        f"The FLOPs a candidate's tiers need per asset-night, counted from the structure the "
        f"candidates had (read from their runs: {big['structure']['samples']:.0f} analysis "
        f"samples a night, AR order {big['structure']['ar_order']:.0f}, embedding m = "
        f"{big['structure']['embedding_dim']:.1f}, J = "
        f"{big['structure']['hidden_units']:.0f} hidden units, "
        f"{100 * big['structure']['trained_share']:.0f} % of networks training their input "
        f"weights, {big['structure']['iterations']:.0f} L-BFGS iterations): the residual is "
        f"RK4 with 2 sub-steps on every 1-Hz sample, the AR tier its autocovariances and "
        f"innovations at the analysis rate, the network one evaluation (forward, loss, "
        f"gradient) per iteration. Each operation counts once, a tanh as one; see "
        f"`benchmarks/scale_floor.py`. The machine's numpy matmul (1024 x 1024, best of 5, "
        f"all cores) ran at {m['float64'] / 1e9:.1f} GFLOP/s float64 and "
        f"{m['float32'] / 1e9:.1f} GFLOP/s float32"
        + (f" ({results['matmul_after']['float64'] / 1e9:.1f} float64 after the runs)"
           if "matmul_after" in results else "") + ".",
        _markdown(*floor_table(results)),
        f"At the float64 rate the floor of 1,000 asset-nights is "
        f"{FLEET * f['float64']:.1f} s ({FLEET * f['float32']:.1f} s at float32); the "
        f"measured CPU of the compute stages is {1e3 * d['compute_cpu']:.0f} ms per "
        f"asset-night, {d['compute_cpu'] / f['float64']:.0f} x the floor, and the whole "
        f"process {d['total']['cpu']:.2f} s CPU per asset-night. The floor is far below the "
        f"targets: what separates a night from it is per-call overhead (small numpy and "
        f"torch operations, Parquet, the registry's SQLite transactions, Prefect), not "
        f"arithmetic.",
    ]
    if NOTES.exists():
        parts += ["## Notes", NOTES.read_text().strip()]
    if DASK_NOTES.exists():
        parts += [DASK_NOTES.read_text().strip()]
    return "\n\n".join(parts) + "\n"
