"""``python -m benchmarks.diagnosis.separability [--seeds 2] [--magnitudes 0.5,2]
[--candidate-nights N]``

How often the gas-turbine grid's speed-sensor bias *can* rank first: the top-1 rate the
night's evidence allows, against which the diagnosis' measured top-1 is read.

Why it is needed. In the shaft ``J omega' = M1 - M2`` a reading ``y = omega + b`` obeys
``J y' = M1(y - b) - M2(y - b)``: to first order a constant extra moment ``J gamma(omega) b``.
A change of ``compressor_linear`` adds ``-dc omega``, of ``turbine_gain`` ``da mu``, of
``compressor_quadratic`` ``-dd omega^2``. On one night the four differ only in how they
scale with the operating point, and the k-step errors they are fitted on are mostly the
process noise accumulated over the horizon (2.3 rad/s against a 0.5 rad/s bias).

What is computed (the diagnosis' own linearisation, :func:`graybox.diagnosis.diagnose`'s
screening): per night after the onset, on the tuned baseline white box, the k-step residual
``r`` against the baseline's level tier and each hypothesis' slope ``s_j = dr / dvalue`` at
the baseline (bias, gain, the four diagnosable parameters; the noise hypothesis reads other
evidence and is left out), weighted as the diagnosis weights them (``N_eff / N`` over the
baseline's ``residual_std``). With a bias of the injected size as the truth, the linearised
data are ``m s_bias + noise`` (noise white in those units: the composite likelihood's own
assumption) and each hypothesis scores ``(s_j . r)^2 / |s_j|^2`` (equal penalties): the
share of draws in which the bias scores highest is the top-1 the night allows. Also printed:
``1 - cos^2`` between the bias' slope and each parameter's (0: the same signature), and the
non-centrality ``delta = (1 - cos^2) m^2 |s_bias|^2`` that separates the two (the expected
score gap; the bias leads a single rival with probability ``Phi(sqrt(delta) / 2)``). The
same figures under a whitened likelihood (the errors through an autoregression of order
``2 k`` fitted to the centred ``r``, over its innovations' spread) say what a
prediction-error likelihood would gain over the diagnosis' ``N_eff / N`` scaling.

With ``--candidate-nights N`` (default the product's ``[nightly] candidate_nights``) each
scored night is read over its candidate's span, as the nightly flow diagnoses it: the
slopes over every night of the span (each hypothesis a constant over it), the bias only in
the nights from the onset on. Printed apart: the onset nights (the span holds the healthy
night before; the product now fits a change from the night that explains most, which this
constant-over-the-span geometry does not follow) and the later ones (every night faulty:
the non-centrality adds up over the nights). ``--candidate-nights 1`` is one night alone.
"""
from __future__ import annotations

import argparse
import statistics
from dataclasses import replace

import numpy as np
from scipy.signal import lfilter

import graybox as gb
from benchmarks.detection.grid import asset_id, simulate_seed, trailing_nights
from benchmarks.diagnosis.grid_run import (DETECTION, TUNED, fit_vehicle_baselines, read_windows,
                                           white_box)
from graybox.effective_samples import effective_sample_size
from graybox.level_tier import start_stride
from graybox.parameter_estimation import (ErrorSetup, operating_segments, prediction_errors,
                                          with_parameters)
from graybox.state_estimation import window_arrays
from graybox.telemetry.window import window_periods

PARAMETERS = ("compressor_linear", "turbine_gain", "compressor_quadratic", "inertia")
#: Monte-Carlo draws per night
DRAWS = 20000


