"""The scientific API: what ``import graybox as gb`` offers."""
import graybox as gb
from graybox import embedding, level_tier, linear_tier, noise_tier, nonlinear_tier, stationarize

TIER_FITTERS = {
    "choose_differencing": stationarize.choose_differencing,
    "Differencing": stationarize.Differencing,
    "DifferencingChoice": stationarize.DifferencingChoice,
    "fit_ar": linear_tier.fit_ar,
    "LinearTier": linear_tier.LinearTier,
    "choose_delay": embedding.choose_delay,
    "choose_dimension": embedding.choose_dimension,
    "lagged": nonlinear_tier.lagged,
    "fit_networks": nonlinear_tier.fit_networks,
    "NonlinearTier": nonlinear_tier.NonlinearTier,
    "describe_noise": noise_tier.describe_noise,
    "NoiseTier": noise_tier.NoiseTier,
    "fit_level": level_tier.fit_level,
    "LevelTier": level_tier.LevelTier,
}


def test_every_name_in_all_exists_once_and_is_documented():
    assert len(gb.__all__) == len(set(gb.__all__))
    missing = [name for name in gb.__all__ if not hasattr(gb, name)]
    assert missing == []
    undocumented = [name for name in gb.__all__ if name != "TIERS"
                    and not (getattr(gb, name).__doc__ or "").strip()]
    assert undocumented == []


def test_tier_fitters_are_exported_under_their_own_names():
    assert set(TIER_FITTERS) <= set(gb.__all__)
    assert {name: getattr(gb, name) for name in TIER_FITTERS} == TIER_FITTERS
