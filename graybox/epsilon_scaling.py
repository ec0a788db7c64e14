"""Epsilon of a candidate window whose sample count differs from the calibrated night's.

Calibration (:mod:`graybox.calibration`, step 2) sets epsilon for a candidate of one night
of ``N`` residual samples against a baseline of ``N_baseline``: parameter estimates are
asymptotically averages, so a change ``d`` has variance ``V (1/N + 1/N_baseline)`` and a
healthy zeta ``|d|^2`` scales with it. A candidate of ``n`` samples has
``V (1/n + 1/N_baseline)``.

Longer window (``n > N``, e.g. ``[nightly] candidate_nights = 2``)
    epsilon is multiplied by ``(1/n + 1/N_baseline) / (1/N + 1/N_baseline)``: the baseline's
    own estimation noise does not shrink with the candidate's length, so the threshold falls
    less than ``N / n`` (0.6 rather than 0.5 for two nights against a four-night baseline).
    Chosen over ``N / n`` from the detection benchmark's two-night experiment
    (``python -m benchmarks.detection.window``, docs/benchmarks.md): ``N / n`` gave 2 false
    alarms in 576 healthy windows (one model-error cell at 1.0 %, the target), this form 1 in
    576, and both close the gap at the middle fault magnitudes.
Shorter window (``n < N``, a partial window of a reanalysis)
    epsilon is multiplied by ``N / n`` as before (the conservative side: more than the
    variance model's ratio).
``n = N``
    factor 1: a one-night candidate's epsilon is the calibrated one.

Without ``N_baseline`` (unknown) a longer window keeps factor 1 (never lowered blindly).
"""
from __future__ import annotations


def epsilon_scale(n_samples: int, reference_samples: int,
                  baseline_samples: int | None = None) -> float:
    """Factor on a calibrated epsilon for a candidate of ``n_samples`` residual samples.

    Parameters
    ----------
    n_samples : int
        Residual samples of the candidate (> 0).
    reference_samples : int
        Residual samples of one calibrated night, ``N`` (> 0).
    baseline_samples : int, optional
        Residual samples of the baseline, ``N_baseline``; needed to scale down.

    Returns
    -------
    float
        ``N / n`` for ``n <= N``; ``(1/n + 1/N_baseline) / (1/N + 1/N_baseline)`` for
        ``n > N`` with ``N_baseline`` given; else 1.

    Examples
    --------
    >>> epsilon_scale(200, 100, 400)
    0.6
    >>> epsilon_scale(50, 100, 400)
    2.0
    """
    if n_samples <= 0 or reference_samples <= 0:
        raise ValueError(f"sample counts must be positive, got n_samples={n_samples}, "
                         f"reference_samples={reference_samples}")
    if n_samples <= reference_samples:
        return reference_samples / n_samples
    if baseline_samples is None:
        return 1.0
    if baseline_samples <= 0:
        raise ValueError(f"baseline_samples must be positive, got {baseline_samples}")
    return ((1 / n_samples + 1 / baseline_samples)
            / (1 / reference_samples + 1 / baseline_samples))
