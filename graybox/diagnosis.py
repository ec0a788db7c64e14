"""Fault hypotheses: which single physical cause explains an alarmed window, and by how much.

A **hypothesis** changes one thing against the healthy baseline and has one free value:

``parameter``
    one parameter of the white box (the model's ``diagnosable`` names, default every number
    parameter; tables are not): the value.
``bias``
    a channel's sensor reads ``b`` high (``y = y_true + b``): ``b``, in the channel's units.
``gain``
    a channel's sensor reads ``1 + g`` times the truth: ``g`` (0.06 is +6 %).
``noise``
    a channel's one-step innovations spread ``s`` times the baseline's: ``s`` (1 is healthy).
    One-sided: a sensor that got noisier is a fault, one that got quieter is not, and a
    smaller spread is what faster-decaying dynamics give (more damping shrinks the
    fluctuation), so a fall scores no gain (its estimate still shows it) and leaves the
    ranking to the parameters.

**The evidence** is the level tier's (:mod:`graybox.level_tier`): each channel's k-step
prediction errors ``e(t) = y(t) - yhat(t | x(t - k), u)`` over the window, which carry a
parameter change (the prediction drifts from the data over ``k`` samples), a sensor bias (the
prediction forgets its biased start; the one-step residual cannot see a bias) and a gain. With
an inexact white box the healthy errors depend on the operating condition, so the baseline's
explanation is taken out first: ``r(t) = e(t) - level - slopes . (z(t) - centre)`` with the
baseline's level tier (``z``: the channel's prediction, the inputs and the drifting hidden
states' changes, :func:`graybox.level_tier.drifting_states`). Healthy, ``r`` is
modelled as Gaussian with mean 0 and the baseline's ``residual_std``.

**Fitting.** A parameter, bias or gain hypothesis transforms the white box (the parameter
changed) or the telemetry (the channel corrected, ``y - b`` or ``y / (1 + g)``), the errors
are computed again (hidden states re-estimated) and the free value minimises the weighted
squared ``r`` of every channel (a one-dimensional trust region of Newton steps, :func:`_refine`).
A gain's errors are taken back to the sensor's units (times ``1 + g``): compared in the
corrected units, dividing a
channel by ``1 + g`` shrinks its errors and any ``g > 0`` scored (a healthy crane night read
"angle sensor gain +68 %"). A noise hypothesis keeps
the white box and the telemetry as they are and fits a variance in closed form, on its own
evidence: the window's one-step innovations under the baseline's linear tier
(:mod:`graybox.innovation_spread`, what the detection's linear and noise tiers read). The
k-step errors integrate the process noise over ``k`` samples and barely see a sensor's (the
gas turbine's speed sensor x1.3 moved their spread by 2-4 %, as much as a healthy day does;
the innovations' by 12-14 %, healthy days within 1.5 %). Without a signature
(:func:`diagnose_window` given no ``spreads``) it is read on the k-step errors' spread.

**Score.** The errors are autocorrelated (overlapping predictions, slow model error), so the
log-likelihood is the Gaussian one of each channel scaled by ``N_eff / N`` (a composite
likelihood whose gain for a mean shift is chi-square with one degree of freedom when healthy;
:func:`graybox.effective_samples.effective_sample_size` of the best hypothesis' remaining
errors, per channel). The score is BIC's: ``2 (loglik - loglik_healthy) - log N_eff``, the
effective samples of all channels. Positive: the data prefer the hypothesis to "healthy" even
after paying for its free value. The hypotheses are ranked by score; if none is above
``min_score`` (default 0) the diagnosis says that no single cause explains the window
(``explained`` False) rather than name the least bad one.

**Positive values.** A parameter the model declares positive (its ``positive``, default
every number parameter whose default value is > 0:
:func:`graybox.parameter_estimation.positive_parameters`) and a gain's factor ``1 + g`` are
fitted in log space, their free value ``log(p / p_baseline)`` and ``log(1 + g) / 0.01``,
within :data:`POSITIVE_RANGE` times or divided by the baseline: the refinement steps in the
log (onto the range's end if need be), and the interval is normal in the log and mapped back
(positive, asymmetric). The screening step is taken in the value and converted, so that a
change the errors are linear in still starts the refinement at its minimum. A fit that walks
outwards past its reach tries the range's end: if the cost still falls there, the fit is
that end (no finite optimum within the range); and a refined fit far out whose
log-likelihood at the range's end is within ``z^2 / 2`` of its own has its interval opened to
that end. Either is said by :attr:`Hypothesis.bound`.

**Intervals.** From the same weighted likelihood: a bias ``value +- z sd`` (a positive
parameter or a gain: the same in the log of the value or of ``1 + g``, mapped back)
with ``sd^2 = 1 / sum_c (N_eff,c / N_c) / (1 + N_c / N_base,c) sum_t (dr_c/dvalue)^2 /
sigma_c^2``: the Gauss-Newton variance inflated by the effective-sample-size factor, as
:mod:`graybox.parameter_estimation`, and by ``1 + N_c / N_base,c`` for the baseline's own
estimate of the level it is compared with (its samples ``N_base`` taken as equally
autocorrelated: the level tier records no more). The baseline's explanation
``level + slopes . (z - centre)`` is read once, at the baseline white box's features of the
window, and held fixed under every hypothesis: a hypothesis changes the prediction, not the
operating condition, and re-reading the slopes at a changed prediction carried the slopes'
own estimation noise into the estimate (measured: a friction change's estimate 3.5 sd off).
A noise factor from the chi-square law of the variance
with ``N_eff`` degrees of freedom of its evidence (conservative: the variance's own effective
sample size is larger than the mean's); its score pays ``log N_eff`` of its evidence.

What a noise hypothesis measures is the innovations' spread, of which the sensor's noise is a
share: a sensor noise ``s`` times the baseline's gives ``1 + c (s^2 - 1)`` for the variance,
``c`` the sensor's share of the healthy innovations (1 where the sensor noise is all of the
one-step residual, less where process noise or another sensor's noise enters it). Two hypotheses that change the prediction alike (a
parameter and a gain through the same equilibrium; two parameters that only enter as a sum)
score alike: the list shows both, and the gap between the first two scores says how sure the
ranking is.

**Noise, or the plant.** A plant's fault moves the one-step innovations too: with a coarse
white box a changed heat capacity, a weaker fan or a lower flow leaves the one-step
prediction further off, and a noise hypothesis read on the whole spread of the innovations
explains that spread with a likelihood gain over thousands of samples that the physical
hypothesis, scored on the k-step errors, does not reach (the plant zoo's heat pump: "supply
noise level up" first on 13 of its 18 diagnosed nights). A sensor's extra noise cannot be
taken back by changing the plant: so the innovations are read again with the white box
changed by each refined parameter hypothesis (its estimate, from the noise hypothesis'
start), and the noise hypothesis is scored on the least spread left (its estimate and
interval stay those of the whole spread). Only a noise hypothesis' score can fall by it; a
parameter hypothesis is scored on its k-step errors as before (given the innovations' gain
too, parameters fitted the innovations' chance spread and took the first place from the gas
turbine's sensor biases and the tanks' meter gain: branch `spreadgain`, not kept). A
:func:`diagnose_window` without ``spreads_under`` scores on the whole spread.

**Several windows** (a candidate of several nights, ``[nightly] candidate_nights``). Their
evidence adds up: the same night twice gives every hypothesis twice its log-likelihood gain
(the score gap between two hypotheses doubles; the interval narrows by
``sqrt((1 + 2 n / N_base) / (2 (1 + n / N_base)))``, not ``sqrt(2)``: the baseline's level
is not estimated again). But a fault that began inside the span (the candidate of its onset
night holds a healthy night first) is not a constant over it: fitted as one, a bias came
back halved and a span that one night alone diagnoses read "no single cause". Each
hypothesis is therefore fitted from each window's first operating period on (the errors
before it keep their healthy values; a noise hypothesis reads the innovations from there
on) and kept at the start that explains most (``Hypothesis.since``: that window's first
sample, None for the first). The start is a choice among ``W`` windows: with a uniform prior
over them it costs ``log W`` of the likelihood, ``2 log W`` of every score (the ranking is
unchanged; a healthy span is not explained more easily). The interval's baseline term counts
the errors from the start on. Each operating period's k-step errors depend on that period
alone, so a hypothesis is screened from every start on one white-box run (from its first
start); only a refinement runs the nights from its own start on.

**Side by side.** The hypotheses are screened side by side, and the refined ones then
refined side by side (:mod:`graybox.diagnosis_runs`: each hypothesis' own fit in its own
thread, unchanged, the white-box runs they ask for at one time evaluated as one batch). For a
white box with hidden states the batch fits each period's initial hidden state for every
trial together, each exactly as alone: the diagnosis is the same, number for number, as one
fitted hypothesis by hypothesis, and costs less (the EV battery's alarmed night: 15.9 against
6.9 CPU s). Without hidden states each run is the trial's own, one after another.

**Thinning** (``thinning=M``, default 1: off). The errors may be predicted from every M-th
of the level tier's starting points only: every run costs about M times less, the
likelihood reads the thinned errors' effective samples, and an interval's baseline term
counts the window's errors at the level tier's spacing. It is a trade, not a free saving:
each k-step error carries its predicted sample's measurement noise, independent from start
to start, so a channel whose errors are not correlated over M starts loses that share of
its evidence (the zoo's traction drive at M = 2: half the CPU, its temperature's effective
samples down 18 %, the best scores down 14 %; docs/performance.md).

**Evidence.** The diagnosis also hands its caller, in memory, the window's ``r(t)`` per
channel and what the best three hypotheses leave of it
(:class:`graybox.diagnosis_evidence.DiagnosisEvidence`, for a plot; not part of its JSON).
"""
from __future__ import annotations