def night_geometry(signature, windows, model, faulty_from: int = 0) -> dict:
    """The weighted slopes of a candidate's hypotheses at the baseline (over its nights
    ``windows``, as the diagnosis reads them), the bias' ``1 - cos^2`` with each parameter,
    and ``faulty``: which k-step errors are of the nights from ``faulty_from`` on (where the
    bias is)."""
    if not isinstance(windows, (list, tuple)):
        windows = [windows]
    model = with_parameters(model, signature.tuning.parameters()) if signature.tuning else model
    level = signature.channel("omega").level
    step = signature.analysis_step
    setup = ErrorSetup(signature.sample_interval, max(1, round(step / signature.sample_interval)),
                       level.horizon, start_stride(step, level.horizon), signature.integration_used)
    frames, _ = operating_segments(windows)
    # the night each operating period is of (prediction_errors numbers the periods)
    night_of = np.concatenate([np.full(len(window_periods(w)), i)
                               for i, w in enumerate(windows)])
    segments = [window_arrays(model, frame) for frame in frames]

    def residual(trial, trial_segments):
        errors, features, _ = prediction_errors(trial, trial_segments, setup)["omega"]
        return errors - level.level - (base_features - np.asarray(level.center)) @ np.asarray(
            level.slopes)

    _, base_features, positions = prediction_errors(model, segments, setup)["omega"]
    r = residual(model, segments)
    weight = np.sqrt(effective_sample_size([(r - r.mean())[positions == p]
                                            for p in np.unique(positions)]) / len(r))
    weight /= level.residual_std
    h = 1e-3 * level.residual_std
    slopes = {"bias": (residual(model, [(y - h, u) for y, u in segments]) - r) / h,
              "gain": (residual(model, [(y / (1 + 1e-5), u) for y, u in segments]) * (1 + 1e-5)
                       - r) / 1e-5}
    for name in PARAMETERS:
        value = model.parameters[name]
        slopes[name] = (residual(with_parameters(model, {name: value * (1 + 1e-5)}), segments)
                        - r) / (value * 1e-5)
    whitened = _whitened(r, slopes, level.horizon)
    slopes = {k: v * weight for k, v in slopes.items()}
    return {"slopes": slopes, "collinear": _collinear(slopes), "samples": len(r),
            "whitened": whitened, "collinear_whitened": _collinear(whitened),
            "faulty": night_of[positions] >= faulty_from}


def _collinear(slopes: dict) -> dict:
    b = slopes["bias"]
    return {k: float(1 - (b @ s) ** 2 / ((b @ b) * (s @ s))) for k, s in slopes.items()
            if k != "bias"}


def _whitened(r: np.ndarray, slopes: dict, order: int) -> dict:
    """The slopes through the autoregressive filter of order ``2 k`` fitted to the centred
    ``r`` (least squares), over the filtered residual's spread: the Gaussian likelihood of AR errors, the
    one a whitened (state-space) likelihood would use, instead of the ``N_eff / N`` scaling."""
    p = 2 * order
    r = r - r.mean()    # the fault's offset is not part of the noise
    lags = np.column_stack([r[p - i - 1:len(r) - i - 1] for i in range(p)])
    coefficients, *_ = np.linalg.lstsq(lags, r[p:], rcond=None)
    innovation = float(np.std(r[p:] - lags @ coefficients))
    a = np.concatenate([[1.0], -coefficients])
    return {k: lfilter(a, [1.0], v)[p:] / innovation for k, v in slopes.items()}


def allowed_top1(slopes: dict, magnitude: float, rng: np.random.Generator,
                 faulty: np.ndarray | None = None) -> float:
    """The share of draws of ``magnitude * s_bias + white noise`` in which the bias scores
    highest (each hypothesis' score ``(s . r)^2 / |s|^2``); with ``faulty`` (a mask of the
    errors), the bias is only in those (a candidate whose first nights are before the
    onset)."""
    names = list(slopes)
    matrix = np.column_stack([slopes[n] for n in names])
    basis, _ = np.linalg.qr(matrix)
    directions = basis.T @ matrix
    directions /= np.linalg.norm(directions, axis=0)
    signal = basis.T @ (magnitude * _signal(slopes, faulty))
    draws = signal[None] + rng.standard_normal((DRAWS, len(signal)))
    scores = (draws @ directions) ** 2
    return float(np.mean(np.argmax(scores, axis=1) == names.index("bias")))


def _signal(slopes: dict, faulty: np.ndarray | None) -> np.ndarray:
    """The bias' slope where the bias is (all errors without ``faulty``)."""
    return slopes["bias"] if faulty is None else np.where(faulty, slopes["bias"], 0.0)


