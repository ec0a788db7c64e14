"""``python -m benchmarks.zoo.export``: a zoo family's fleet as a user would have it, telemetry in
the store layout and a fleet.toml, to run through ``fleet-health`` itself.

The zoo's benchmark (``python -m benchmarks.zoo``) calls the fit functions directly to score
hundreds of asset-nights; this writes the same plants for the product's own commands (baseline
flow, nightly flow, alerts, report), with the family's white box, column map and grid line and
every other setting at its default.

Examples
--------
python -m benchmarks.zoo.export --family ev_battery --assets 2 --fault resistance_growth:large \\
    --out /tmp/packs
PYTHONPATH=. fleet-health --config /tmp/packs/fleet.toml baseline fit --all \\
    --start 2026-01-05 --end 2026-01-10 --promote --reason "first baselines"
PYTHONPATH=. fleet-health --config /tmp/packs/fleet.toml run --as-of 2026-01-13
"""
from __future__ import annotations

import argparse
import pathlib
import sys

import pandas as pd

from benchmarks.zoo.families import family_option
from benchmarks.zoo.family import Family
from benchmarks.zoo.run import START, plan_fleet
from flows.config.template import render_config
from graybox.telemetry.writing import write_telemetry


def export_fleet(family: Family, out: pathlib.Path, assets: int = 2, baseline_days: int = 5,
                 nights: int = 3, faults: tuple[tuple[str, str], ...] = (),
                 seed: int = 1) -> dict:
    """Write ``assets`` healthy vehicles and the chosen faulty assets of ``family`` under
    ``out`` (``telemetry/`` and ``fleet.toml``, its store ``mlflow.db`` beside them).

    Parameters
    ----------
    family : Family
    out : pathlib.Path
    assets, baseline_days, nights : int
        Healthy vehicles; their baseline days and the nights after them.
    faults : tuple of (fault kind, "small" or "large")
        Faulty assets, each on a vehicle's seed (named after it: its days up to the onset are
        the vehicle's), with the fault from an onset inside the first night after the baseline.
    seed : int

    Returns
    -------
    dict
        ``config`` (the fleet.toml path), ``assets``, ``baseline`` (start, end) and ``as_of``
        (the end of the last night), all as strings.
    """
    if family.parameters:
        raise ValueError(f"{family.name}: export writes no parameter overrides, and the family "
                         f"has {sorted(family.parameters)}")
    kinds = {kind.name for kind in family.faults}
    unknown = sorted({name for name, _ in faults} - kinds)
    if unknown:
        raise ValueError(f"{family.name} has no fault {unknown}; it has {sorted(kinds)}")
    vehicles, faulty = plan_fleet(family, assets, 1, seed, baseline_days)
    chosen = [plan for plan in faulty if (plan.fault.name, plan.size) in set(faults)]
    days = baseline_days + nights
    out.mkdir(parents=True, exist_ok=True)
    telemetry = out / "telemetry"
    frames = family.simulate(vehicles + chosen, START, days)
    for asset, frame in frames.items():
        write_telemetry(telemetry, asset, frame)
        print(f"{asset}: {days} days written", file=sys.stderr, flush=True)
    prefix = vehicles[0].asset_id.split("-")[0]
    config = out / "fleet.toml"
    config.write_text(render_config(
        telemetry_root=str(telemetry), tracking_uri=f"sqlite:///{out / 'mlflow.db'}",
        class_name=family.name, model=family.spec, assets=(f"{prefix}-*",),
        columns=family.columns, grid=family.grid))
    end = START + pd.Timedelta(days=baseline_days)
    return {"config": str(config), "assets": sorted(frames),
            "baseline": (START.date().isoformat(), end.date().isoformat()),
            "as_of": (START + pd.Timedelta(days=days)).date().isoformat()}


def _fault(text: str) -> tuple[str, str]:
    name, _, size = text.partition(":")
    if size not in ("small", "large"):
        raise argparse.ArgumentTypeError(f"{text!r}: write KIND:small or KIND:large")
    return name, size


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.zoo.export",
                                     description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    families = family_option(parser)
    parser.add_argument("--out", required=True, type=pathlib.Path,
                        help="directory for telemetry/, fleet.toml and the store")
    parser.add_argument("--assets", type=int, default=2, help="healthy vehicles (default 2)")
    parser.add_argument("--baseline-days", type=int, default=5, help="default 5")
    parser.add_argument("--nights", type=int, default=3, help="nights after the baseline (default 3)")
    parser.add_argument("--fault", type=_fault, action="append", default=[],
                        help="a faulty asset, KIND:small or KIND:large (repeatable)")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    try:
        written = export_fleet(families[args.family], args.out, args.assets, args.baseline_days,
                               args.nights, tuple(args.fault), args.seed)
    except ValueError as error:
        parser.error(str(error))
    start, end = written["baseline"]
    config = written["config"]
    print(f"wrote {len(written['assets'])} assets and {config}; run them with (from the "
          f"repository root, so that the white box imports):\n"
          f"  PYTHONPATH=. fleet-health --config {config} baseline fit --all --start {start} "
          f"--end {end} --promote --reason 'first baselines'\n"
          f"  PYTHONPATH=. fleet-health --config {config} run --as-of {written['as_of']}\n"
          f"  PYTHONPATH=. fleet-health --config {config} alerts")
    return 0


if __name__ == "__main__":
    sys.exit(main())