import functools
import threading
import time
from dataclasses import dataclass, field, replace
from typing import Callable, ClassVar, Mapping, Sequence

import numpy as np
import pandas as pd
from scipy import linalg, special
from threadpoolctl import threadpool_limits

from graybox.diagnosis_evidence import (EVIDENCE_HYPOTHESES, ChannelResidual,
                                       DiagnosisEvidence, HypothesisFit)
from graybox.diagnosis_runs import Runner, Trial, side_by_side
from graybox.effective_samples import effective_sample_size
from graybox.exceptions import GrayBoxError, InsufficientDataError, ModelSpecError
from graybox.innovation_spread import InnovationSpread, period_innovations, pooled_spreads
from graybox.integration import Integration
from graybox.level_tier import LevelTier, start_stride
from graybox.models.base import WhiteBoxModel
from graybox.parameter_estimation import (DIFF_STEP, INVALID_ERROR, ErrorSetup,
                                          float_parameters, operating_segments,
                                          positive_parameters, prediction_errors,
                                          with_parameters)
from graybox.signature import Signature
from graybox.start_uncertainty import start_covariance, start_slopes
from graybox.state_estimation import estimate_states, window_arrays
from graybox.telemetry.window import window_periods
from graybox.timestamps import utc

KINDS = ("parameter", "bias", "gain", "noise")
#: the white-box runs of one refined hypothesis, at most
MAX_EVALUATIONS = 50
#: hypotheses fitted in full after every one is screened by a Gauss-Newton step (the best
#: by the screened likelihood gain: as many as an alert lists); the others keep their
#: screened value, which far from the baseline can be a linear extrapolation
REFINED = 5
#: a screened hypothesis is refined only when its log-likelihood gain reaches this: one that
#: explains nothing along its slope at the baseline is not worth a full fit (a healthy window)
REFINE_GAIN = 1.0
#: ... nor when it explains less than this share of what the best screened hypothesis does
#: (a noise hypothesis' closed-form fit included): the ranking's head is not in question, and
#: the refinement of a hypothesis a hundred times weaker moved its own log-likelihood gain by
#: a few per cent at most (the EV battery's night: four rounds of runs for five hypotheses
#: each explaining under 0.2 % of its voltage noise's gain); it keeps its screened value
REFINE_SHARE = 0.01
#: the refinement's tolerances: the value to 1e-4 of itself, far inside any interval the
#: window's errors give (scipy's default 1e-8 cost a stiff white box 10-20 runs a hypothesis)
REFINE_XTOL, REFINE_FTOL = 1e-4, 1e-6
#: a screened value further than this from the baseline, in units of its scale (the
#: parameter's value, the channel's spread, 1 % of gain), is a start for the refinement only
#: when the white box run there explains more than the baseline does
SCREEN_REACH = 10.0
#: seconds a window's diagnosis may take by default: each hypothesis re-runs the white box
#: over the window, which for a costly model (a ProgPy pump, hidden states at 1 Hz) takes
#: minutes; past the budget the diagnosis fails with that reason, and the alert still stands
TIME_BUDGET = 10.0
#: a positive parameter's change, and a sensor's gain factor ``1 + g``, is searched in log
#: space within this factor of its baseline either way: a fit that ends there has no finite
#: optimum within it (the cost still falls outwards) and says so (:attr:`Hypothesis.bound`)
POSITIVE_RANGE = 1e3
#: the exponent of a log-space interval's ends is held within this (no overflow of exp)
_MAX_EXPONENT = 700.0


@dataclass(frozen=True)
class Hypothesis:
    """One fitted fault hypothesis.

    Attributes
    ----------
    hypothesis : str
        What it says, e.g. ``"parameter friction"``, ``"speed sensor bias"``.
    kind : str
        ``"parameter"``, ``"bias"``, ``"gain"`` or ``"noise"``.
    target : str
        The parameter's name, or the channel's (the model's output name).
    baseline : float
        The healthy value: the baseline's parameter; 0 for a bias or a gain; 1 for noise.
    estimate : float
        The value fitted on the window (a bias in the channel's units; a gain as a fraction,
        0.06 for +6 %; noise as the factor on the one-step innovations' spread).
    interval : tuple of (float, float)
        Its confidence interval (95 % unless asked otherwise); an end the window's errors
        do not bound at all (a value they carry no information on, fitted in the value, not
        its log) is infinite, and written to JSON as such.
    score : float
        ``2 * log_likelihood_gain - log(effective samples)``; positive: preferred to healthy.
    log_likelihood_gain : float
        The log-likelihood over the healthy baseline's (effective-sample scaled).
    since : str, optional
        When the change was fitted from: the first sample of the window it starts with (ISO
        8601), when the telemetry is of several windows (a candidate's nights) and the
        hypothesis explains it best from a later one on (the fault began inside the span);
        None: over all of it.
    bound : str, optional
        For a positive parameter or a gain (fitted in log space, within
        :data:`POSITIVE_RANGE` times or divided by the baseline, or ``1 + g``), ``"upper"``
        or ``"lower"`` when the data do not bound the value on that side within that range:
        the interval's end on that side is the range's end, and so is the estimate when the
        fit found no finite optimum within it (the cost still fell outwards). None: bounded
        on both sides.
    """

    omitted_when_none: ClassVar[frozenset[str]] = frozenset({"since", "bound"})
    non_finite_fields: ClassVar[frozenset[str]] = frozenset({"interval"})

    hypothesis: str
    kind: str
    target: str
    baseline: float
    estimate: float
    interval: tuple[float, float]
    score: float
    log_likelihood_gain: float
    since: str | None = None
    bound: str | None = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")
        if self.bound not in (None, "upper", "lower"):
            raise ValueError(f"bound must be 'upper', 'lower' or None, got {self.bound!r}")

    @property
    def change(self) -> float:
        """``estimate - baseline``."""
        return self.estimate - self.baseline

    def describe(self) -> str:
        """One line for a person, e.g. ``parameter friction 0.5 -> 0.59 (+18 %; interval
        0.57 to 0.61), score 412``."""
        low, high = self.interval
        relative = (f" ({self.change / self.baseline:+.0%}; interval {low:.4g} to {high:.4g})"
                    if self.baseline else f" (interval {low:.4g} to {high:.4g})")
        since = f" since {self.since}" if self.since else ""
        end = self.interval[1] if self.bound == "upper" else self.interval[0]
        bound = ("" if not self.bound else
                 f" (at the {self.bound} end of its search range: no finite optimum within "
                 f"x{POSITIVE_RANGE:g} of the baseline)" if self.estimate == end else
                 f" (not bounded {'above' if self.bound == 'upper' else 'below'} within "
                 f"x{POSITIVE_RANGE:g} of the baseline)")
        return (f"{self.hypothesis} {self.baseline:.4g} -> {self.estimate:.4g}{relative}{since}"
                f"{bound}, score {self.score:.3g}")


