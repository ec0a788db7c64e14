"""The input conditions of a fit, and the discount of a night driven beyond its baseline's."""
import json

import numpy as np
import pytest
from conftest import make_channel, make_signature

from graybox.drift import Drift, compute_drift
from graybox.models.base import WhiteBoxModel
from graybox.operating_conditions import (OperatingConditions, covered, exogenous_inputs,
                                          farthest, operating_conditions, outside)
from graybox.record_json import from_dict, to_dict
from graybox.signature import Signature


class Room(WhiteBoxModel):
    states = ("air",)
    inputs = ("heater", "outdoor", "sun")
    controlled_inputs = ("heater",)

    def derivatives(self, x, u):
        return u[..., :1] - x


class Thermostat(WhiteBoxModel):
    states = ("air",)
    inputs = ("heater",)
    controlled_inputs = ("heater",)

    def derivatives(self, x, u):
        return u - x


def _pieces(values, residual=0.0, cycle=0.0):
    """Eight pieces per window about each window's value: a daily ``cycle`` shared by every
    window and, in the first two windows, ``+-residual`` in turn (zero row and column means:
    the two-way analysis's residual sum of squares is 16 residual**2)."""
    pattern = np.zeros((len(values), 8))
    pattern[:2] = residual * np.array([[1, -1] * 4, [-1, 1] * 4])[:len(values)]
    daily = cycle * np.sin(2 * np.pi * np.arange(8) / 8)
    pieces = np.asarray(values, float)[:, None] + daily + pattern
    return tuple(tuple((float(v),) for v in row) for row in pieces)


def _conditions(means, spreads=None, residual=0.0, cycle=0.0, excitations=None,
                excitation_residual=0.0):
    """One input's figures per window, its pieces by :func:`_pieces` (spreads piece by piece
    as the window's); without ``excitations`` a record stored before the excitation figure."""
    spreads = spreads or [1.0] * len(means)
    extra = {} if excitations is None else {
        "excitations": tuple((e,) for e in excitations),
        "piece_excitations": _pieces(excitations, excitation_residual)}
    return OperatingConditions(("outdoor",), tuple((m,) for m in means),
                               tuple((s,) for s in spreads), _pieces(means, residual, cycle),
                               tuple(tuple((float(sd),) for _ in range(8)) for sd in spreads),
                               **extra)


def test_each_windows_exogenous_inputs_mean_and_spread_over_its_segments():
    assert exogenous_inputs(Room()) == (1, 2)
    heater = np.full(8, 9.0)
    # window 0 has two segments (outdoor 1, 3, 1, 3 then 5, 7, 5, 7), window 1 one
    segments = [np.column_stack([heater[:4], [1.0, 3.0, 1.0, 3.0], np.zeros(4)]),
                np.column_stack([heater[:4], [5.0, 7.0, 5.0, 7.0], np.full(4, 2.0)]),
                np.column_stack([heater, np.repeat([10.0, 12.0], 4),
                                 [1.0, np.nan, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]])]
    conditions = operating_conditions(Room(), segments, owners=[0, 0, 1])
    assert conditions.inputs == ("outdoor", "sun")
    assert conditions.means == ((4.0, 1.0), (11.0, 1.0))
    np.testing.assert_allclose(conditions.spreads, [[np.sqrt(5.0), 1.0], [1.0, 0.0]])
    # eight pieces of one sample each: their figures are the samples (spreads 0)
    assert [p[0] for p in conditions.piece_means[0]] == [1.0, 3.0, 1.0, 3.0, 5.0, 7.0, 5.0, 7.0]
    assert conditions.piece_means[1][7] == (12.0, 1.0)
    assert conditions.piece_spreads[0] == ((0.0, 0.0),) * 8
    # the excitation: the spread of the steps within each segment (3 -> 5 is no step)
    np.testing.assert_allclose(conditions.excitations, [[np.std([2, -2, 2] * 2), 0.0],
                                                        [np.std([0, 0, 0, 2, 0, 0, 0]), 0.0]])
    assert from_dict(OperatingConditions, json.loads(json.dumps(to_dict(conditions)))) == \
        conditions
    # every input set by a controller: nothing places a night in or outside a range
    assert operating_conditions(Thermostat(), [np.ones((5, 1))], [0]) is None


