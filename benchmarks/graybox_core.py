"""Zeta/epsilon on healthy and faulty nights, and fit time per asset-day.

    python -m benchmarks.graybox_core [--assets N] [--nights N]

Simulates gas-turbine vehicles (graybox.simulation), fits baselines with calibration on 4
healthy days, then one candidate per asset-night, for the exact white box and for one whose
parameters are 20 % off. Prints zeta/epsilon per tier for a healthy vehicle and for each fault
kind (onset at the first night), and the wall time per asset of each stage.
"""
from __future__ import annotations

import argparse
import time


from graybox import FitRequest, compute_drift, fit_baselines, fit_signatures, load_model
from graybox.simulation import Fault, FleetSpec, VehicleSpec, simulate_fleet, white_box_parameters

BASELINE_DAYS = 4
KINDS = {"healthy": None, "(a) friction 0.5": Fault("friction", BASELINE_DAYS, 0.5),
         "(b) nonlinear 0.25": Fault("nonlinear", BASELINE_DAYS, 0.25),
         "(c) noise 1.0": Fault("noise", BASELINE_DAYS, 1.0),
         "(d) bias 2.0 rad/s": Fault("bias", BASELINE_DAYS, 2.0)}


def day_frames(frame):
    frame = frame.set_index("timestamp")
    return [day for _, day in frame.groupby(frame.index.floor("1D"))]


def run(model_error: float, nights: int, extra_healthy: int) -> None:
    vehicles = [VehicleSpec(f"V{i}", 100 + i, faults=() if f is None else (f,))
                for i, f in enumerate(KINDS.values())]
    vehicles += [VehicleSpec(f"H{i}", 200 + i) for i in range(extra_healthy)]
    frames = simulate_fleet(FleetSpec(tuple(vehicles), days=BASELINE_DAYS + nights))
    days = {v.asset_id: day_frames(frames[v.asset_id]) for v in vehicles}
    model = load_model("graybox.models:GasTurbineShaft", white_box_parameters(model_error),
                       {"omega": "shaft_speed"})
    start = time.perf_counter()
    baselines = fit_baselines([FitRequest(model, days[v.asset_id][:BASELINE_DAYS],
                                          asset_id=v.asset_id) for v in vehicles])
    baseline_time = time.perf_counter() - start
    requests = [FitRequest(model, [days[v.asset_id][n]], baseline=b[0])
                for v, b in zip(vehicles, baselines) for n in range(BASELINE_DAYS, BASELINE_DAYS + nights)]
    start = time.perf_counter()
    candidates = fit_signatures(requests)
    candidate_time = time.perf_counter() - start
    print(f"\nwhite box {model_error:.0%} off: zeta/epsilon per night "
          f"(nights {BASELINE_DAYS}..{BASELINE_DAYS + nights - 1}, onset at night {BASELINE_DAYS})")
    print(f"{'vehicle':22s} {'linear':>22s} {'nonlinear':>22s} {'noise':>22s}")
    healthy_ratios = []
    for i, (v, (signature, calibration)) in enumerate(zip(vehicles, baselines)):
        drifts = [compute_drift(c, signature, calibration)
                  for c in candidates[i * nights:(i + 1) * nights]]
        cells = [",".join(f"{d.get('omega', tier).ratio:.2f}" for d in drifts)
                 for tier in ("linear", "nonlinear", "noise")]
        label = list(KINDS)[i] if i < len(KINDS) else f"healthy {v.asset_id}"
        if label.startswith("healthy"):
            healthy_ratios += [e.ratio for d in drifts for e in d.entries]
        if i < len(KINDS) or extra_healthy <= 4:
            print(f"{label:22s} {cells[0]:>22s} {cells[1]:>22s} {cells[2]:>22s}")
    alarms = sum(r > 1 for r in healthy_ratios)
    print(f"healthy tier-nights: {len(healthy_ratios)}, above epsilon: {alarms}, "
          f"largest zeta/epsilon: {max(healthy_ratios):.2f}")
    n = len(vehicles)
    print(f"time: baseline with calibration {baseline_time / n:.2f} s per asset "
          f"({BASELINE_DAYS} days, {baseline_time / n / BASELINE_DAYS:.2f} s per asset-day); "
          f"candidate {candidate_time / len(requests):.3f} s per asset-night "
          f"({n} assets batched)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nights", type=int, default=3)
    parser.add_argument("--extra-healthy", type=int, default=3,
                        help="healthy vehicles beyond the first (for the false-alarm count)")
    args = parser.parse_args()
    for model_error in (0.0, 0.2):
        run(model_error, args.nights, args.extra_healthy)


if __name__ == "__main__":
    main()
