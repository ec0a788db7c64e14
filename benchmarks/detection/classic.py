"""The classic detectors of the paper's section I, on the white-box residual, and their
per-asset calibration.

Every detector turns one night's residual ``r`` (one channel, one UTC day) into one alarm
statistic; an asset-night alarms when the statistic exceeds the asset's threshold. All work
from the same per-night *features* on 5-minute batches:

``redline``     fixed 3-sigma redline: fraction of samples outside ``mu0 +- 3 sigma0`` (mean
                and std of the K baseline days).
``adaptive``    adaptive threshold: fraction of samples outside ``m_t +- 3 s_t``, the trailing
                one-hour rolling mean and std (the first hour of every night is the warm-up).
``cusum_mean``  two-sided Page CUSUM (reference k = 0.5) on the standardized batch means
                ``u_b = (mean_b(r) - M) / S``; the statistic is the night's largest CUSUM value.
``cusum_var``   the same on the standardized log batch mean squares of the standardized
                residual, ``v_b = (log mean_b(z^2) - Q) / R``, ``z = (r - mu0) / sigma0`` (a
                variance CUSUM; the log makes the chi-square-like mean square near-Gaussian).
``glr``         generalized likelihood ratio for a shift, at an unknown batch, of the mean of
                ``(u_b, v_b)`` (Gaussian, unit variance): ``max_tau |S_tau|^2 / (2 m_tau)`` over
                change points with at least ``glr_min_batches`` batches after them.

Batches make the mean/variance detectors usable on a coloured residual (the raw residual is
an AR(2)-like process, and a wrong white box adds the daily load cycle); the batch statistics
``M, S, Q, R`` come from the baseline days too.

Calibration (per asset, to the same target as the gray box). With K = 4 healthy days an
empirical 1 % quantile is out of reach, and recombining pieces of the baseline days into
pseudo-nights was tried and rejected: the night maximum of a CUSUM or GLR is set by its worst
piece, so pseudo-nights can never exceed the worst baseline piece and their 99 % quantile
equals their maximum (measured: 10-17 % false alarms). Instead a *fitted distribution*:

1. The features of baseline day ``d`` are computed with reference values fitted on the other
   K - 1 days (leave one day out), so the estimation error of ``mu0``, ``sigma0``, ``M``, ...
   is part of the healthy spread.
2. Each batch-level series (fraction beyond the redline, fraction beyond the rolling limits,
   ``u``, ``v``) is modelled as a time-of-day profile plus Gaussian AR noise
   (:func:`fit_series_model`): the profile is the K-day mean shrunk by a James-Stein factor
   (kept when a wrong white box leaves the daily load cycle in the residual, dropped when it
   is noise), the AR order is chosen by AIC, and the noise variance is inflated for the
   profile's own estimation error.
3. ``simulated_nights`` predictive nights are drawn from these models: each with its own level
   offset (the error of the K-day mean, from the AR model's long-run variance, plus the
   day-to-day variation of the level that the K days show beyond it) and its own
   noise variance (scaled inverse chi-square with the estimate's effective degrees of freedom),
   so the threshold carries the baseline's estimation error, like the gray box's predictive F
   quantile. The threshold of every detector is the ``1 - alpha`` quantile of its statistic over
   these nights.

The realized false-alarm rate of this calibration is measured by the benchmark on healthy
nights that were not used to fit it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

DETECTORS = ("redline", "adaptive", "cusum_mean", "cusum_var", "glr")


@dataclass(frozen=True)
class ClassicSettings:
    """Choices of the classic detectors (none is learned from data)."""

    batch_seconds: float = 300.0
    rolling_seconds: float = 3600.0
    sigma_limit: float = 3.0
    cusum_k: float = 0.5
    glr_min_batches: int = 12
    simulated_nights: int = 4000


@dataclass(frozen=True)
class Reference:
    """Healthy reference values of one asset's residual (fitted on baseline days)."""

    mean: float
    std: float
    batch_mean: float
    batch_mean_std: float
    batch_square: float
    batch_square_std: float