def test_outside_is_the_farthest_figure_over_the_baselines_reach():
    baseline = _conditions([5.0, 8.0, 10.0], residual=0.1)   # centre 23/3, reach 8/3
    assert outside(_conditions([23 / 3 + 16 / 3]), baseline) == pytest.approx(2.0)
    assert outside(_conditions([8.0]), baseline) < 1.0
    # the same mean on a far gustier night: outside through the spread
    baseline = _conditions([5.0, 8.0, 10.0], [1.0, 1.5, 2.0], residual=0.1)  # spreads: 1.5 +- 0.5
    assert outside(_conditions([8.0], [3.0]), baseline) == pytest.approx(3.0)
    assert farthest(_conditions([8.0], [3.0]), baseline) == \
        (pytest.approx(3.0), "outdoor spread 3 (baseline days 1 to 2)")
    # a candidate of two nights is as far outside as its farthest: one inside the range
    # (spread 1.5) and one far gustier (3.5) give 4.0 where their average (2.5) would give 2.0
    assert outside(_conditions([8.0, 8.0], [1.5, 3.5]), baseline) == pytest.approx(4.0)
    assert farthest(_conditions([8.0, 8.0], [1.5, 3.5]), baseline)[1] == \
        "outdoor spread 3.5 (baseline days 1 to 2)"
    # no record, a single baseline window, other inputs or a figure no window moved: 0
    assert outside(None, baseline) == outside(_conditions([8.0]), None) == 0.0
    assert outside(_conditions([30.0]), _conditions([5.0])) == 0.0
    other = OperatingConditions(("sun",), ((8.0,),), ((1.0,),), (((8.0,),),), (((1.0,),),))
    assert outside(other, baseline) == 0.0
    assert outside(_conditions([9.0], [1.0]), _conditions([4.0, 4.0], [1.0, 1.0])) == 0.0


def test_a_figure_counts_only_where_the_baseline_windows_differ_beyond_chance():
    # windows at 5, 8 and 10 C: the mean varies, the spread (1 in every window) does not
    baseline = _conditions([5.0, 8.0, 10.0], residual=0.5)
    assert list(baseline.varying()) == [True, False]
    assert outside(_conditions([13.0]), baseline) == pytest.approx(2.0)
    # a daily cycle every window shares is the times of day's effect, not the windows'
    assert _conditions([5.0, 8.0, 10.0], residual=0.5, cycle=20.0).varying()[0]
    # windows' effect: 8 x 12.667 / 2 = 50.67; residual 16 c^2 over 2 x 7; F(2, 14) at 1 %
    # is 6.51: the windows differ for c = 2.5 (F 7.09), not for c = 2.7 (F 6.08), where
    # five such days differ by chance and nothing is outside them
    assert _conditions([5.0, 8.0, 10.0], residual=2.5).varying()[0]
    noisy = _conditions([5.0, 8.0, 10.0], residual=2.7)
    assert not noisy.varying()[0]
    assert outside(_conditions([13.0]), noisy) == 0.0


def test_the_conditions_a_baseline_covers_are_the_figures_outside_counts_with_their_range():
    # the mean varies between the windows (5 to 10), the spread does not: one figure
    assert covered(_conditions([5.0, 8.0, 10.0], residual=0.5)) == ("outdoor mean 5 to 10",)
    assert covered(_conditions([5.0, 8.0, 10.0], [1.0, 1.5, 2.0], residual=0.1)) == (
        "outdoor mean 5 to 10", "outdoor spread 1 to 2")
    # days that differ by chance alone, a single window, no record: nothing judged outside
    assert covered(_conditions([5.0, 8.0, 10.0], residual=2.7)) == ()
    assert covered(_conditions([5.0])) == covered(None) == ()
    # said in the signature's summary, where an engineer reads what its nights are judged on
    summary = make_signature(conditions=_conditions([5.0, 8.0, 10.0], residual=0.5)).summary()
    assert "Days' conditions:       outdoor mean 5 to 10" in summary
    assert "Days' conditions" not in make_signature().summary()


