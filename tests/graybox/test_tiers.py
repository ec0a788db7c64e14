import pytest

from graybox import TIERS
from graybox.tiers import TIER_KINDS, NoiseTierKind, Tier, tier_kind


def test_tier_kinds_are_registered_in_table_order():
    assert TIERS == ("linear", "nonlinear", "noise", "level")
    assert tuple(kind.name for kind in TIER_KINDS) == TIERS
    assert all(isinstance(kind, Tier) for kind in TIER_KINDS)


def test_tier_kind_by_name():
    assert isinstance(tier_kind("noise"), NoiseTierKind)
    with pytest.raises(ValueError, match="unknown tier"):
        tier_kind("quadratic")