@dataclass
class Features:
    """Per-batch features of one night (arrays of one length, the night's batches)."""

    count: np.ndarray      # samples in the batch
    beyond: np.ndarray     # samples outside mu0 +- limit sigma0
    adaptive: np.ndarray   # samples outside the rolling limits
    evaluated: np.ndarray  # samples the rolling limits were evaluated on
    u: np.ndarray          # standardized batch mean
    v: np.ndarray          # standardized batch mean square

    FIELDS = ("count", "beyond", "adaptive", "evaluated", "u", "v")

    @classmethod
    def stack(cls, items: Sequence["Features"]) -> "Features":
        return cls(*(np.stack([getattr(f, name) for f in items]) for name in cls.FIELDS))


@dataclass(frozen=True)
class ClassicCalibration:
    """Per-asset thresholds of every classic detector and what they came from."""

    reference: Reference
    thresholds: dict
    alpha: float
    baseline_days: int
    simulated_nights: int
    day_statistics: dict = field(default_factory=dict)  # leave-one-day-out day values
    profile_weights: dict = field(default_factory=dict)  # shrinkage of each series' profile


def _batch_ids(n: int, batch: int, offset: int) -> np.ndarray:
    return (np.arange(n) + offset) // batch


def _samples(seconds: float, dt: float) -> int:
    return max(1, int(round(seconds / dt)))


def _log_square(mean_square: np.ndarray) -> np.ndarray:
    """Log of a batch mean square (near-Gaussian where the mean square is chi-square-skewed)."""
    return np.log(np.maximum(mean_square, 1e-12))


def fit_reference(days: Sequence[np.ndarray], dt: float, settings: ClassicSettings,
                  offset: int = 1) -> Reference:
    """Reference values from healthy days' residuals.

    ``offset`` is the grid position of a day's first residual sample (1 for the one-step
    residual, which drops the first sample of the window).
    """
    pooled = np.concatenate(days)
    mean, std = float(pooled.mean()), float(pooled.std())
    if not std > 0:
        raise ValueError("the baseline residual is constant")
    batch = _samples(settings.batch_seconds, dt)
    means, squares = [], []
    for r in days:
        ids = _batch_ids(len(r), batch, offset)
        count = np.bincount(ids)
        z = (r - mean) / std
        means.append(np.bincount(ids, weights=r) / count)
        squares.append(_log_square(np.bincount(ids, weights=z * z) / count))
    means, squares = np.concatenate(means), np.concatenate(squares)
    return Reference(mean, std, float(means.mean()), float(means.std()) or 1.0,
                     float(squares.mean()), float(squares.std()) or 1.0)


def night_features(r: np.ndarray, reference: Reference, dt: float, settings: ClassicSettings,
                   offset: int = 1, n_batches: int | None = None) -> Features:
    """The per-batch features of one night's residual."""
    r = np.asarray(r, dtype=float)
    batch = _samples(settings.batch_seconds, dt)
    window = _samples(settings.rolling_seconds, dt)
    ids = _batch_ids(len(r), batch, offset)
    size = int(ids[-1]) + 1 if n_batches is None else n_batches
    count = np.bincount(ids, minlength=size).astype(float)
    safe = np.maximum(count, 1.0)
    z = (r - reference.mean) / reference.std
    beyond = np.bincount(ids, weights=np.abs(z) > settings.sigma_limit, minlength=size)
    u = (np.bincount(ids, weights=r, minlength=size) / safe - reference.batch_mean) / reference.batch_mean_std
    v = ((_log_square(np.bincount(ids, weights=z * z, minlength=size) / safe) - reference.batch_square)
         / reference.batch_square_std)
    # trailing rolling mean and std over the previous `window` samples (not the current one)
    x = r - r.mean()
    c1 = np.concatenate([[0.0], np.cumsum(x)])
    c2 = np.concatenate([[0.0], np.cumsum(x * x)])
    t = np.arange(window, len(x))
    m = (c1[t] - c1[t - window]) / window
    s = np.sqrt(np.maximum((c2[t] - c2[t - window]) / window - m * m, 0.0))
    outside = np.abs(x[t] - m) > settings.sigma_limit * s
    adaptive = np.bincount(ids[t], weights=outside, minlength=size)
    evaluated = np.bincount(ids[t], minlength=size).astype(float)
    return Features(count, beyond, adaptive, evaluated, u, v)