@dataclass(frozen=True)
class Diagnosis:
    """The ranked fault hypotheses of a window.

    Attributes
    ----------
    hypotheses : tuple of Hypothesis
        Best first (highest score).
    explained : bool
        Whether the best scores above ``min_score``; False reads "no single cause explains
        it" (the ranking is then kept, for inspection, not as an answer).
    min_score : float
    channels : tuple of str
    n_obs : int
        k-step errors of the window, all channels together.
    effective_samples : float
        Their effective number (the score's penalty is its log).
    evidence : DiagnosisEvidence or None
        The window's residual and the best hypotheses' fits, for a plot (None when the
        diagnosis was read back or built by hand). In memory only: not written with the
        record, not compared.
    """

    transient_fields: ClassVar[frozenset[str]] = frozenset({"evidence"})

    hypotheses: tuple[Hypothesis, ...]
    explained: bool
    min_score: float
    channels: tuple[str, ...]
    n_obs: int
    effective_samples: float
    evidence: DiagnosisEvidence | None = field(default=None, compare=False, repr=False)

    @property
    def best(self) -> Hypothesis | None:
        """The first hypothesis when it explains the window, else None."""
        return self.hypotheses[0] if self.explained and self.hypotheses else None

    def summary(self) -> str:
        """The best hypothesis described, or "no single cause explains it"."""
        return self.best.describe() if self.best else "no single cause explains it"


def candidate_hypotheses(model: WhiteBoxModel) -> tuple[tuple[str, str], ...]:
    """``(kind, target)`` of every hypothesis of ``model``: a parameter hypothesis for each of
    its class attribute ``diagnosable`` (default: every number parameter), then a bias, a gain
    and a noise hypothesis for each output channel.

    Raises
    ------
    ModelSpecError
        If ``diagnosable`` names something that is not a number parameter.
    """
    numbers = float_parameters(model)
    names = tuple(getattr(model, "diagnosable", None) or numbers)
    wrong = [n for n in names if n not in numbers]
    if wrong:
        raise ModelSpecError(f"{model.spec()}.diagnosable names {wrong}, which are not number "
                             f"parameters: {', '.join(numbers)}")
    sensors = tuple((kind, channel) for channel in model.outputs
                    for kind in ("bias", "gain", "noise"))
    return tuple(("parameter", n) for n in names) + sensors


@dataclass
class _Fit:
    """A hypothesis fitted with the first weights: its value and, per channel, what the
    score and the interval need."""

    kind: str
    target: str
    baseline: float
    scale: float
    value: float
    residuals: list[np.ndarray]
    sensitivity: np.ndarray       # per channel, sum of (dr/dvalue)^2 / sigma^2
    channel: int | None = None    # the channel a noise hypothesis scales
    evidence_samples: float | None = None   # a noise hypothesis read on the innovations: theirs
    start: int = 0                # the first operating period the change is fitted on
    log: bool = False             # the free value is a log: of the parameter, of 1 + g
    bound: str | None = None      # "upper"/"lower": the value is its search range's end
    #: per channel, sum of (dr/dvalue) (dr/dstart) / sigma^2 over each period's hidden
    #: starts (:mod:`graybox.start_uncertainty`); None without hidden states
    start_cross: np.ndarray | None = None


def diagnose(baseline: Signature, windows: Sequence, model: WhiteBoxModel | None = None, *,
             hypotheses: Sequence[tuple[str, str]] | None = None, level: float = 0.95,
             min_score: float = 0.0, time_budget: float | None = TIME_BUDGET,
             thinning: int = 1) -> Diagnosis:
    """Fit, score and rank the fault hypotheses of a window against its healthy baseline.

    Parameters
    ----------
    baseline : Signature
        The healthy baseline; its level tiers (every channel needs one), sample and analysis
        intervals and integrator are used.
    windows : sequence
        The alarmed window(s): TelemetryWindow, DataFrame, or sequence of DataFrames (the
        operating periods of one window).
    model : WhiteBoxModel, optional
        The baseline's white box (default ``baseline.model.load()``); its parameters, with a
        tuned baseline's estimates (``baseline.tuning``) over them, are the hypotheses'
        baseline values.
    hypotheses : sequence of (kind, target), optional
        Default :func:`candidate_hypotheses` of the model.
    level : float, default 0.95
        Of the intervals.
    min_score : float, default 0
        The best hypothesis must score above it to explain the window.
    time_budget : float or None, default :data:`TIME_BUDGET`
        Seconds the diagnosis may take; None: no limit.
    thinning : int, default 1
        Predict from every ``thinning``-th of the level tier's starting points only (see
        :func:`diagnose_window`): each white-box run costs about that many times less, at
        the price of the information the skipped starts carried.

    Returns
    -------
    Diagnosis

    Raises
    ------
    InsufficientDataError
        If the baseline has no level tier, or no segment is longer than its horizon.
    GrayBoxError
        If the hypotheses are not all fitted within ``time_budget`` (the message says how
        many were).
    """
    model = model or baseline.model.load()
    if baseline.tuning is not None:
        model = with_parameters(model, baseline.tuning.parameters())
    levels = {c: baseline.channel(c).level for c in model.outputs}
    if any(tier is None for tier in levels.values()):
        raise InsufficientDataError("the baseline has no level tier (stored before it existed): "
                                    "refit the baseline to diagnose its alerts")
    analysis = baseline.analysis_step
    horizon = next(iter(levels.values())).horizon
    setup = ErrorSetup(baseline.sample_interval, max(1, round(analysis / baseline.sample_interval)),
                       horizon, start_stride(analysis, horizon), baseline.integration_used)
    frames, interval = operating_segments(windows)
    # the periods' states under the baseline's white box, estimated once for the innovations
    # and the k-step errors (with hidden states: each period's start fitted, then run)
    states = ([estimate_states(model, *window_arrays(model, frame), interval,
                               baseline.integration_used) for frame in frames]
              if model.hidden_states and interval == baseline.sample_interval else None)
    # the innovations from each window on: a noise change may begin with any of them (each
    # period's residual computed once)
    innovations = period_innovations(baseline, model, frames, interval, states)
    spreads = {start: pooled_spreads(baseline, innovations, start)
               for start in _window_starts(windows)}

    def spreads_under(trial: WhiteBoxModel) -> Callable[[int], dict[str, InnovationSpread]]:
        innovations = period_innovations(baseline, trial, frames, interval)   # one run
        return functools.partial(pooled_spreads, baseline, innovations)

    return diagnose_window(model, levels, windows, setup, hypotheses=hypotheses, level=level,
                           min_score=min_score, time_budget=time_budget,
                           spreads=spreads.get(0), spreads_from=spreads, states=states,
                           thinning=thinning, spreads_under=spreads_under)