def _delta(slopes: dict, magnitude: float, faulty: np.ndarray | None = None) -> float:
    """The non-centrality separating the bias from ``compressor_linear``: the expected score
    gap ``(u_bias . v)^2 - (u_c . v)^2`` (unit slopes ``u``, signal ``v``), which is
    ``(1 - cos^2) m^2 |s_bias|^2`` when the bias is in every error."""
    v = magnitude * _signal(slopes, faulty)
    b, c = slopes["bias"], slopes["compressor_linear"]
    return float((b @ v) ** 2 / (b @ b) - (c @ v) ** 2 / (c @ c))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.diagnosis.separability",
                                     description=__doc__.split("\n\n")[1])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--magnitudes", default="0.5,2",
                        help="bias sizes, rad/s (the grid's middle and large: 0.5,2)")
    parser.add_argument("--model-error", type=float, default=0.2)
    parser.add_argument("--candidate-nights", type=int,
                        default=DETECTION.candidate_nights,
                        help="nights a candidate spans, as the diagnosis reads them (default "
                             "the product's [nightly] candidate_nights: %(default)s; 1: a night "
                             "alone)")
    args = parser.parse_args(argv)
    magnitudes = tuple(float(m) for m in args.magnitudes.split(","))
    grid = replace(DETECTION, magnitudes={"bias": magnitudes}, model_errors=(args.model_error,),
                   seeds=tuple(range(1, args.seeds + 1)), candidate_nights=args.candidate_nights)
    rng = np.random.default_rng(0)
    found = {m: [] for m in magnitudes}
    for seed in grid.seeds:
        vehicles = simulate_seed(grid, seed)
        windows = read_windows(grid, vehicles, white_box(0.0))
        _, baselines = fit_vehicle_baselines(grid, vehicles, windows, args.model_error)
        for v in vehicles:
            result = baselines[v.vehicle]
            if isinstance(result, gb.GrayBoxError):
                continue
            twin = asset_id(v.seed, v.vehicle)
            for m in magnitudes:
                asset = asset_id(v.seed, v.vehicle, "bias", m)
                for night in range(grid.onset_day, grid.days):
                    # the candidate's span; before the onset the healthy twin's telemetry
                    days = list(trailing_nights(night, grid.candidate_nights,
                                                grid.baseline_days))
                    parts = [windows[asset if (asset, d) in windows else twin, d] for d in days]
                    onset = sum(d < grid.onset_day for d in days)
                    geometry = night_geometry(result[0], parts, white_box(args.model_error),
                                              faulty_from=onset)
                    faulty = geometry["faulty"]
                    # the whitened errors start after the autoregression's first lags
                    whitened = faulty[len(faulty) - len(geometry["whitened"]["bias"]):]
                    found[m].append({
                        "nights_in_span": len(days), "onset_in_span": onset > 0,
                        "allowed": allowed_top1(geometry["slopes"], m, rng, faulty),
                        "allowed_whitened": allowed_top1(geometry["whitened"], m, rng,
                                                         whitened),
                        "collinear": geometry["collinear"],
                        "delta_c": _delta(geometry["slopes"], m, faulty),
                        "delta_c_whitened": _delta(geometry["whitened"], m, whitened)})
    print(f"seeds {list(grid.seeds)} x {grid.vehicles} vehicles x {grid.post_nights} nights, model error "
          f"{args.model_error:g} (tuned on {list(TUNED)}); candidates on "
          f"{grid.candidate_nights} night(s)")
    for m, rows in found.items():
        allowed = statistics.mean(r["allowed"] for r in rows)
        median = {k: statistics.median(r["collinear"][k] for r in rows)
                  for k in rows[0]["collinear"]}
        whitened = statistics.mean(r["allowed_whitened"] for r in rows)
        print(f"bias {m:g} rad/s: {len(rows)} nights; top-1 the evidence allows "
              f"{allowed:.0%} (mean over nights; {whitened:.0%} under the whitened "
              f"likelihood); median delta vs compressor_linear "
              f"{statistics.median(r['delta_c'] for r in rows):.2f} (whitened "
              f"{statistics.median(r['delta_c_whitened'] for r in rows):.2f}); median "
              f"1 - cos^2 with " + ", ".join(f"{k} {v:.4f}" for k, v in median.items()))
        if grid.candidate_nights > 1:
            for onset in (True, False):
                part = [r for r in rows if r["onset_in_span"] == onset]
                if part:
                    which = ("onset night (a healthy night in the span)" if onset
                             else "later nights (every night of the span faulty)")
                    print(f"  {which}: {len(part)} nights, allowed "
                          f"{statistics.mean(r['allowed'] for r in part):.0%}, median delta "
                          f"{statistics.median(r['delta_c'] for r in part):.2f}")


if __name__ == "__main__":
    main()
