"""Positive parameters and gains are fitted in log space (``graybox.diagnosis``): their
estimates and intervals stay positive (a gain's factor ``1 + g`` too), the interval is normal
in the log and so asymmetric about the estimate, a fit with no finite optimum stops at its
search range's end and says so, and an interval the data do not close on one side is opened
to that end. Known answers on hypotheses whose weighted errors are known functions of the free
value (each call one white-box run), and on the test drive."""
import numpy as np
import pytest

from graybox import record_json
from graybox.alert_diagnosis import cause_text, hypothesis_entry
from graybox.diagnosis import (POSITIVE_RANGE, SCREEN_REACH, Hypothesis, _interval, _Objective,
                               _open_end, _refine, _Rows, _screen, diagnose_window)
from graybox.exceptions import ModelSpecError
from graybox.models.gas_turbine import GasTurbineShaft
from graybox.models.linear import DriveTrain
from graybox.parameter_estimation import positive_parameters
from tests.graybox.test_diagnosis import FAULTS, Drive, drive_frame, levels  # noqa: F401

N = 200
Z95 = 1.959963984540054


def log_objective(errors, runs: list, baseline: float = 2.0) -> _Objective:
    """A positive parameter hypothesis (``baseline``, log space, scale 1) whose weighted
    errors at ``x`` are ``errors(value)``, ``value = baseline exp(x)``; ``runs`` collects every
    value run."""
    def weighted(x: float) -> np.ndarray:
        runs.append(x)
        return errors(baseline * np.exp(x))
    rows = _Rows(np.ones(N), np.array([0, N]), np.array([1.0]))
    span = float(np.log(POSITIVE_RANGE))
    return _Objective("parameter", "tau", baseline, 1.0, weighted, (-span, span), rows,
                      log=True, reach=float(np.log1p(SCREEN_REACH)))


def zero_mean_noise(seed: int) -> np.ndarray:
    noise = np.random.default_rng(seed).normal(0.0, 1.0, N)
    return noise - noise.mean()


def test_the_model_declares_its_positive_parameters():
    # default: every number parameter whose default value is > 0
    assert positive_parameters(GasTurbineShaft()) == tuple(GasTurbineShaft.default_parameters)
    assert positive_parameters(Drive()) == tuple(Drive.default_parameters)
    # a linear model's coefficients are signed: none
    assert positive_parameters(DriveTrain()) == ()

    class Celsius(Drive):
        positive = ("inertia", "friction")      # the ambient may cross zero
    assert positive_parameters(Celsius()) == ("inertia", "friction")

    class Wrong(Drive):
        positive = ("wear",)
    with pytest.raises(ModelSpecError, match="positive"):
        positive_parameters(Wrong())


def test_a_time_constants_interval_is_positive_and_asymmetric():
    # a decay time constant 3 times its baseline of 2 s, seen for 3 s on a noisy record: the
    # fit in log space finds the least-squares value (6.03 s); its interval is normal in
    # log(tau): symmetric there, positive and twice as long above the estimate as below it
    # (3.02 to 12.07 s)
    t = np.linspace(0.0, 3.0, N)
    noise = zero_mean_noise(11)
    data = np.exp(-t / 6.0) + noise

    def errors(tau):
        return data - np.exp(-t / tau)

    runs = []
    hypothesis = log_objective(errors, runs)
    fit = _refine(hypothesis, _screen(hypothesis, errors(2.0)))
    taus = np.exp(np.linspace(np.log(0.5), np.log(500.0), 20001))
    costs = [errors(tau) @ errors(tau) for tau in taus]
    best = taus[int(np.argmin(costs))]
    estimate = 2.0 * np.exp(fit.value)
    low, high = _interval(fit, np.ones(1), np.ones(1), Z95, 0.95)
    # the least-squares value to within a hundredth of the interval's half-width (in the log)
    assert abs(np.log(estimate / best)) < 0.01 * np.log(high / estimate)
    assert 0 < low < estimate < high
    assert high - estimate > 1.5 * (estimate - low)
    assert np.log(high / estimate) == pytest.approx(np.log(estimate / low), rel=1e-9)
    assert (low, high) == (pytest.approx(3.03, rel=0.01), pytest.approx(12.05, rel=0.01))