def diagnose_window(model: WhiteBoxModel, levels: Mapping[str, LevelTier], windows: Sequence,
                    setup: ErrorSetup | None = None, *,
                    hypotheses: Sequence[tuple[str, str]] | None = None, level: float = 0.95,
                    min_score: float = 0.0, time_budget: float | None = TIME_BUDGET,
                    spreads: Mapping[str, InnovationSpread] | None = None,
                    spreads_from: Mapping[int, Mapping[str, InnovationSpread]] | None = None,
                    states: Sequence | None = None, thinning: int = 1,
                    spreads_under: Callable[[WhiteBoxModel], Callable[
                        [int], Mapping[str, InnovationSpread]]] | None = None
                    ) -> Diagnosis:
    """:func:`diagnose` from its parts: the white box, each channel's baseline level tier and
    how the errors are computed (default: the level tier's at the telemetry's rate with
    RK4, the horizon the level tiers'), without a signature.

    ``spreads``: each channel's one-step innovation spread
    (:func:`graybox.innovation_spread.innovation_spreads`) over all the telemetry, what its
    noise hypothesis is read on; a channel without one reads it on its k-step errors'
    spread. ``spreads_from``: the same over the operating periods from a window's first on,
    by that period's index among them (``spreads`` is the one of index 0): a noise change
    beginning with a later window is read there; a window without one is not a start of
    the noise hypothesis. ``states``: each operating period's full states under ``model``
    at the telemetry rate with ``setup``'s integration, when already estimated
    (:func:`graybox.state_estimation.estimate_states`): the baseline's k-step errors read
    them instead of estimating them again.

    ``thinning``: the k-step errors are predicted from every ``thinning``-th of ``setup``'s
    starting points only (its ``stride`` times ``thinning``), a regular subsample: every run
    of every hypothesis costs about ``thinning`` times less. The likelihood's effective
    samples are those of the thinned errors (so a channel whose errors were correlated over
    more than ``thinning`` starts loses little, one whose errors were nearly independent
    loses the skipped starts' information: its intervals widen, honestly), and the
    baseline's share of an interval counts the errors at the level tier's own spacing
    (``thinning`` times the thinned count: the baseline level was estimated at that
    spacing).

    ``spreads_under``: with a changed white box, each channel's innovation spread over the
    periods from a start on, ``spreads_under(model)(start)`` (the white box run once per
    model); with it, a noise hypothesis
    read on the innovations is scored on the spread left once the refined parameter
    hypotheses have taken back what they can (the module's "Noise, or the plant"). Without
    it a noise hypothesis is scored on the whole spread."""
    if int(thinning) != thinning or thinning < 1:
        raise ValueError(f"thinning must be a whole number of at least 1, got {thinning!r}")
    clock = _Deadline(time_budget)
    hypotheses = tuple(hypotheses or candidate_hypotheses(model))
    # many small vector products: BLAS threads spin-waiting cost more than they give (as in
    # graybox.signature_fit.fit_signatures)
    with threadpool_limits(limits=1):
        try:
            by_start = {**(spreads_from or {}), **({0: spreads} if spreads else {})}
            return _diagnose_window(model, levels, windows, setup, hypotheses, level,
                                    min_score, clock, by_start, states, int(thinning),
                                    spreads_under)
        except _OutOfTime:
            raise GrayBoxError(f"the diagnosis stopped at its time budget of {time_budget:g} s "
                               f"after {clock.fitted} of {len(hypotheses)} hypotheses (a "
                               f"costly white box: each hypothesis re-runs it over the "
                               f"window)") from None


class _OutOfTime(Exception):
    """Raised inside a fit when the diagnosis' time budget is spent; not a GrayBoxError, which
    a hypothesis' fit reads as an invalid trial."""


class _Deadline:
    def __init__(self, budget: float | None):
        self.end = None if budget is None else time.monotonic() + budget
        self.fitted = 0
        self._lock = threading.Lock()     # hypotheses are fitted side by side, in threads

    def check(self) -> None:
        if self.end is not None and time.monotonic() > self.end:
            raise _OutOfTime

    def count(self) -> None:
        """One more hypothesis fitted."""
        with self._lock:
            self.fitted += 1


