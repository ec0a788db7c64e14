"""Time to build and draw the fleet heat map of a synthetic fleet (no registry involved).

    python -m benchmarks.fleet_view_render --assets 1000 --nights 14 \
        --png docs/benchmarks/fleet_heatmap_1000.png

A fleet of ``--assets`` assets over ``--nights`` nights: ratios drawn from a seeded
lognormal around 0.35 (healthy), 2 % of the assets drifting upwards over the window, 1 %
failed and 1 % stale on the last night, a few nights missing at random. Prints the seconds
to build the view (:func:`flows.fleet_view.build_view`, sorting included), to draw and
encode the PNG (:func:`flows.fleet_plot.heatmap_png`) and to render the HTML page, with
the PNG's size; the best of ``--repeat`` runs.
"""
from __future__ import annotations

import argparse
import pathlib
import time

import numpy as np

from flows.fleet_plot import heatmap_png
from flows.fleet_view import DEFAULT_TOP, Mark, build_view, window_nights
from flows.html_report import render_page
from registry.fleet_nights import NightRatio


def synthetic_fleet(assets: int, nights: int, seed: int = 1):
    """(nights, ratios, marks, coverage) of a synthetic fleet (see the module docstring)."""
    rng = np.random.default_rng(seed)
    days = window_nights("2026-03-14", nights)
    ids = [f"T-{i:04d}" for i in range(assets)]
    drifting = set(rng.choice(assets, max(1, assets // 50), replace=False))
    ratios = []
    for i, asset in enumerate(ids):
        base = rng.lognormal(np.log(0.35), 0.35, nights)
        if i in drifting:
            base = base * np.linspace(1.0, rng.uniform(3.0, 18.0), nights)
        for j, night in enumerate(days):
            if rng.random() < 0.02:
                continue
            ratios.append(NightRatio(asset, "turbine", night, float(base[j])))
    chosen = rng.permutation(assets)
    failed, stale = chosen[:max(1, assets // 100)], chosen[assets // 100:2 * (assets // 100)]
    marks = ([Mark(ids[i], "turbine", days[-1], "failed", "bad telemetry") for i in failed]
             + [Mark(ids[i], "turbine", days[-1], "stale", "no telemetry for 3 days")
                for i in stale])
    coverage = {"assets": assets, "monitored": assets - len(failed) - len(stale),
                "stale": len(stale), "failed": len(failed),
                "without baseline": 0}
    return days, ratios, marks, coverage


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--assets", type=int, default=1000)
    parser.add_argument("--nights", type=int, default=14)
    parser.add_argument("--top", type=int, default=DEFAULT_TOP)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--png", type=pathlib.Path, help="write the PNG here")
    args = parser.parse_args(argv)
    days, ratios, marks, coverage = synthetic_fleet(args.assets, args.nights)
    best = {"build": float("inf"), "png": float("inf"), "html": float("inf")}
    for _ in range(args.repeat):
        start = time.perf_counter()
        view = build_view(days, ratios, marks, coverage, days[-1])
        built = time.perf_counter()
        png = heatmap_png(view, args.top)
        drawn = time.perf_counter()
        render_page(view, png, [])
        done = time.perf_counter()
        best = {"build": min(best["build"], built - start), "png": min(best["png"], drawn - built),
                "html": min(best["html"], done - drawn)}
    print(f"{args.assets} assets x {args.nights} nights, top {args.top}: build view "
          f"{best['build']:.3f} s, draw + encode PNG {best['png']:.3f} s "
          f"({len(png) / 1024:.0f} KiB), HTML page {best['html']:.3f} s "
          f"(best of {args.repeat})")
    if args.png:
        args.png.write_bytes(png)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