def test_a_night_beyond_the_baselines_conditions_has_its_tiers_changes_discounted():
    base = make_signature((make_channel(a=(0.5,)),),
                          conditions=_conditions([5.0, 8.0, 10.0], residual=0.1))
    assert Signature.from_json(base.to_json()) == base
    moved = make_channel(a=(0.6,))
    inside = compute_drift(make_signature((moved,), conditions=_conditions([8.0])), base)
    linear = inside.get("omega", "linear")
    assert linear.zeta == pytest.approx(0.01) and linear.outside is None
    far = make_signature((moved,), conditions=_conditions([23 / 3 + 16 / 3]))
    drift = compute_drift(far, base)
    linear = drift.get("omega", "linear")
    # twice the reach: the change halved, zeta quartered, and said
    assert linear.zeta == pytest.approx(0.0025) and linear.outside == pytest.approx(2.0)
    assert linear.top_changes[0].contribution == pytest.approx(0.0025)
    assert drift.get("omega", "noise").outside == pytest.approx(2.0)
    assert Signature.from_json(far.to_json()) == far
    assert "omega linear, omega nonlinear, omega noise: outside the baseline's operating " \
           "range (2.0000 x its reach), change discounted" in drift.summary()
    # which input left the range, its value and the baseline days' range
    assert drift.conditions == "outdoor mean 13 (baseline days 5 to 10)"
    assert "farthest outside: outdoor mean 13 (baseline days 5 to 10)" in drift.summary()
    assert Drift.from_dict(json.loads(json.dumps(drift.to_dict()))) == drift
    assert compute_drift(make_signature((moved,), conditions=_conditions([8.0])),
                         base).conditions is None
    # a baseline stored without the record: nothing discounted
    plain = make_signature((make_channel(a=(0.5,)),))
    assert compute_drift(far, plain).get("omega", "linear").zeta == pytest.approx(0.01)
    assert "conditions" not in plain.to_dict()


def test_calibration_discounts_a_left_out_day_driven_beyond_the_other_days():
    from graybox.calibration import _changes

    rest = make_signature((make_channel(a=(0.5,), n_samples=4000),), n_samples=4000,
                          conditions=_conditions([5.0, 8.0, 10.0, 7.0], residual=0.1))
    piece = make_signature((make_channel(a=(0.6,), n_samples=500),), n_samples=500,
                           conditions=_conditions([30.0]))
    # two left-out days with the same change: one inside the others' range, one at twice
    # their reach (centre 7.5, reach 2.5: 12.5 is twice as far)
    inside = make_signature((make_channel(a=(0.6,)),), conditions=_conditions([8.0]))
    beyond = make_signature((make_channel(a=(0.6,)),), conditions=_conditions([12.5]))
    baseline = make_signature((make_channel(a=(0.5,), n_samples=5000),), n_samples=5000)
    pieces, days = _changes(baseline, [(rest, piece)] * 3,
                            [(rest, inside), (rest, beyond)])["omega", "linear"]
    assert days[1] == pytest.approx(days[0] / 2)
    # a piece is compared as it is, however far its own figures lie (a part of a day)
    plain_piece = make_signature((make_channel(a=(0.6,), n_samples=500),), n_samples=500)
    plain = _changes(baseline, [(rest, plain_piece)] * 3, [(rest, inside)] * 2)
    assert pieces[0] == pytest.approx(plain["omega", "linear"][0][0])