def _diagnose_window(model, levels, windows, setup, hypotheses, level, min_score,
                     clock: _Deadline,
                     spreads: Mapping[int, Mapping[str, InnovationSpread]],
                     states: Sequence | None = None, thinning: int = 1,
                     spreads_under=None) -> Diagnosis:
    frames, interval = operating_segments(windows)
    if setup is None:
        setup = ErrorSetup.default(interval, horizon=next(iter(levels.values())).horizon,
                                   integration=Integration())
    if thinning > 1:
        setup = replace(setup, stride=setup.stride * thinning)
    segments = [window_arrays(model, frame) for frame in frames]
    channels = model.outputs
    sigma = np.array([max(levels[c].residual_std, 1e-12) for c in channels])

    if model.hidden_states and states is None:
        # estimated once, for the errors and their slopes in the starts (_start_uncertainty)
        states = [estimate_states(model, y, u, setup.sample_interval, setup.integration)
                  for y, u in segments]
    # the baseline's explanation at the window's operating condition, read once at the
    # baseline white box's features: a hypothesis changes the prediction, not the condition
    data = prediction_errors(model, segments, setup,
                             {c: levels[c].drifting or () for c in channels}, states=states)
    explanation = [levels[c].level + (data[c][1] - np.asarray(levels[c].center))
                   @ np.asarray(levels[c].slopes) for c in channels]
    positions = data[channels[0]][2]
    # where a change may begin: the first period of each window with k-step errors, and
    # each one's first error (the errors are in period order)
    starts = [s for s in _window_starts(windows) if np.any(positions >= s)] or [0]
    offsets = {s: int(np.searchsorted(positions, s)) for s in starts}

    def remaining(trial: WhiteBoxModel, trial_segments, start: int, value: float,
                  shared: _ScreenRun, runner: Runner) -> tuple[list[np.ndarray], np.ndarray]:
        """The residual with ``trial`` (at free value ``value``) run on the periods from
        ``start`` on (given as ``trial_segments``), the healthy errors before them.

        Each period's errors depend on that period alone (a prediction never crosses two;
        hidden states are estimated per period), so a run from an earlier start holds the
        errors of a later one: ``shared`` keeps the hypothesis' first run while it is
        screened (its screening step from its first start), and the same value from a
        later start is read from it instead of run again. ``runner``: where the
        hypothesis' runs go (alone, or batched with the other hypotheses' while they are
        fitted side by side: :mod:`graybox.diagnosis_runs`)."""
        clock.check()
        if shared.errors is not None and shared.value == value and shared.start <= start:
            errors = {c: (e[p >= start - shared.start],) for c, (e, p) in shared.errors.items()}
        else:
            errors = runner.run(Trial(trial, trial_segments, start))
            if shared.screening and shared.errors is None:
                shared.start, shared.value = start, value
                shared.errors = {c: (e, p) for c, (e, _, p) in errors.items()}
        offset = offsets[start]
        out = []
        for c, known in zip(channels, explanation):
            joined = np.concatenate([data[c][0][:offset], errors[c][0]])
            if len(joined) != len(known):
                raise GrayBoxError("a hypothesis' errors do not line up with the window's")
            out.append(joined - known)
        return out, positions

    healthy = [data[c][0] - known for c, known in zip(channels, explanation)]
    finite = [np.isfinite(r) for r in healthy]
    counts = np.array([int(f.sum()) for f in finite])
    if counts.min() < 3:
        raise InsufficientDataError("too few finite k-step errors to diagnose the window")
    healthy = [r[f] for r, f in zip(healthy, finite)]
    pieces = [positions[f] for f in finite]
    # the finite errors from each start on, per channel, at the level tier's spacing (the
    # baseline's level is compared with as many errors as the window had unthinned)
    later = {s: thinning * np.array([int(f[offsets[s]:].sum()) for f in finite])
             for s in starts}

    def n_eff(residuals: list[np.ndarray]) -> np.ndarray:
        return np.array([effective_sample_size([(r - r.mean())[p == s] for s in np.unique(p)])
                         for r, p in zip(residuals, pieces)])

    weights = n_eff(healthy) / counts
    slopes = covariance = None
    if model.hidden_states:
        slopes, covariance = _start_uncertainty(model, segments, setup, channels, levels,
                                                data, states, finite)
    rows = _Rows(np.concatenate([np.full(n, np.sqrt(w) / s)
                                 for n, w, s in zip(counts, weights, sigma)]),
                 np.cumsum([0, *counts]), sigma, slopes, covariance)
    healthy_weighted = np.concatenate(healthy) * rows.weights
    # every hypothesis screened from every start (one white-box run for all of them: a later
    # start reads its periods' errors from the first start's run), at the start that explains
    # most; the best REFINED fitted in full
    # (the hypotheses are screened side by side, then the refined ones refined side by side,
    # their white-box runs batched: :mod:`graybox.diagnosis_runs`; each sees the values it
    # would see alone)
    fits: list = [None] * len(hypotheses)
    together = bool(model.hidden_states)
    runners = {index: Runner(setup) for index, (kind, _) in enumerate(hypotheses)
               if kind != "noise"}

    def screen(kind: str, target: str, runner: Runner) -> tuple[_Objective, _Fit]:
        screened, shared = [], _ScreenRun()
        for start in starts:
            objective = _objective(kind, target, model, segments, start, offsets[start],
                                   functools.partial(remaining, start=start, shared=shared,
                                                     runner=runner),
                                   finite, rows)
            screened.append((objective, _screen(objective, healthy_weighted)))
        shared.screening, shared.errors = False, None   # the refinement runs its own
        clock.count()
        return max(screened, key=lambda pair: _gain(pair[1], healthy, sigma, weights))

    tasks = [(runners[index], functools.partial(screen, *hypotheses[index], runners[index]))
             for index in runners]
    objectives = {}
    for index, (objective, fit) in zip(runners, side_by_side(tasks, setup, together)):
        objectives[index], fits[index] = objective, fit
    for index, (kind, target) in enumerate(hypotheses):
        if kind == "noise":
            # on the innovations from each start on; without them, the k-step errors' spread
            options = [_noise_fit(target, model, sigma, healthy, spreads[start][target], start)
                       for start in starts if target in spreads.get(start, {})] or [
                _noise_fit(target, model, sigma, healthy, None, starts[0])]
            fits[index] = max(options, key=lambda fit: _gain(fit, healthy, sigma, weights))
            clock.count()
    first_gains = [_gain(fit, healthy, sigma, weights) for fit in fits]
    chosen = []
    # (a hypothesis far weaker than the best is not refined either: REFINE_SHARE)
    least = max(REFINE_GAIN, REFINE_SHARE * max(first_gains, default=0.0))
    for index in sorted(objectives, key=lambda i: -first_gains[i])[:REFINED]:
        if first_gains[index] < least:
            break           # explains nothing at the baseline's slope: a healthy-like window
        chosen.append(index)

    def refine(index: int) -> _Fit | None:
        try:
            return _refine(objectives[index], fits[index])
        except _OutOfTime:
            return None     # the screened value stands: the ranking is complete

    refined = set()
    tasks = [(runners[index], functools.partial(refine, index)) for index in chosen]
    for index, fit in zip(chosen, side_by_side(tasks, setup, together)):
        if fit is not None:
            fits[index] = fit
            refined.add(index)
            first_gains[index] = _gain(fit, healthy, sigma, weights)
    # a noise hypothesis is scored on the spread that no refined parameter hypothesis takes
    # back: a plant's fault moves the one-step innovations too, a sensor's noise stays
    left = ({} if spreads_under is None else
            _spread_left(fits, [fits[i] for i in sorted(refined)
                                if fits[i].kind == "parameter"], model, spreads_under, clock))
    # the second weights: the autocorrelation of what the best explanation leaves
    best = fits[int(np.argmax(first_gains))] if fits else None
    effective = n_eff(best.residuals if best is not None else healthy)
    weights = effective / counts
    # BIC's penalty, and the start's: a uniform prior over the windows a change may begin
    # with costs log(starts) of the likelihood (none for one window)
    choice = float(2 * np.log(len(starts)))
    penalty = float(np.log(max(effective.sum(), 1.0))) + choice
    z = float(special.ndtri(0.5 + level / 2))                     # scipy.stats.norm.ppf
    # the baseline's level is an estimate too: the errors a hypothesis is fitted on (those
    # from its start), compared with a baseline of as many samples (and the same
    # autocorrelation), have twice the variance
    base_counts = np.array([max(levels[c].n_obs, 1) for c in channels])
    results = []
    for index, fit in enumerate(fits):
        gain = (_gain(fit, healthy, sigma, weights) if index not in left
                else _noise_gain(left[index], fit.evidence_samples))
        # BIC on the hypothesis' own evidence: a noise hypothesis read on the innovations
        # pays for its free value in their effective samples
        own_penalty = (penalty if fit.evidence_samples is None
                       else float(np.log(max(fit.evidence_samples, 1.0))) + choice)
        compared = weights / (1.0 + later[fit.start] / base_counts)
        interval, bound = _interval(fit, compared, effective, z, level,
                                    rows.start_covariance), fit.bound
        if fit.log:
            interval, bound = _open_end(objectives[index], fit, interval, compared, z,
                                        index in refined)
        results.append(Hypothesis(_name(fit.kind, fit.target), fit.kind, fit.target,
                                  fit.baseline, _value(fit), interval,
                                  float(2 * gain - own_penalty), float(gain),
                                  None if fit.start == starts[0]
                                  else _since(frames, fit.start), bound))
    ranked = sorted(zip(results, fits), key=lambda pair: -pair[0].score)
    results = [hypothesis for hypothesis, _ in ranked]
    explained = bool(results and results[0].score > min_score)
    times = _prediction_times(frames, setup, positions)
    evidence = DiagnosisEvidence(
        tuple(ChannelResidual(c, times[f], r, float(s))
              for c, f, r, s in zip(channels, finite, healthy, sigma)),
        tuple(HypothesisFit(hypothesis, tuple(fit.residuals))
              for hypothesis, fit in ranked[:EVIDENCE_HYPOTHESES]))
    return Diagnosis(tuple(results), explained, float(min_score), tuple(channels),
                     int(counts.sum()), float(effective.sum()), evidence)


def _open_end(objective: _Objective, fit: _Fit, interval: tuple[float, float], weights,
              z: float, refined: bool) -> tuple[tuple[float, float], str | None]:
    """A log-space hypothesis' interval, and its ``bound``, with the side the data do not
    bound opened to the search range's end.

    At the range's end (the fit found no finite optimum within it) the interval's outward
    end is the range's. A refined fit further than its ``reach`` from the baseline (the
    tanks' pump lag at 240 times its baseline on a meter-gain night) may lie in a valley
    that flattens out towards the range's end, where the Gauss-Newton interval, read on the
    curvature at the fit, closes too soon: one white-box run at the range's end in the
    fit's direction, and if the log-likelihood lost there (``weights`` as the interval's)
    is under ``z^2 / 2`` (the likelihood-ratio test at the interval's level), the data do
    not bound the value on that side: the interval's end is the range's, and ``bound``
    says which side."""
    low, high = objective.bounds
    side = fit.bound
    if side is None and refined and abs(fit.value) > objective.reach:
        direction = "upper" if fit.value > 0 else "lower"
        try:
            at_end = objective.at(high if direction == "upper" else low) / objective.rows.weights
        except _OutOfTime:
            return interval, None
        edges, sigma = objective.rows.edges, objective.rows.sigma
        lost = sum(w * (np.sum(at_end[a:b] ** 2) - np.sum(r ** 2)) / (2 * s ** 2)
                   for a, b, r, s, w in zip(edges[:-1], edges[1:], fit.residuals, sigma,
                                            weights))
        if np.isfinite(lost) and lost < z ** 2 / 2:
            side = direction
    if side == "upper":
        return (interval[0], objective.value(high)), side
    if side == "lower":
        return (objective.value(low), interval[1]), side
    return interval, None