def cusum_max(x: np.ndarray, k: float) -> np.ndarray:
    """Largest value of the two-sided Page CUSUM over each row of ``x`` (rows are nights)."""
    x = np.atleast_2d(x)
    high = np.zeros(len(x))
    low = np.zeros(len(x))
    best = np.zeros(len(x))
    for j in range(x.shape[1]):
        high = np.maximum(0.0, high + x[:, j] - k)
        low = np.maximum(0.0, low - x[:, j] - k)
        best = np.maximum(best, np.maximum(high, low))
    return best


def cusum_first_alarm(x: np.ndarray, k: float, h: float) -> int:
    """Index of the first sample at which the two-sided CUSUM of ``x`` exceeds ``h`` (-1: none)."""
    high = low = 0.0
    for j, value in enumerate(np.asarray(x, dtype=float)):
        high = max(0.0, high + value - k)
        low = max(0.0, low - value - k)
        if high > h or low > h:
            return j
    return -1


def glr_max(u: np.ndarray, v: np.ndarray, min_batches: int) -> np.ndarray:
    """``max_tau (S_u^2 + S_v^2) / (2 m)``, sums over the ``m >= min_batches`` batches from
    ``tau`` on: the GLR of a mean shift of ``(u, v)`` starting at an unknown batch."""
    u, v = np.atleast_2d(u), np.atleast_2d(v)
    n = u.shape[1]
    su = np.cumsum(u[:, ::-1], axis=1)[:, ::-1]
    sv = np.cumsum(v[:, ::-1], axis=1)[:, ::-1]
    m = n - np.arange(n)
    keep = m >= min(min_batches, n)
    return ((su[:, keep] ** 2 + sv[:, keep] ** 2) / (2.0 * m[keep])).max(axis=1)


def statistics(features: Features, settings: ClassicSettings) -> dict[str, np.ndarray]:
    """Night statistics of every detector; ``features`` holds one night per row (2-D) or one
    night (1-D)."""
    f = Features(*(np.atleast_2d(getattr(features, name)) for name in Features.FIELDS))
    return {
        "redline": f.beyond.sum(axis=1) / np.maximum(f.count.sum(axis=1), 1.0),
        "adaptive": f.adaptive.sum(axis=1) / np.maximum(f.evaluated.sum(axis=1), 1.0),
        "cusum_mean": cusum_max(f.u, settings.cusum_k),
        "cusum_var": cusum_max(f.v, settings.cusum_k),
        "glr": glr_max(f.u, f.v, settings.glr_min_batches),
    }