def test_an_excitation_counts_beyond_the_chance_reach_of_days_driven_alike():
    # three days stepped alike (2.0, 2.05, 1.95): they do not differ beyond chance, yet a
    # night stepped far harder is outside them. The two-way residual, 16 r^2 over 2 x 7
    # degrees of freedom, gives a day's mean a standard error sqrt(16 r^2 / 14 / 8); three of
    # them, 3 r / sqrt(7) = 0.3969 for r = 0.35, exceed the days' own reach of 0.05
    baseline = _conditions([5.0, 8.0, 10.0], residual=0.1, excitations=[2.0, 2.05, 1.95],
                           excitation_residual=0.35)
    assert list(baseline.varying()) == [True, False, False]
    np.testing.assert_allclose(baseline.chance_reach()[2], 3 * 0.35 / np.sqrt(7))
    night = _conditions([8.0], excitations=[2.0 + 2 * 3 * 0.35 / np.sqrt(7)])
    assert outside(night, baseline) == pytest.approx(2.0)
    assert farthest(night, baseline)[1] == "outdoor excitation 2.794 (baseline days 1.95 to 2.05)"
    # only where a tier answers to it: the means and spreads alone are inside
    assert outside(night, baseline, ("mean", "spread")) < 1.0
    assert covered(baseline) == ("outdoor mean 5 to 10", "outdoor excitation 1.95 to 2.05")
    # a baseline stored before the figure judges on its means and spreads alone
    stored = _conditions([5.0, 8.0, 10.0], residual=0.1)
    assert outside(night, stored) < 1.0
    assert outside(_conditions([23 / 3 + 16 / 3], excitations=[2.0]), stored) == \
        pytest.approx(2.0)


def test_a_night_stepped_beyond_the_baselines_excitation_has_its_noise_tier_discounted():
    conditions = dict(residual=0.1, excitations=[2.0, 2.05, 1.95], excitation_residual=0.35)
    base = make_signature((make_channel(a=(0.5,), moments=(0.0, 1.0, 0.0, 0.0)),),
                          conditions=_conditions([5.0, 8.0, 10.0], **conditions))
    moved = make_channel(a=(0.6,), moments=(0.0, 1.2, 0.0, 0.0))
    night = _conditions([8.0], excitations=[2.0 + 2 * 3 * 0.35 / np.sqrt(7)])
    drift = compute_drift(make_signature((moved,), conditions=night), base)
    inside = compute_drift(make_signature((moved,), conditions=_conditions(
        [8.0], excitations=[2.0])), base)
    # the noise tier's change halved (zeta quartered); the linear tier's as it is
    assert drift.get("omega", "noise").outside == pytest.approx(2.0)
    assert drift.get("omega", "noise").zeta == pytest.approx(
        inside.get("omega", "noise").zeta / 4)
    assert drift.get("omega", "linear").outside is None
    assert drift.get("omega", "linear").zeta == pytest.approx(0.01)
    assert drift.conditions == "outdoor excitation 2.794 (baseline days 1.95 to 2.05)"
    assert Signature.from_json(base.to_json()) == base


def test_calibration_discounts_a_day_stepped_beyond_the_others_in_the_noise_tier_only():
    from graybox.calibration import _changes

    alike = dict(residual=0.1, excitations=[2.0, 2.05, 1.95, 2.0], excitation_residual=0.35)
    rest = make_signature((make_channel(a=(0.5,), n_samples=4000),), n_samples=4000,
                          conditions=_conditions([5.0, 8.0, 10.0, 7.0], **alike))
    piece = make_signature((make_channel(a=(0.6,), n_samples=500),), n_samples=500)
    # the same changes on a day stepped like the others and on one stepped twice the
    # chance reach beyond them (four days: 16 r^2 over 3 x 7 degrees of freedom, a day's
    # standard error sqrt(16 r^2 / 21 / 8), three of them 3 r sqrt(2 / 21))
    moved = dict(a=(0.6,), moments=(0.0, 1.2, 0.0, 0.0))
    reach = 3 * 0.35 * np.sqrt(2 / 21)
    inside = make_signature((make_channel(**moved),),
                            conditions=_conditions([7.5], excitations=[2.0]))
    stepped = make_signature((make_channel(**moved),),
                             conditions=_conditions([7.5], excitations=[2.0 + 2 * reach]))
    baseline = make_signature((make_channel(a=(0.5,), n_samples=5000),), n_samples=5000)
    changes = _changes(baseline, [(rest, piece)] * 3, [(rest, inside), (rest, stepped)])
    noise, linear = changes["omega", "noise"][1], changes["omega", "linear"][1]
    np.testing.assert_allclose(noise[1], noise[0] / 2)
    np.testing.assert_allclose(linear[1], linear[0])
