"""Calibration of the drift threshold epsilon per tier and channel (the paper has no method).

Method (held-out healthy pieces, scaled chi-square, predictive F quantile):

1. The baseline period consists of K >= 3 healthy windows of the nightly length. Each window
   k is left out in turn: the tiers are refitted on the other K - 1 windows (theta_-k, frozen
   structure), and window k, cut into q pieces, is fitted piece by piece exactly as nightly
   candidates of theta_-k are. Each change d = theta_piece - theta_-k is a healthy drift
   between independent data: sampling noise plus the variation of a healthy asset. (A piece
   compared with a baseline that contains it would understate the drift.)
2. A piece is shorter than a night, so its change is rescaled to the change of a nightly
   window against the full baseline: parameter estimates are asymptotically averages,
   Var(theta_n) = V / n, so Var(d) = V (1/n_piece + 1/n_rest) while a night of N samples gives
   V (1/N + 1/N_baseline); d is multiplied by the square root of the ratio. Cutting windows
   into pieces gives K q healthy drifts instead of K, which matters for estimating a tail.
3. A healthy zeta = |d|^2 is a quadratic form of a roughly Gaussian vector, well described by
   g * chi2(h) (Satterthwaite): g h = tr(Sigma), h = tr(Sigma)^2 / tr(Sigma^2). tr(Sigma) is the
   mean of the zetas; tr(Sigma^2) is estimated without bias from the cross products
   (d_k . d_l)^2 of distinct pieces. A second estimate of h comes from the spread of the
   zetas themselves (variance 2 g^2 h), without the small-sample bias of an inverse sample
   variance (times (k - 3) / (k - 1): five zetas that happen to agree would otherwise read
   as a light tail, and a new healthy zeta would cross epsilon at about twice alpha; for
   three zetas, where no such factor exists, a simulated 0.2); the smaller h (the heavier
   tail) is used.
4. With g estimated from only K q pieces, a new healthy zeta divided by their mean is
   F(h, K q h)-distributed, so epsilon = mean(zeta_k) * F.ppf(1 - alpha; h, K q h): the
   uncertainty of a small sample is part of the threshold, not ignored.
5. Day-to-day variation. Pieces of one day share that day's conditions (load, weather, the
   model error at that day's operating point), so their spread can miss how much whole
   healthy days differ. Each left-out window is therefore also fitted whole, as a nightly
   candidate of its refit: K changes of exactly a night's kind (``TierThreshold.day_zetas``).
   Their mean predicts a new night's zeta too, with F(h, K h) for K days: epsilon is the
   larger of the pieces' threshold and the days'. Only the asset's own windows count, so a
   baseline does not depend on which assets are fitted with it (a batch, a memory group, a
   Dask worker). With few days the days' quantile is wide (F(1, 5) at 0.1 % is 43 where
   the pieces' F(1, 40) is 12): the price of not knowing, from five days, whether days
   differ.
   Measured on the plant zoo (``python -m benchmarks.zoo``): without step 5 healthy
   asset-nights alarmed on 5-28 % of nights in four of six families. A left-out day driven
   beyond the other days' input conditions has its changes divided by how far
   (:mod:`graybox.operating_conditions`), as a night's are, so that epsilon describes a night
   within the baseline's range.
6. alpha = false_alarm_rate / (tiers x channels) (Bonferroni), so the asset-night false-alarm
   rate stays at or below the target. A candidate window shorter than the reference window
   gets epsilon scaled up by the ratio of sample counts, a longer one (several nights)
   scaled down (:mod:`graybox.epsilon_scaling`).

The number of pieces q adapts to the telemetry's rate: at most ``calibration_splits``, and
no more than leave each piece enough residual samples for the frozen structure (differencing,
AR order, network delays) plus ``min_samples``. A day of 10-s or 1-s telemetry gives the full
8 pieces; a day of 1-minute telemetry (1,440 samples) gives fewer, longer ones, and step 2's
rescaling accounts for their length.

:func:`fit_baselines` runs the whole method: baselines, the leave-one-window-out refits and
the pieces, all assets batched together (:func:`graybox.signature_fit.fit_signatures`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar, Sequence

import numpy as np
from scipy import special

from graybox import record_json
from graybox.analysis_rate import decimation_factor
from graybox.epsilon_scaling import epsilon_scale
from graybox.exceptions import ArtifactError, GrayBoxError, InsufficientDataError
from graybox.signature_fit import (MIN_BASELINE_WINDOWS, FitRequest, fit_signatures,
                                   without_short_windows)
from graybox.operating_conditions import outside
from graybox.telemetry.window import window_periods
from graybox.settings import GrayBoxSettings
from graybox.signature import Signature
from graybox.stage_clock import StageClock
from graybox.segment_cache import SegmentCache
from graybox.tiers import TIER_KINDS, Tier

METHOD = "held-out healthy pieces rescaled to a night, scaled chi-square, predictive F quantile"


@dataclass(frozen=True)
class TierThreshold:
    """Epsilon of one tier and channel, and what it was computed from."""

    channel: str
    tier: str
    epsilon: float
    mean_zeta: float        #: mean healthy zeta of the K windows
    dof: float              #: effective degrees of freedom h
    healthy_zetas: tuple[float, ...]
    #: zetas of the whole left-out windows (step 5); absent from calibrations stored before it
    day_zetas: tuple[float, ...] | None = None

    omitted_when_none: ClassVar[frozenset[str]] = frozenset({"day_zetas"})


@dataclass(frozen=True)
class Calibration:
    """Thresholds for every tier and channel of a baseline, stored with it.

    Attributes
    ----------
    thresholds : tuple of TierThreshold
    false_alarm_rate : float
        Target false-alarm rate per asset and window.
    test_alpha : float
        Per-threshold rate after the Bonferroni split.
    reference_samples : int
        Residual samples of one healthy window (a night).
    n_windows : int
        Healthy pieces the thresholds were estimated from (K windows times q pieces).
    method : str
    """

    thresholds: tuple[TierThreshold, ...]
    false_alarm_rate: float
    test_alpha: float
    reference_samples: int
    n_windows: int
    method: str = METHOD

    def threshold(self, channel: str, tier: str) -> TierThreshold:
        for entry in self.thresholds:
            if entry.channel == channel and entry.tier == tier:
                return entry
        raise KeyError(f"no calibrated threshold for channel {channel!r}, tier {tier!r}")

    def epsilon(self, channel: str, tier: str, n_samples: int | None = None,
                baseline_samples: int | None = None) -> float:
        """Epsilon for a candidate of ``n_samples`` residual samples: scaled up if shorter
        than a night, down if longer and ``baseline_samples`` is given
        (:func:`graybox.epsilon_scaling.epsilon_scale`)."""
        value = self.threshold(channel, tier).epsilon
        if n_samples:
            value *= epsilon_scale(n_samples, self.reference_samples, baseline_samples)
        return value

    def to_dict(self) -> dict:
        """A JSON-ready dict; :meth:`from_dict` gives back an equal calibration."""
        return record_json.to_dict(self)

    def to_json(self, indent: int | None = None) -> str:
        return record_json.to_json(self, indent)

    @classmethod
    def from_dict(cls, data) -> "Calibration":
        """Rebuild from :meth:`to_dict`; anything malformed raises ArtifactError (every
        number must be finite, every epsilon >= 0, one threshold per channel and tier)."""
        calibration = record_json.from_dict(cls, data)
        seen = set()
        for entry in calibration.thresholds:
            where = f"Calibration threshold of channel {entry.channel!r}, tier {entry.tier!r}"
            if not entry.tier:  # a tier added by the caller's kinds is stored like the others
                raise ArtifactError(f"{where}: the tier has no name")
            if entry.epsilon < 0:
                raise ArtifactError(f"{where}: epsilon must be >= 0, got {entry.epsilon!r}")
            if (entry.channel, entry.tier) in seen:
                raise ArtifactError(f"{where}: listed twice")
            seen.add((entry.channel, entry.tier))
        if not 0 < calibration.false_alarm_rate < 1:
            raise ArtifactError(f"Calibration.false_alarm_rate must be in (0, 1), got "
                                f"{calibration.false_alarm_rate!r}")
        return calibration

    @classmethod
    def from_json(cls, text: str | bytes) -> "Calibration":
        return cls.from_dict(record_json.parse_json(text, "calibration"))


#: :func:`_spread_factor` for three changes, where E[1 / s^2] is infinite and no factor
#: removes the bias: chosen by simulation (zetas chi2(h) of h = 1-20 among 4-32 parameters,
#: 20,000 calibrations each) so that a new healthy zeta crosses epsilon at 0.1-1.4 alpha;
#: (k - 3) / (k - 1) would be 0, h 1 and epsilon 24-80 times the true quantile: a baseline
#: of three days of a slow export (one piece a day) that never alarms
THREE_CHANGES_SPREAD_FACTOR = 0.2


def _spread_factor(k: int) -> float:
    """The factor on ``2 mean^2 / s^2`` of ``k`` zetas that takes out the small-sample bias
    of an inverse sample variance: (k - 3) / (k - 1), and for k = 3
    :data:`THREE_CHANGES_SPREAD_FACTOR`."""
    return (k - 3) / (k - 1) if k > 3 else THREE_CHANGES_SPREAD_FACTOR


def threshold_from_deltas(deltas: Sequence[np.ndarray], alpha: float,
                          day_zetas: Sequence[float] | None = None
                          ) -> tuple[float, float, float]:
    """Epsilon from healthy parameter changes (steps 3-5 of the module's method).

    Parameters
    ----------
    deltas : sequence of ndarray
        The vectors ``d_k`` (pieces, rescaled to a night) whose squared norms are healthy
        zetas.
    alpha : float
        Probability that a healthy zeta exceeds epsilon.
    day_zetas : sequence of float, optional
        Zetas of D whole windows (step 5): epsilon is at least their mean times
        ``F.ppf(1 - alpha; h, D h)``.

    Returns
    -------
    epsilon, mean_zeta, dof : float
    """
    deltas = [np.asarray(d, dtype=float) for d in deltas]
    k = len(deltas)
    if k < 3:
        raise InsufficientDataError(f"calibration needs at least 3 healthy changes, got {k}")
    size = deltas[0].size
    zetas = np.array([d @ d for d in deltas])
    mean = float(zetas.mean())
    if mean <= 0 or size == 0:
        return 0.0, mean, float(max(size, 1))
    stacked = np.vstack(deltas)
    cross = (stacked @ stacked.T) ** 2
    np.fill_diagonal(cross, 0.0)
    trace_sq = float(cross.sum()) / (k * (k - 1))
    dof_cross = np.inf if trace_sq <= 0 else mean ** 2 / trace_sq
    # the zetas' own spread gives a second estimate (g chi2(h) has variance 2 g^2 h); it
    # guards against non-Gaussian changes, e.g. a network landing in different minima
    spread = float(zetas.var(ddof=1))
    # the variance of k zetas is estimated without bias, its inverse is not: for a sample
    # variance on k - 1 degrees of freedom E[1 / s^2] = (k - 1) / (k - 3) / sigma^2, so
    # 2 mean^2 / s^2 overstates h, on five zetas by half (a light tail where five days
    # happened to agree); (k - 3) / (k - 1) removes that bias
    dof_spread = np.inf if spread <= 0 else 2 * mean ** 2 / spread * _spread_factor(k)
    dof = float(np.clip(min(dof_cross, dof_spread, size), 1.0, size))
    # special.fdtri is scipy.stats.f.ppf's own; scipy.stats takes 0.5 s to import
    epsilon = mean * float(special.fdtri(dof, k * dof, 1.0 - alpha))
    if day_zetas:
        days = float(np.mean(day_zetas)) * float(special.fdtri(dof, len(day_zetas) * dof,
                                                                 1.0 - alpha))
        epsilon = max(epsilon, days)
    return epsilon, mean, dof


#: target false alarms per asset-night that sets epsilon, unless a caller gives another
#: (``[alerts] false_alarm_rate``, ``GrayBox(false_alarm_rate=...)``)
DEFAULT_FALSE_ALARM_RATE = 0.01


def fit_baselines(requests: Sequence[FitRequest], settings: GrayBoxSettings | None = None,
                  false_alarm_rate: float = DEFAULT_FALSE_ALARM_RATE, chunk_size: int = 32,
                  clock: StageClock | None = None, kinds: Sequence[Tier] = TIER_KINDS
                  ) -> list[tuple[Signature, Calibration] | GrayBoxError]:
    """Fit baselines and calibrate their epsilons (see :mod:`graybox.calibration`).

    Each request's windows are its K >= 3 healthy windows, each as long as a nightly window
    (typically one day). Each window is left out in turn: the others refit the baseline, and
    the window, cut into pieces (:func:`calibration_pieces`), is fitted as nightly candidates
    of that refit. All assets' refits are batched like the baselines.

    clock : StageClock, optional
        Accumulates the seconds of the fits' stages (see
        :func:`graybox.signature_fit.fit_signatures`).
    kinds : sequence of Tier, default TIER_KINDS
        The tiers fitted and calibrated (an added tier gets its epsilons like the others).

    Returns
    -------
    list
        Per request ``(signature, calibration)`` or the error that stopped it.
    """
    if not 0 < false_alarm_rate < 1:
        raise ValueError(f"false_alarm_rate must be in (0, 1), got {false_alarm_rate}")
    settings = settings or GrayBoxSettings()
    fresh = [replace(r, baseline=None, warm_start=None) for r in requests]
    # every window is fitted several times below: its hidden states, residual and level
    # data are computed once (the pieces, new data, are not kept)
    cache = SegmentCache()
    signatures = fit_signatures(fresh, settings, chunk_size, clock, cache, kinds)
    # a window that ran too little to fit is left out where enough others remain
    fresh, signatures = without_short_windows(
        fresh, signatures, lambda again: fit_signatures(again, settings, chunk_size, clock,
                                                        cache, kinds),
        least=MIN_BASELINE_WINDOWS)
    cache.storing = False
    results: list = list(signatures)
    jobs = []  # (position, baseline signature, number of windows)
    for position, (request, signature) in enumerate(zip(fresh, signatures)):
        if isinstance(signature, GrayBoxError):
            continue
        if len(request.windows) < MIN_BASELINE_WINDOWS:
            results[position] = InsufficientDataError(
                f"asset {signature.asset_id!r}: calibration needs at least "
                f"{MIN_BASELINE_WINDOWS} healthy windows "
                f"(one per night), got {len(request.windows)}")
            continue
        jobs.append((position, signature, len(request.windows)))
    # every window is left out once: the others refit the baseline (frozen structure)...
    rest_requests = [replace(fresh[p], windows=[w for j, w in enumerate(fresh[p].windows) if j != k],
                             baseline=sig)
                     for p, sig, count in jobs for k in range(count)]
    rests = fit_signatures(rest_requests, settings, chunk_size, clock, cache, kinds)
    # ...and the left-out window's pieces are fitted as nightly candidates of that refit, and
    # so is the whole window (a healthy night with its own day's conditions)
    requests, owners = [], []
    for (p, sig, count), first in zip(jobs, np.cumsum([0] + [c for _, _, c in jobs])):
        for k in range(count):
            rest = rests[first + k]
            window = fresh[p].windows[k]
            warm = rest if isinstance(rest, Signature) else sig
            # a fragment must be as long as the fit asks of any operating period, and a
            # piece as long as its frozen structure needs
            shortest = settings.shortest_period_samples(sig.sample_interval)
            pieces = _split(window, calibration_pieces(sig, _length(window), sig.settings),
                            shortest)
            for piece in _merge_short(pieces, sig, sig.settings) + [window]:
                requests.append(replace(fresh[p], windows=[piece], baseline=sig, warm_start=warm))
                owners.append((p, first + k, piece is window))
    fitted = fit_signatures(requests, settings, chunk_size, clock, cache, kinds)
    pairs: dict[int, list] = {p: [] for p, _, _ in jobs}
    days: dict[int, list] = {p: [] for p, _, _ in jobs}
    for (p, rest_index, whole), candidate in zip(owners, fitted):
        (days if whole else pairs)[p].append((rests[rest_index], candidate))
    for p, sig, count in jobs:
        # a piece too bare to describe (the machine stood still through it: its residual is
        # constant) holds no healthy change; the day's other pieces and the whole day do
        pairs[p] = [pair for pair in pairs[p] if not isinstance(pair[1], InsufficientDataError)
                    ] or pairs[p]
        failure = next((x for pair in pairs[p] + days[p] for x in pair
                        if isinstance(x, GrayBoxError)), None)
        if failure is not None:
            results[p] = failure
            continue
        try:
            results[p] = (sig, _calibrate(sig, _changes(sig, pairs[p], days[p], kinds),
                                          false_alarm_rate))
        except GrayBoxError as error:
            results[p] = type(error)(f"asset {sig.asset_id!r}: {error}")
    return results


def calibration_pieces(baseline: Signature, n_samples: int, settings: GrayBoxSettings) -> int:
    """Pieces a healthy window of ``n_samples`` telemetry samples is cut into.

    At most ``settings.calibration_splits``; fewer where a piece would not leave every
    channel's frozen structure (differencing, AR order, network delays) and
    ``settings.min_samples`` residual samples at the analysis interval.
    """
    return int(np.clip(n_samples // _piece_need(baseline, settings), 1,
                       settings.calibration_splits))


def _piece_need(baseline: Signature, settings: GrayBoxSettings) -> int:
    """Telemetry samples a piece needs: every channel's frozen structure plus min_samples."""
    factor = decimation_factor(baseline.analysis_step, baseline.sample_interval)
    need = 0
    for channel in baseline.channels:
        s = channel.structure
        need = max(need, s.differencing.lost
                   + max(settings.min_sample_count, s.ar_order + s.embedding_dim * s.tau
                         + settings.min_sample_count // 2) + 2)
    return factor * need


def _length(window) -> int:
    return sum(len(p) for p in window_periods(window))


def _split(window, parts: int, shortest: int = 1) -> list:
    """Cut a window into ``parts`` contiguous pieces of (nearly) equal length.

    A window of several operating periods is cut by operating samples, and a piece is the
    tuple of its periods' fragments. A cut closer than ``shortest`` samples to a period's
    edge moves to that edge, so no fragment is shorter; periods shorter than ``shortest``
    are left out.
    """
    periods = window_periods(window)
    if len(periods) > 1:
        periods = [p for p in periods if len(p) >= shortest]
        if not periods:
            return []
    if len(periods) == 1:
        frame = periods[0]
        bounds = np.linspace(0, len(frame), parts + 1).round().astype(int)
        return [frame.iloc[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
    edges = np.cumsum([0] + [len(p) for p in periods])
    cuts = []
    for cut in np.linspace(0, edges[-1], parts + 1).round().astype(int):
        k = min(int(np.searchsorted(edges, cut, side="right")) - 1, len(periods) - 1)
        offset = cut - edges[k]
        if offset < shortest:
            cut = edges[k]
        elif edges[k + 1] - cut < shortest:
            cut = edges[k + 1]
        cuts.append(int(cut))
    pieces = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        if b <= a:
            continue
        fragments = tuple(period.iloc[max(a, lo) - lo:min(b, hi) - lo]
                          for period, lo, hi in zip(periods, edges[:-1], edges[1:])
                          if lo < b and hi > a)
        pieces.append(fragments)
    return pieces


def _merge_short(pieces: list, baseline: Signature, settings: GrayBoxSettings) -> list:
    """Pieces of several operating periods joined with the next (the last with the one
    before) until each keeps ``min_samples`` residual samples: every fragment loses its
    channels' differencing, AR order and delays at its start, so a piece of many short
    fragments needs more operation than one of a single period."""
    factor = decimation_factor(baseline.analysis_step, baseline.sample_interval)
    loss = max(c.structure.differencing.lost + c.structure.ar_order
               + c.structure.embedding_dim * c.structure.tau for c in baseline.channels)

    def enough(fragments: tuple) -> bool:
        return sum(max(0, len(f) // factor - loss) for f in fragments) > settings.min_sample_count + 2

    merged, pending = [], ()
    for piece in pieces:
        if not isinstance(piece, tuple):
            merged.append(piece)
            continue
        pending = pending + piece
        if enough(pending):
            merged.append(pending)
            pending = ()
    if pending:
        if merged and isinstance(merged[-1], tuple):
            merged[-1] = merged[-1] + pending
        else:
            merged.append(pending)
    return merged


def _changes(baseline: Signature, pairs: list[tuple[Signature, Signature]],
             days: list[tuple[Signature, Signature]], kinds: Sequence[Tier] = TIER_KINDS
             ) -> dict[tuple[str, str], tuple[list, list]]:
    """Per channel and tier: the pieces' changes and the whole windows' changes against
    their rest refits, each rescaled to a night against the full baseline.

    Var(theta_n) ~ V / n: a candidate and its reference are independent, so the change has
    variance V (1/n_candidate + 1/n_rest); a night against the baseline has
    V (1/n_night + 1/n_baseline).
    """
    total = baseline.n_samples
    night = 1 / (total / len(days)) + 1 / total
    # a whole day driven beyond the other days' conditions is discounted as a night would be
    # (graybox.operating_conditions); a piece's conditions are part of a day's (a diurnal
    # cycle), not a day's, so pieces are compared as they are
    beyond = {figures: [outside(whole.conditions, rest.conditions, figures)
                        for rest, whole in days]
              for figures in {kind.condition_figures for kind in kinds}}
    out = {}
    for channel in baseline.channel_names:
        for kind in kinds:
            if kind.present(baseline.channel(channel)):
                out[channel, kind.name] = (
                    [_rescaled(kind, rest, piece, channel, night) for rest, piece in pairs],
                    [_rescaled(kind, rest, whole, channel, night, conditions)
                     for (rest, whole), conditions in zip(days, beyond[kind.condition_figures])])
    return out


def _calibrate(baseline: Signature, changes: dict[tuple[str, str], tuple[list, list]],
               false_alarm_rate: float) -> Calibration:
    """Epsilons from the pieces' and the whole windows' changes (:func:`_changes`)."""
    alpha = false_alarm_rate / len(changes)
    thresholds = []
    for (channel, tier), (deltas, day_deltas) in changes.items():
        day_zetas = tuple(float(d @ d) for d in day_deltas)
        epsilon, mean, dof = threshold_from_deltas(deltas, alpha, day_zetas)
        thresholds.append(TierThreshold(channel, tier, epsilon, mean, dof,
                                        tuple(float(d @ d) for d in deltas), day_zetas))
    pieces, windows = (len(c) for c in next(iter(changes.values())))
    return Calibration(tuple(thresholds), false_alarm_rate, alpha,
                       int(round(baseline.n_samples / windows)), pieces)


def _rescaled(kind, rest: Signature, candidate: Signature, channel: str,
              night: float, conditions: float = 0.0) -> np.ndarray:
    """A candidate's change against its rest refit (as :meth:`~graybox.tiers.Tier.drift_deltas`
    discounts it, ``conditions`` the candidate's distance beyond the rest's input
    conditions), rescaled to a night's variance."""
    delta = kind.drift_deltas(candidate.channel(channel), rest.channel(channel), conditions)
    return delta * np.sqrt(night / (1 / candidate.n_samples + 1 / rest.n_samples))