def _start_uncertainty(model, segments, setup: ErrorSetup, channels, levels, data, states,
                       finite) -> tuple[np.ndarray, np.ndarray]:
    """The k-step errors' slopes in each period's hidden start, rows as the window's finite
    errors (N, periods x hidden), and the starts' block-diagonal covariance, both at the
    baseline's white box (:mod:`graybox.start_uncertainty`)."""
    drift = {c: levels[c].drifting or () for c in channels}
    by_channel = start_slopes(model, segments, setup, drift, states, data)
    slopes = np.concatenate([by_channel[c][f] for c, f in zip(channels, finite)])
    spread = {c: levels[c].residual_std for c in channels}
    covariance = linalg.block_diag(*[
        start_covariance(model, y, u, setup.sample_interval, setup.integration,
                         np.array([window.initial_hidden[h] for h in model.hidden_states]),
                         spread)
        for (y, u), window in zip(segments, states)])
    return slopes, covariance


def _window_starts(windows) -> list[int]:
    """The index, among the operating periods of ``windows`` (as
    :func:`~graybox.parameter_estimation.operating_segments` lists them), of each window's
    first period; windows without one left out."""
    starts, first = [], 0
    for window in windows:
        count = len(window_periods(window))
        if count:
            starts.append(first)
        first += count
    return starts


def _since(frames, start: int) -> str:
    """The first sample of the operating periods from ``start`` on."""
    first = frames[start].index[0]
    return utc(first).isoformat() if isinstance(first, pd.Timestamp) else str(first)


def _prediction_times(frames, setup: ErrorSetup, positions: np.ndarray) -> np.ndarray:
    """When each k-step error's predicted sample was measured, as
    :func:`graybox.level_tier.level_data` takes them: every ``factor``-th sample of each
    segment long enough, from the ``horizon``-th, one every ``stride``."""
    pieces = []
    for position in np.unique(positions):
        index = frames[position].index[::setup.factor][setup.horizon::setup.stride]
        if isinstance(index, pd.DatetimeIndex):
            index = utc(index).tz_localize(None)
        pieces.append(np.asarray(index))
    return np.concatenate(pieces)


def _name(kind: str, target: str) -> str:
    return {"parameter": f"parameter {target}", "bias": f"{target} sensor bias",
            "gain": f"{target} sensor gain", "noise": f"{target} noise level"}[kind]


def _physical(kind: str, log: bool, baseline: float, scale: float, x: float) -> float:
    """The hypothesis' value (the parameter, ``b``, ``g``) at its free value ``x``: ``baseline
    + scale x``, or in log space ``baseline exp(scale x)`` for a parameter and ``exp(scale x)
    - 1`` for a gain (a noise hypothesis' free value is its factor)."""
    if kind == "noise":
        return float(x)
    if not log:
        return float(baseline + scale * x)
    exponent = float(np.clip(scale * x, -_MAX_EXPONENT, _MAX_EXPONENT))
    return float(np.expm1(exponent)) if kind == "gain" else float(baseline * np.exp(exponent))


def _transform(kind: str, target: str, model: WhiteBoxModel, segments,
               value: Callable[[float], float]) -> Callable[[float], tuple[WhiteBoxModel, list]]:
    """The changed white box and telemetry for a free value ``x`` (``value(x)``: the
    parameter, the bias ``b`` or the gain ``g``)."""
    if kind == "parameter":
        return lambda x: (with_parameters(model, {target: value(x)}), segments)
    column = model.outputs.index(target)

    def corrected(x: float):
        out = []
        for y, u in segments:
            y = y.copy()
            y[:, column] = (y[:, column] - value(x) if kind == "bias"
                            else y[:, column] / (1.0 + value(x)))
            out.append((y, u))
        return model, out
    return corrected


def _noise_fit(target, model, sigma, healthy, innovations: InnovationSpread | None,
               start: int = 0) -> _Fit:
    """A noise hypothesis in closed form: on the innovations when given (those of the periods
    from ``start`` on), else on the k-step errors' spread (all of them)."""
    channel = model.outputs.index(target)
    if innovations is not None:
        return _Fit("noise", target, 1.0, 1.0, float(np.sqrt(innovations.ratio)), healthy,
                    np.zeros(0), channel, innovations.effective_samples, start)
    spread = float(np.sqrt(np.mean(healthy[channel] ** 2)) / sigma[channel])
    return _Fit("noise", target, 1.0, 1.0, spread, healthy, np.zeros(0), channel)


@dataclass
class _ScreenRun:
    """A hypothesis' first screening run (from its first start), while it is screened from
    the later ones: each k-step error with the position of its period, per channel."""

    screening: bool = True
    start: int = 0
    value: float = 0.0
    errors: dict | None = None


@dataclass(frozen=True)
class _Rows:
    """The window's k-step errors as one weighted vector, shared by every hypothesis: each
    row's weight ``sqrt(N_eff / N) / sigma`` of its channel, and where each channel's rows
    start and end."""

    weights: np.ndarray
    edges: np.ndarray
    sigma: np.ndarray
    #: with hidden states: the errors' slopes in each period's start (N, periods x hidden)
    #: and the starts' covariance (:mod:`graybox.start_uncertainty`)
    start_slopes: np.ndarray | None = None
    start_covariance: np.ndarray | None = None