def test_a_hypothesis_with_no_finite_optimum_stops_at_its_range_and_says_so():
    # the cost falls all the way to tau = infinity (the errors lose 5 / tau): the fit walks
    # out by doubling log-steps to the range's end (POSITIVE_RANGE times the baseline) in
    # a few runs (16 without the walk test: Newton steps of a constant half a log unit in the
    # tail e^-2x, until the fall they promise is within REFINE_FTOL) and reports that end,
    # with the interval open on that side
    noise = zero_mean_noise(13)

    def errors(tau):
        return noise + 5.0 / tau

    runs = []
    hypothesis = log_objective(errors, runs)
    screened = _screen(hypothesis, errors(2.0))
    runs.clear()
    fit = _refine(hypothesis, screened)
    assert fit.bound == "upper"
    assert hypothesis.value(fit.value) == pytest.approx(2.0 * POSITIVE_RANGE)
    assert len(runs) <= 7
    interval, bound = _open_end(hypothesis, fit, _interval(fit, np.ones(1), np.ones(1), Z95,
                                                           0.95), np.ones(1), Z95, True)
    assert bound == "upper" and interval[1] == pytest.approx(2.0 * POSITIVE_RANGE)
    assert 0 < interval[0] < interval[1]


@pytest.mark.parametrize("ratio, opened", [(0.1, True), (0.2, False)])
def test_an_interval_the_data_do_not_close_is_opened_to_the_range(ratio, opened):
    # a finite optimum at tau = 50 (25 times the baseline) in a valley that flattens out to
    # infinity: the cost there is higher by N ratio^2 / 2 (1.0 and 4.0), against the 95 %
    # likelihood-ratio threshold z^2 / 2 = 1.92; one run at the range's end decides
    noise = zero_mean_noise(17)

    def errors(tau):
        return noise + ratio * 50.0 * (1.0 / tau - 1.0 / 50.0)

    runs = []
    hypothesis = log_objective(errors, runs)
    fit = _refine(hypothesis, _screen(hypothesis, errors(2.0)))
    # (to REFINE_FTOL of the cost: the valley is flat, the interval factors of ten wide)
    assert fit.bound is None and 2.0 * np.exp(fit.value) == pytest.approx(50.0, rel=0.01)
    closed = _interval(fit, np.ones(1), np.ones(1), Z95, 0.95)
    runs.clear()
    interval, bound = _open_end(hypothesis, fit, closed, np.ones(1), Z95, True)
    assert len(runs) <= 1                     # the range's end, unless run before
    if opened:
        assert bound == "upper" and interval == (closed[0], pytest.approx(2.0 * POSITIVE_RANGE))
    else:
        assert bound is None and interval == closed


def test_the_drives_parameters_and_gains_have_positive_intervals(levels):  # noqa: F811
    # every parameter (all positive) and every sensor gain factor 1 + g: estimate and
    # interval above zero, on a healthy window (wide intervals) and a friction change
    for options in ({}, {"model": FAULTS["friction"][0]["model"]}):
        model = options.get("model", Drive())
        diagnosis = diagnose_window(Drive(), levels, [drive_frame(model, 10)])
        for h in diagnosis.hypotheses:
            low, high = h.interval
            assert low <= h.estimate <= high
            if h.kind == "parameter":
                assert low > 0
                assert high - h.estimate > h.estimate - low     # normal in the log
            elif h.kind == "gain":
                assert low > -1


def test_a_bound_is_recorded_shown_and_listed_on_the_alert():
    h = Hypothesis("parameter pump_lag", "parameter", "pump_lag", 2.5, 596.5, (76.2, 2500.0),
                   3778.0, 1890.0, bound="upper")
    again = record_json.from_dict(Hypothesis, record_json.to_dict(h))
    assert again == h
    assert "bound" not in record_json.to_dict(Hypothesis("x", "bias", "y", 0.0, 1.0, (0.5, 1.5),
                                                         3.0, 2.0))
    assert "not bounded above within x1000 of the baseline" in h.describe()
    at_end = Hypothesis("parameter pump_lag", "parameter", "pump_lag", 2.5, 2500.0,
                        (300.0, 2500.0), 3778.0, 1890.0, bound="upper")
    assert "no finite optimum within x1000" in at_end.describe()
    entry = hypothesis_entry(h)
    assert entry["bound"] == "upper"
    assert "interval 76.2 to 2500, not bounded above" in cause_text(entry)
    with pytest.raises(ValueError, match="bound"):
        Hypothesis("x", "parameter", "p", 1.0, 1.0, (0.5, 2.0), 1.0, 1.0, bound="left")