def _series(features: Features) -> dict[str, np.ndarray]:
    """Batch-level series (one day per row) that the calibration model describes."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return {"beyond": features.beyond / features.count,
                "adaptive": np.where(features.evaluated > 0,
                                     features.adaptive / features.evaluated, np.nan),
                "u": features.u, "v": features.v}


def fit_ar(rows: np.ndarray, max_order: int) -> tuple[np.ndarray, float]:
    """Gaussian AR model of the rows of ``rows`` (pooled autocovariances, Yule-Walker, order
    by AIC). Returns the coefficients ``a_1 .. a_p`` and the innovation variance."""
    from scipy.linalg import solve_toeplitz

    rows = np.atleast_2d(rows)
    n_total = rows.size
    acov = np.array([sum(float(r[: len(r) - lag] @ r[lag:]) for r in rows) / n_total
                     for lag in range(max_order + 1)])
    if not acov[0] > 0:
        return np.zeros(0), 0.0
    best = (n_total * np.log(acov[0]), np.zeros(0), float(acov[0]))
    for order in range(1, min(max_order, rows.shape[1] // 4) + 1):
        coefficients = solve_toeplitz(acov[:order], acov[1:order + 1])
        variance = float(acov[0] - coefficients @ acov[1:order + 1])
        if not variance > 0:
            break
        aic = n_total * np.log(variance) + 2 * order
        if aic < best[0]:
            best = (aic, coefficients, variance)
    return best[1], best[2]


@dataclass(frozen=True)
class SeriesModel:
    """Healthy model of one batch-level series: time-of-day profile + Gaussian AR noise."""

    profile: np.ndarray        # expected value at every batch of the night (shrunken)
    coefficients: np.ndarray   # AR coefficients of the deviations
    variance: float            # innovation variance, inflated for the profile's error
    shrinkage: float           # weight of the time-of-day profile (0: flat, 1: full)
    dof: float                 # effective degrees of freedom of the variance estimate
    level_variance: float      # per-night level variance: the K-day mean's error + day effect

    def simulate(self, nights: int, rng: np.random.Generator, burn_in: int = 200) -> np.ndarray:
        """Predictive draws: each night gets its own level offset (the K-day mean's error) and
        noise variance (scaled inverse chi-square with ``dof``), so the thresholds carry the
        estimation error of the baseline, not only the night-to-night noise."""
        from scipy.signal import lfilter

        n = len(self.profile)
        scale = np.sqrt(self.variance * self.dof / rng.chisquare(self.dof, size=(nights, 1)))
        shocks = rng.standard_normal((nights, n + burn_in)) * scale
        noise = lfilter([1.0], np.concatenate([[1.0], -self.coefficients]), shocks, axis=1)
        level = rng.standard_normal((nights, 1)) * np.sqrt(self.level_variance)
        return self.profile + level + noise[:, burn_in:]


def _variance_dof(coefficients: np.ndarray, n_total: int, lags: int = 2000) -> float:
    """Effective sample size of a variance estimate from ``n_total`` values of a Gaussian AR
    process: ``n / (1 + 2 sum rho_l^2)``."""
    from scipy.signal import lfilter

    impulse = np.zeros(lags)
    impulse[0] = 1.0
    h = lfilter([1.0], np.concatenate([[1.0], -coefficients]), impulse)
    acov = np.correlate(h, h, mode="full")[lags - 1:]
    rho = acov / acov[0]
    return max(2.0, n_total / (1.0 + 2.0 * float((rho[1:] ** 2).sum())))


def fit_series_model(rows: np.ndarray, max_order: int = 12) -> SeriesModel:
    """Model of a batch-level series from K healthy days (rows; NaN = not evaluated).

    The time-of-day profile is the mean of the K days, shrunk towards its overall mean by the
    James-Stein factor ``1 - (sigma^2 / K) / var(profile)``: a profile that the day-to-day
    noise explains is dropped, a real one (the load cycle a wrong white box leaves) is kept.
    The deviations from the profile are a Gaussian AR process (Yule-Walker, AIC); its variance
    is inflated by ``1 + shrinkage / K`` for the error of the profile itself.
    """
    rows = np.atleast_2d(np.asarray(rows, dtype=float))
    k = len(rows)
    valid = ~np.isnan(rows).any(axis=0)
    x = rows[:, valid]
    profile = x.mean(axis=0)
    noise = float(((x - profile) ** 2).sum() / max((k - 1) * x.shape[1], 1))
    level = float(profile.mean())
    spread = float(((profile - level) ** 2).mean())
    shrinkage = 0.0 if spread <= 0 else max(0.0, 1.0 - noise / (k * spread))
    smooth = level + shrinkage * (profile - level)
    # deviations from the profile used; removing a K-day mean loses (shrinkage / K) of them
    deviations = (x - smooth) / np.sqrt(max(1.0 - shrinkage / k, 1e-6))
    coefficients, variance = fit_ar(deviations, max_order)
    full = np.full(rows.shape[1], np.nan)
    full[valid] = smooth
    dof = _variance_dof(coefficients, x.size)
    long_run = variance / (1.0 - float(coefficients.sum())) ** 2 if coefficients.size else variance
    # day-to-day variation of the level beyond what the AR noise explains (one-way random
    # effects, method of moments): e.g. a slow modulation of the residual's variance moves a
    # whole night's exceedance fraction
    day_means = (x - smooth).mean(axis=1)
    between = max(0.0, float(day_means.var(ddof=1)) - long_run / x.shape[1]) if k > 1 else 0.0
    level = long_run / x.size + between * (1.0 + 1.0 / k)
    return SeriesModel(full, coefficients, variance * (1.0 + shrinkage / k), shrinkage, dof, level)


def simulate_nights(days: Features, settings: ClassicSettings, rng: np.random.Generator
                    ) -> tuple[Features, dict[str, SeriesModel]]:
    """Healthy nights drawn from the series models fitted on ``days`` (one day per row)."""
    models = {name: fit_series_model(rows) for name, rows in _series(days).items()}
    m = settings.simulated_nights
    count = np.broadcast_to(days.count[0], (m, days.count.shape[1]))
    evaluated = np.broadcast_to(days.evaluated[0], count.shape)
    sim = {name: np.nan_to_num(model.simulate(m, rng)) for name, model in models.items()}
    return Features(count, sim["beyond"] * count, sim["adaptive"] * evaluated, evaluated,
                    sim["u"], sim["v"]), models


def calibrate(days: Sequence[np.ndarray], dt: float, settings: ClassicSettings = ClassicSettings(),
              alpha: float = 0.01, seed: int = 0, offset: int = 1) -> ClassicCalibration:
    """Per-asset thresholds from K >= 3 healthy days (see the module docstring).

    Parameters
    ----------
    days : sequence of ndarray
        The residual of each baseline day (all of the same length).
    dt : float
        Sample interval in seconds.
    alpha : float
        Target false-alarm probability per asset-night of each detector.
    seed : int
        Seeds the Monte Carlo nights.
    """
    if len(days) < 3:
        raise ValueError(f"calibration needs at least 3 baseline days, got {len(days)}")
    if len({len(d) for d in days}) != 1:
        raise ValueError("baseline days must have the same number of samples")
    reference = fit_reference(days, dt, settings, offset)
    loo = []
    for d in range(len(days)):
        others = [x for i, x in enumerate(days) if i != d]
        loo.append(night_features(days[d], fit_reference(others, dt, settings, offset), dt,
                                  settings, offset))
    stacked = Features.stack(loo)
    simulated, models = simulate_nights(stacked, settings, np.random.default_rng(seed))
    values = statistics(simulated, settings)
    thresholds = {name: float(np.quantile(values[name], 1.0 - alpha)) for name in DETECTORS}
    day_values = {name: tuple(map(float, v)) for name, v in statistics(stacked, settings).items()}
    return ClassicCalibration(reference, thresholds, alpha, len(days), settings.simulated_nights,
                              day_values, {n: m.shrinkage for n, m in models.items()})


def night_statistics(r: np.ndarray, calibration: ClassicCalibration, dt: float,
                     settings: ClassicSettings = ClassicSettings(), offset: int = 1
                     ) -> dict[str, float]:
    """Every detector's statistic for one night's residual."""
    values = statistics(night_features(r, calibration.reference, dt, settings, offset), settings)
    return {name: float(values[name][0]) for name in DETECTORS}