@dataclass
class _Objective:
    """A parameter, bias or gain hypothesis' weighted errors as a function of its free value
    ``x`` (in units of ``scale``: the baseline value, the channel's spread or 1 %; with
    ``log``, of the log of a positive parameter, scale 1, or of ``1 + g``, scale 0.01)."""

    kind: str
    target: str
    baseline: float
    scale: float
    weighted: Callable[[float], np.ndarray]
    bounds: tuple[float, float]
    rows: _Rows
    start: int = 0                # the first operating period the change applies to
    log: bool = False
    #: a screened value further than this from the baseline is a start only when its run
    #: explains more than the baseline (:func:`_refine`)
    reach: float = SCREEN_REACH
    #: the weighted errors at every value evaluated (one white-box run each), by value
    evaluated: dict = field(default_factory=dict)

    def value(self, x: float) -> float:
        """The parameter, bias or gain at free value ``x``."""
        return _physical(self.kind, self.log, self.baseline, self.scale, x)

    def at(self, x: float) -> np.ndarray:
        """The weighted errors at ``x``, each value run once."""
        key = float(x)
        if key not in self.evaluated:
            self.evaluated[key] = self.weighted(key)
        return self.evaluated[key]

    def slope(self, x: float) -> np.ndarray:
        """The errors' slope at ``x``, shape (N,), for the refinement: the secant to the
        nearest value run before (a one-dimensional Broyden update: one run an iteration
        instead of two), a finite difference of :data:`DIFF_STEP` when none lies further
        than that (a secant over a shorter span would read the inner fits' tolerance)."""
        key = float(x)
        fun = self.at(key)
        step = DIFF_STEP * max(1.0, abs(key))
        others = [v for v in self.evaluated if abs(v - key) >= step]
        other = min(others, key=lambda v: abs(v - key)) if others else key + step
        return (fun - self.at(other)) / (key - other)

    def newton(self, x: float) -> tuple[float, float, bool]:
        """The cost ``|errors|^2 / 2``'s derivative and curvature at ``x``, and whether the
        curvature is Newton's, from the values run before.

        The errors' quadratic through ``x`` and its two nearest values (``a``, then ``b`` at
        least a tenth of ``|x - a|`` from ``a``, so that the second difference does not read
        the runs' own noise, and at most ten times as far from ``x`` as ``a``, so that it
        does not read a value far out: one where the white box failed bends the quadratic by
        its failure) has the slope ``J`` and second derivative ``F`` at ``x``; Newton's
        curvature is ``J.J + e.F`` (0 or less where the cost bends down). Where fewer values
        lie so, the Gauss-Newton ``J.J`` on the secant (:meth:`slope`), as at the screened
        value, whose neighbours are the baseline and its finite difference. Gauss-Newton
        ignores how the errors bend: where the white box' errors bend towards the data (a
        tanks' pump lag, a crane's rope length) each of its steps went about half the
        remaining way, 6-8 runs a hypothesis.
        """
        fun = self.at(x)
        secant = self.slope(x)
        gradient, curvature = float(secant @ fun), float(secant @ secant)
        step = DIFF_STEP * max(1.0, abs(x))
        near = sorted((v for v in self.evaluated if abs(v - x) >= step),
                      key=lambda v: abs(v - x))
        if not near:
            return gradient, curvature, False
        a = near[0]
        b = next((v for v in near[1:] if abs(v - a) >= max(step, 0.1 * abs(x - a))), None)
        if b is None or abs(b - x) > 10.0 * abs(a - x):
            return gradient, curvature, False
        over_a = (fun - self.at(a)) / (x - a)
        bend = (over_a - (fun - self.at(b)) / (x - b)) / (a - b)    # F / 2
        slope = over_a + bend * (x - a)
        newton = float(slope @ slope) + 2.0 * float(fun @ bend)
        if not np.isfinite(newton):
            return gradient, curvature, False
        return float(slope @ fun), newton, True

    def record(self, x: float, fun: np.ndarray, slope: np.ndarray) -> _Fit:
        """The fit at ``x`` from its weighted errors and their weighted slope in ``x``."""
        raw = fun / self.rows.weights
        slope = slope / self.rows.weights
        spans = list(zip(self.rows.edges[:-1], self.rows.edges[1:]))
        # per channel, sum of (dr/dx)^2 / sigma^2: the Gauss-Newton information without weights
        sensitivity = np.array([np.sum((slope[a:b] / s) ** 2)
                                for (a, b), s in zip(spans, self.rows.sigma)])
        cross = (None if self.rows.start_slopes is None else
                 np.array([(slope[a:b] / s ** 2) @ self.rows.start_slopes[a:b]
                           for (a, b), s in zip(spans, self.rows.sigma)]))
        low, high = self.bounds
        bound = "upper" if x >= high else "lower" if x <= low else None
        return _Fit(self.kind, self.target, self.baseline, self.scale, float(x),
                    [raw[a:b] for a, b in spans], sensitivity, start=self.start, log=self.log,
                    bound=bound, start_cross=cross)


def _objective(kind, target, model, segments, start, offset, remaining, finite,
               rows: _Rows) -> _Objective:
    """The hypothesis changing the white box or the telemetry from the operating period
    ``start`` on, whose first error is the ``offset``-th; ``remaining(trial,
    trial_segments, value=x)`` runs the trial (at free value ``x``) on those periods."""
    if kind not in KINDS:
        raise ValueError(f"hypothesis kind must be one of {KINDS}, got {kind!r}")
    if kind == "parameter":
        baseline = float(model.parameters[target])
        # positive by nature (the model's declaration): changed by a factor, in log space
        log = baseline > 0 and target in positive_parameters(model)
        scale = 1.0 if log else abs(baseline) if baseline else 1.0
    else:
        baseline = 0.0
        log = kind == "gain"             # the sensor's factor 1 + g > 0
        scale = float(rows.sigma[model.outputs.index(target)]) if kind == "bias" else 0.01
    value = functools.partial(_physical, kind, log, baseline, scale)
    transform = _transform(kind, target, model, segments[start:], value)
    sigma = rows.sigma

    # a gain hypothesis' errors are compared in the units the baseline measured them in:
    # the corrected channel's error y / (1 + g) - yhat times 1 + g is y - (1 + g) yhat (in
    # the corrected units alone, dividing by 1 + g shrinks every error and any g > 0 pays);
    # only the errors from the start on were corrected (the earlier ones are not scaled:
    # scaled, a gain below 0 shrank a healthy first night and "explained" it)
    gained = model.outputs.index(target) if kind == "gain" else None
    later = np.arange(len(finite[0])) >= offset

    def weighted(x: float) -> np.ndarray:
        try:
            residuals, _ = remaining(*transform(x), value=x)
            units = [np.where(later, 1.0 + value(x), 1.0) if c == gained
                     else np.ones(len(later)) for c in range(len(residuals))]
            parts = [u[f] * np.nan_to_num(r[f], nan=INVALID_ERROR * s, posinf=INVALID_ERROR * s,
                                          neginf=-INVALID_ERROR * s) for r, f, s, u in
                     zip(residuals, finite, sigma, units)]
        except (GrayBoxError, FloatingPointError):
            parts = [np.full(int(f.sum()), INVALID_ERROR * s) for f, s in zip(finite, sigma)]
        return np.concatenate(parts) * rows.weights

    span = float(np.log(POSITIVE_RANGE)) / scale
    bounds = (-span, span) if log else (-np.inf, np.inf)
    # a screened positive parameter is far out past a factor 1 + SCREEN_REACH either way
    reach = float(np.log1p(SCREEN_REACH)) if log and kind == "parameter" else SCREEN_REACH
    return _Objective(kind, target, baseline, scale, weighted, bounds, rows, start=start,
                      log=log, reach=reach)


def _screen(objective: _Objective, healthy_weighted: np.ndarray) -> _Fit:
    """One Gauss-Newton step from the baseline: the errors' slope from one finite difference
    (the errors at the baseline are the healthy ones, shared by every hypothesis), the free
    value that minimises the linearised errors, and those errors."""
    step = DIFF_STEP
    objective.evaluated[0.0] = healthy_weighted
    slope = (objective.at(step) - healthy_weighted) / step
    information = float(slope @ slope)
    x = -float(slope @ healthy_weighted) / information if information > 0 else 0.0
    if not objective.log:
        x = float(np.clip(x, *objective.bounds))
        return objective.record(x, healthy_weighted + slope * x, slope)
    # in log space the step is still taken in the value (the errors' slope at the baseline is
    # the same in the value, in units of its scale, and in its log), where a bias-like change
    # is linear: the refinement then starts at the linear minimum, and stops there on one run
    # (its secant to the baseline is along the same slope); a value the linear step takes to
    # zero or below is the range's lower end
    s = objective.scale
    low, high = objective.bounds
    logged = float(np.clip(np.log1p(s * x) / s if s * x > -1.0 else low, low, high))
    factor = float(np.exp(s * logged))            # the value over the baseline's
    return objective.record(logged, healthy_weighted + slope * (factor - 1.0) / s,
                            slope * factor)


