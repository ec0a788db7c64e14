import json

import numpy as np
import pytest
from conftest import make_channel, make_signature

from graybox.exceptions import ArtifactError
from graybox.signature import Signature, tier_parameters


def test_json_round_trip_is_exact(signature):
    again = Signature.from_json(signature.to_json())
    assert again == signature
    assert again.to_json() == signature.to_json()
    awkward = make_signature((make_channel(a=(1 / 3, -2 ** -40, 1e-300)),))
    assert Signature.from_json(awkward.to_json()) == awkward


def test_parameter_vector_names_every_parameter(signature):
    names, values = signature.parameter_vector()
    assert len(names) == len(values) == 2 + (2 + 6) + 4
    assert names[:2] == ["omega.linear.a1", "omega.linear.a2"]
    assert "omega.nonlinear.W1_2" in names and "omega.nonlinear.w_2_3" in names
    assert names[-4:] == ["omega.noise.mean", "omega.noise.variance", "omega.noise.skewness",
                          "omega.noise.excess_kurtosis"]
    assert values[names.index("omega.nonlinear.W1_2")] == -0.4


def test_multichannel_vector_and_lookup():
    sig = make_signature((make_channel("a"), make_channel("b", a=(0.1,))))
    names, _ = sig.parameter_vector()
    assert names[0] == "a.linear.a1" and "b.linear.a1" in names and "b.linear.a2" not in names
    assert sig.channel("b").linear.coefficients == (0.1,)
    with pytest.raises(KeyError):
        sig.channel("c")


def test_tier_parameters_order_is_eq28(signature):
    names, values = tier_parameters(signature.channels[0], "nonlinear")
    assert names[:2] == ["W1_1", "W1_2"] and names[2] == "w_1_1"
    np.testing.assert_array_equal(values[:2], [0.3, -0.4])


@pytest.mark.parametrize("mutate, message", [
    (lambda d: d.update(extra=1), "unknown field"),
    (lambda d: d.pop("channels"), "missing field"),
    (lambda d: d["channels"][0]["linear"].update(n_obs="many"), "must be an integer"),
    (lambda d: d["channels"][0]["structure"].update(nonlinear_needed=1), "true or false"),
    (lambda d: d.update(format_version=99), "not supported"),
    (lambda d: d["channels"][0].update(noise=[1, 2]), "expected an object"),
])
def test_malformed_json_is_refused_with_a_clear_error(signature, mutate, message):
    data = json.loads(signature.to_json())
    mutate(data)
    with pytest.raises(ArtifactError, match=message):
        Signature.from_dict(data)


def test_non_json_is_refused():
    with pytest.raises(ArtifactError, match="not valid JSON"):
        Signature.from_json(b"\x80\x04\x95 pickle bytes")
