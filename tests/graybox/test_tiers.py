import numpy as np
import pytest

from graybox import TIERS
from graybox.tiers import TIER_KINDS, NoiseTierKind, Tier, tier_kind


def test_tier_kinds_are_registered_in_table_order():
    assert TIERS == ("linear", "nonlinear", "noise", "level")
    assert all(isinstance(kind, Tier) for kind in TIER_KINDS)


def test_each_tier_kind_reads_the_channel_record_it_is_named_after():
    # a kind registered under a name that is not the ChannelSignature field of its record, or
    # reading another tier's record, fails here
    import dataclasses

    from graybox.level_tier import LevelTier
    from tests.graybox.conftest import make_channel

    channel = dataclasses.replace(make_channel("x"), level=LevelTier(
        0.25, (0.0,), (0.0,), 1.0, 12, 100))
    fields = {f.name for f in dataclasses.fields(channel)}
    for kind in TIER_KINDS:
        assert kind.name in fields and kind.present(channel), kind.name
        names, values = kind.parameters(channel)
        assert len(names) == len(values) > 0, kind.name
    level_names, level_values = tier_kind("level").parameters(channel)
    assert list(level_values) == [0.25]
    assert not tier_kind("level").present(make_channel("x"))


def test_each_tier_kind_takes_its_parameters_from_its_own_record_only():
    # two channels whose every tier differs; a channel with one tier's record taken from the
    # other changes that tier's parameters and no other tier's: a kind that reads another
    # tier's record, or registers under another tier's name, fails here
    import dataclasses

    from graybox.level_tier import LevelTier
    from tests.graybox.conftest import make_channel

    one = dataclasses.replace(make_channel("x"), level=LevelTier(0.25, (0.0,), (0.0,), 1.0,
                                                                 12, 100))
    other = dataclasses.replace(
        make_channel("x", a=(0.1, 0.3), w=np.full((2, 3), -0.2), W=[0.7, 0.2],
                     moments=(0.5, 2.0, 0.1, 0.3)),
        level=LevelTier(-1.5, (0.0,), (0.0,), 1.0, 12, 100))

    def values(kind, channel):
        return list(kind.parameters(channel)[1])

    for kind in TIER_KINDS:
        assert isinstance(kind.record(one), kind.record_type), kind.name
        assert kind.record(one) is getattr(one, kind.name), kind.name
        assert values(kind, one) != values(kind, other), kind.name
        mixed = dataclasses.replace(one, **{kind.name: getattr(other, kind.name)})
        for each in TIER_KINDS:
            assert values(each, mixed) == values(each, other if each is kind else one), \
                (kind.name, each.name)


def test_tier_kind_by_name():
    assert isinstance(tier_kind("noise"), NoiseTierKind)
    with pytest.raises(ValueError, match="unknown tier"):
        tier_kind("quadratic")


def test_each_tier_kind_names_its_own_fit_figures():
    # what the registry records of each tier's fit (registry.write.run_content.fit_metrics)
    import dataclasses

    from graybox.level_tier import LevelTier
    from tests.graybox.conftest import make_channel

    channel = dataclasses.replace(make_channel("x"), level=LevelTier(
        0.25, (0.0,), (0.0,), 1.5, 12, 100))
    figures = {kind.name: kind.fit_metrics(channel) for kind in TIER_KINDS}
    assert figures == {
        "linear": {"fit.x.ar_innovation_variance": 1.0},
        "nonlinear": {"fit.x.nn_train_mse": 0.05, "fit.x.nn_iterations": 12,
                      "fit.x.nn_heldout_gain": 0.001},
        "noise": {"noise.x.mean": 0.0, "noise.x.variance": 1.0, "noise.x.skewness": 0.0,
                  "noise.x.excess_kurtosis": 0.0, "noise.x.ljung_box_statistic": 20.0,
                  "noise.x.ljung_box_pvalue": 0.4},
        "level": {"level.x.level": 0.25, "level.x.residual_std": 1.5}}
    unselected = make_channel("x", selection=False)
    assert "fit.x.nn_heldout_gain" not in tier_kind("nonlinear").fit_metrics(unselected)
    assert Tier().fit_metrics(channel) == {}


def test_each_tier_kind_writes_its_alerts_hint():
    # Alert.hint asks the alert's tier; a tier added through kinds= gets the generic hint
    from graybox.alert import Alert

    moved = ({"name": "a1", "baseline": 0.91, "candidate": 1.12},
             {"name": "W1_3", "baseline": -0.3, "candidate": 0.2})
    assert tier_kind("linear").hint(moved, count=1) == "a1 0.91→1.12"
    assert Tier().hint(moved, "load 12.5") == \
        "a1 0.91→1.12, W1_3 -0.3→0.2; outside the baseline's conditions: load 12.5"
    level = ({"name": "level", "baseline": 129.02, "candidate": 129.49},)
    assert tier_kind("level").hint(level, "load 12.5") == \
        "level moved from 129.02 to 129.49 (+0.47)"
    assert tier_kind("level").hint((), "load 12.5") == \
        "; outside the baseline's conditions: load 12.5"

    def alert(tier, changes):
        return Alert("T-1", "turbine", "2026-01-01", "2026-01-02", "omega", tier, 3.0, 1.0, 3.0,
                     "major", changes)

    assert alert("level", level).hint() == "level moved from 129.02 to 129.49 (+0.47)"
    assert alert("mean_abs", moved).hint() == "a1 0.91→1.12, W1_3 -0.3→0.2"