def _refine(objective: _Objective, screened: _Fit) -> _Fit:
    """The least-squares fit of the free value (the errors need not be linear in it far from
    the baseline): a one-dimensional trust region of Newton steps on ``|errors|^2 / 2``
    (:meth:`_Objective.newton`: derivatives from the values already run, one run a step),
    from the screened value when it is within :data:`SCREEN_REACH` of the baseline or,
    further out, when its run explains more than the baseline (smaller weighted errors), else
    from the baseline (a step far out can land in another valley: a shaft's damping screened
    at -250 times its value was refined to a worse minimum). From the baseline, a trust
    region that starts at one scale walks out one doubling a run (1, 3, 7, 15, 31 scales): a
    tanks' level sensor bias screened at 44 of its spread took 6 runs to reach it.

    It stops, before running the step, when the step is within :data:`REFINE_XTOL` of the
    value (``|dx| <= xtol (xtol + |x|)``, the test of ``scipy.optimize.least_squares``, which
    ran that last step to find it small: a run a hypothesis) or, on Newton's curvature, when
    the cost the step promises to remove is within :data:`REFINE_FTOL` of the cost (not on
    the Gauss-Newton one, which ignores how the errors bend: it promised a crane's gain an
    eighth of what the step then removed); after a run that removed less than that; or after
    :data:`MAX_EVALUATIONS` runs. A step that does not lower the cost is not taken and
    halves the region. A screened value whose first step is within ``xtol`` (the errors
    linear in the value over the span from the baseline: a sensor bias, a small parameter
    change) is the fit on its one run.

    In log space (a positive parameter, a gain) a step may land on the search range's end
    (:data:`POSITIVE_RANGE`). Two steps in a row outwards, past the objective's ``reach``,
    the second at least half the first, are a walk along a cost that flattens out (the
    tanks' pump lag walked 19 runs, each 1.1-1.3 times further out): the range's end is run
    once and, if its cost is lower, one finite difference in from it; where the cost still
    falls outwards there the fit is the end (no finite optimum within the range), else the
    refinement goes on.
    """
    x = screened.value
    if x != 0.0 and abs(x) > objective.reach:
        fun, healthy = objective.at(x), objective.at(0.0)
        if not float(fun @ fun) < float(healthy @ healthy):
            x = 0.0
    fun = objective.at(x)
    cost = 0.5 * float(fun @ fun)
    low, high = objective.bounds
    radius = max(abs(x), 1.0)
    walked, tried_end = 0.0, False      # the last step taken; whether the range's end was
    for _ in range(MAX_EVALUATIONS):
        gradient, curvature, newton = objective.newton(x)
        if not (np.isfinite(gradient) and np.isfinite(curvature)) or gradient == 0.0:
            break
        # where the cost bends down (or barely up), to the region's edge
        step = (float(np.clip(-gradient / curvature, -radius, radius))
                if curvature * radius > abs(gradient) else -np.sign(gradient) * radius)
        # at most to the search range's end (a positive value's, in log space), onto it
        step = float(np.clip(step, low - x, high - x))
        new = high if step >= high - x else low if step <= low - x else x + step
        promised = -gradient * step - 0.5 * curvature * step ** 2
        if (abs(step) <= REFINE_XTOL * (REFINE_XTOL + abs(x))
                or (newton and promised <= REFINE_FTOL * cost)):
            break
        if (not tried_end and np.isfinite(high - low) and abs(x) > objective.reach
                and step * walked > 0 and step * x > 0 and abs(step) >= 0.5 * abs(walked)):
            # a walk: outwards past the reach, the steps not shrinking (a cost that flattens
            # towards the range's end; a Newton step in a tail e^-x is a constant). Is the
            # cost still falling at the range's end? Its run, and one a finite difference in
            # from it: if so, no finite optimum lies within the range, the fit is its end
            tried_end = True
            end = high if step > 0 else low
            at_end = objective.at(end)
            end_cost = 0.5 * float(at_end @ at_end)
            if end_cost < cost:
                # (two finite-difference steps in: the secant the fit's slope is read on)
                inner = objective.at(end - np.sign(end) * 2 * DIFF_STEP * max(1.0, abs(end)))
                if end_cost < 0.5 * float(inner @ inner):
                    x, fun, cost = end, at_end, end_cost
                    break
        trial = objective.at(new)
        trial_cost = 0.5 * float(trial @ trial)
        if not trial_cost < cost:
            radius = 0.5 * abs(step)
            continue
        x, fun, removed, cost, walked = new, trial, cost - trial_cost, trial_cost, step
        radius = max(radius, 2.0 * abs(step))
        if removed <= REFINE_FTOL * (cost + removed):
            break
    return objective.record(x, fun, objective.slope(x))


def _gain(fit: _Fit, healthy, sigma, weights) -> float:
    """The hypothesis' log-likelihood over the healthy one's, each channel's scaled by its
    weight ``N_eff / N``."""
    if fit.kind == "noise":
        n = (weights[fit.channel] * len(healthy[fit.channel]) if fit.evidence_samples is None
             else fit.evidence_samples)
        return _noise_gain(fit.value ** 2, n)
    return float(sum(w * (np.sum(h ** 2) - np.sum(r ** 2)) / (2 * s ** 2)
                     for h, r, s, w in zip(healthy, fit.residuals, sigma, weights)))


def _spread_left(fits: list, parameters: list, model: WhiteBoxModel, spreads_under,
                 clock: "_Deadline") -> dict[int, float]:
    """Per noise hypothesis read on the innovations (by index in ``fits``), the least spread
    ratio of its channel's innovations from its start on with the white box changed by one
    of the refined ``parameters`` hypotheses (their estimates), where that is below its own:
    what a sensor's extra noise would still have to explain. Past the diagnosis' time budget
    the hypotheses read so far stand (as a refinement's screened value does)."""
    noise = {i: f for i, f in enumerate(fits)
             if f.kind == "noise" and f.evidence_samples is not None and f.value > 1.0}
    left: dict[int, float] = {}
    for fit in parameters if noise else ():
        try:
            clock.check()
            from_start = spreads_under(with_parameters(model, {fit.target: _value(fit)}))
        except _OutOfTime:
            return left
        except GrayBoxError:     # the changed white box cannot run over the window
            continue
        by_start: dict[int, Mapping[str, InnovationSpread]] = {}
        for index, spread in noise.items():
            if spread.start not in by_start:
                by_start[spread.start] = from_start(spread.start)
            after = by_start[spread.start].get(spread.target)
            if after is not None and after.ratio < left.get(index, spread.value ** 2):
                left[index] = after.ratio
    return left


def _noise_gain(q: float, samples: float) -> float:
    """A noise hypothesis' log-likelihood gain for a variance ratio ``q`` over ``samples``
    effective samples: its maximum over factors ``s >= 1`` (a fall of the spread is
    ``s = 1``, no gain)."""
    return float(samples / 2 * (q - 1 - np.log(q))) if q > 1 else 0.0


def _value(fit: _Fit) -> float:
    return _physical(fit.kind, fit.log, fit.baseline, fit.scale, fit.value)


def _interval(fit: _Fit, weights, effective, z: float, level: float,
              start_covariance: np.ndarray | None = None) -> tuple[float, float]:
    if fit.kind == "noise":
        # the spread's square times N_eff / s^2 is chi-square with N_eff degrees of freedom
        dof = max(float(effective[fit.channel] if fit.evidence_samples is None
                        else fit.evidence_samples), 1.0)
        tail = (1 - level) / 2
        q = fit.value ** 2
        # scipy.stats.chi2.ppf(p, dof) is 2 * gammaincinv(dof / 2, p)
        return (float(np.sqrt(q * dof / (2 * special.gammaincinv(dof / 2, 1 - tail)))),
                float(np.sqrt(q * dof / (2 * special.gammaincinv(dof / 2, tail)))))
    information = float(np.sum(weights * fit.sensitivity))
    variance = 1.0 / information if information > 0 else np.inf       # of the free value
    if fit.start_cross is not None and start_covariance is not None and information > 0:
        # the hidden starts' estimation noise, shared by each period's errors
        # (graybox.start_uncertainty)
        cross = weights @ fit.start_cross
        variance += float(cross @ start_covariance @ cross) / information ** 2
    sd = float(np.sqrt(variance))
    if fit.log:
        # normal in the log, mapped back: positive and asymmetric about the estimate
        return (_physical(fit.kind, True, fit.baseline, fit.scale, fit.value - z * sd),
                _physical(fit.kind, True, fit.baseline, fit.scale, fit.value + z * sd))
    value = _value(fit)
    return (float(value - z * fit.scale * sd), float(value + z * fit.scale * sd))
