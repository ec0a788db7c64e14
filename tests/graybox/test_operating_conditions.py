"""The input conditions of a fit, and the discount of a night driven beyond its baseline's."""
import json

import numpy as np
import pytest
from conftest import make_channel, make_signature

from graybox.drift import compute_drift
from graybox.models.base import WhiteBoxModel
from graybox.operating_conditions import (OperatingConditions, exogenous_inputs,
                                          operating_conditions, outside)
from graybox.records import from_dict, to_dict
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


def _conditions(means, spreads=None, within=1e-4):
    """One input's figures per window; ``within``: each figure's variance from its pieces."""
    spreads = spreads or [1.0] * len(means)
    return OperatingConditions(("outdoor",), tuple((m,) for m in means),
                               tuple((s,) for s in spreads), ((within,),) * len(means),
                               ((within,),) * len(means))


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
    # eight pieces of one sample: window 0's outdoor pieces 1, 3, 1, 3, 5, 7, 5, 7 vary by 5
    # about their mean (each piece's spread is 0); window 1's by 1
    np.testing.assert_allclose(conditions.mean_variances, [[5.0 / 8, 1.0 / 8], [1.0 / 8, 0.0]])
    np.testing.assert_allclose(conditions.spread_variances, [[0.0, 0.0], [0.0, 0.0]])
    assert from_dict(OperatingConditions, json.loads(json.dumps(to_dict(conditions)))) == \
        conditions
    # every input set by a controller: nothing places a night in or outside a range
    assert operating_conditions(Thermostat(), [np.ones((5, 1))], [0]) is None


def test_outside_is_the_farthest_figure_over_the_baselines_reach():
    baseline = _conditions([5.0, 8.0, 10.0])    # centre 23/3, reach 8/3 (the 5 C day)
    assert outside(_conditions([23 / 3 + 16 / 3]), baseline) == pytest.approx(2.0)
    assert outside(_conditions([8.0]), baseline) < 1.0
    # the same mean on a far gustier night: outside through the spread
    baseline = _conditions([5.0, 8.0, 10.0], [1.0, 1.5, 2.0])   # spreads: centre 1.5, reach 0.5
    assert outside(_conditions([8.0], [3.0]), baseline) == pytest.approx(3.0)
    # a night over two windows is placed at their average
    assert outside(_conditions([8.0, 8.0], [2.5, 3.5]), baseline) == pytest.approx(3.0)
    # no record, a single baseline window, other inputs or a figure no window moved: 0
    assert outside(None, baseline) == outside(_conditions([8.0]), None) == 0.0
    assert outside(_conditions([30.0]), _conditions([5.0])) == 0.0
    other = OperatingConditions(("sun",), ((8.0,),), ((1.0,),), ((0.0,),), ((0.0,),))
    assert outside(other, baseline) == 0.0
    assert outside(_conditions([9.0], [1.0]), _conditions([4.0, 4.0], [1.0, 1.0])) == 0.0


def test_a_figure_counts_only_where_the_baseline_windows_differ_beyond_chance():
    # windows 5, 8, 10 C whose pieces say a window's mean varies by 0.1 (sd 0.3): they differ
    baseline = _conditions([5.0, 8.0, 10.0], within=0.1)
    assert list(baseline.varying()) == [True, False]   # the mean varies, the spread does not
    assert outside(_conditions([13.0]), baseline) == pytest.approx(2.0)
    # the same windows with pieces that vary by 10 (a strong daily cycle in every window):
    # five such days differ by chance, and nothing is outside them
    cycling = _conditions([5.0, 8.0, 10.0], within=10.0)
    assert not cycling.varying().any()
    assert outside(_conditions([13.0]), cycling) == 0.0
    # F(2, 21) at 1 % is 5.78: between-window variance 6.33 against within 1.0 counts,
    # against 1.2 it does not
    assert _conditions([5.0, 8.0, 10.0], within=1.0).varying()[0]
    assert not _conditions([5.0, 8.0, 10.0], within=1.2).varying()[0]


def test_a_night_beyond_the_baselines_conditions_has_its_tiers_changes_discounted():
    base = make_signature((make_channel(a=(0.5,)),), conditions=_conditions([5.0, 8.0, 10.0]))
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
    # a baseline stored without the record: nothing discounted
    plain = make_signature((make_channel(a=(0.5,)),))
    assert compute_drift(far, plain).get("omega", "linear").zeta == pytest.approx(0.01)
    assert "conditions" not in plain.to_dict()


def test_calibration_discounts_a_left_out_day_driven_beyond_the_other_days():
    from graybox.calibration import _changes

    rest = make_signature((make_channel(a=(0.5,), n_samples=4000),), n_samples=4000,
                          conditions=_conditions([5.0, 8.0, 10.0, 7.0]))
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
