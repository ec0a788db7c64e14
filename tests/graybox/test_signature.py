import json
import pathlib

import numpy as np
import pytest
from conftest import make_channel, make_signature

from graybox.exceptions import ArtifactError
from graybox.models import ModelSpec, load_model
from graybox.network_settings import FitSettings
from graybox.settings import GrayBoxSettings
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


DATA = pathlib.Path(__file__).parent / "data"


#: settings stored before the fixed-feature needed network and the function-space measure
#: load with these fields None: needed networks trained, drift Eq. 28 on the weights
BEFORE_FUNCTION_SPACE = dict(needed_network=None, needed_hidden_units=None, reference_points=None,
                             min_samples=200)  # the file's count (the default before "auto")


def _format_1_signature():
    """The record the format-1 file in tests/graybox/data was written from (by the code
    that still kept ``model`` and ``settings`` as dicts)."""
    model = load_model("graybox.models.gas_turbine:LangevinShaft", {"gamma": 0.06})
    return make_signature((make_channel(), make_channel("torque", a=(1 / 3,), selection=False)),
                          model=ModelSpec.from_model(model),
                          settings=GrayBoxSettings(hidden_units=2, analysis_interval=30.0,
                                                   **BEFORE_FUNCTION_SPACE),
                          analysis_interval=30.0)


def test_a_signature_written_by_the_dict_code_loads_to_an_equal_record():
    text = (DATA / "signature_v1.json").read_text().strip()
    loaded = Signature.from_json(text)
    assert loaded == _format_1_signature()
    assert loaded.to_json() == text                   # and is written back byte for byte
    assert isinstance(loaded.model, ModelSpec) and isinstance(loaded.settings, GrayBoxSettings)
    assert loaded.settings.network == FitSettings()
    assert loaded.model.load().parameters["gamma"] == 0.06


def test_typed_model_and_settings_are_hashable_records(signature):
    again = Signature.from_json(signature.to_json())
    assert hash(again.model) == hash(signature.model)
    assert hash(again.settings) == hash(signature.settings)
    assert len({signature.settings, again.settings, GrayBoxSettings(hidden_units=3)}) == 2
    assert signature.model.parameters == {"gamma": 0.06}
    assert signature.frozen_structure()["model"] == {
        "spec": "graybox.models.gas_turbine:LangevinShaft", "parameters": {"gamma": 0.06},
        "columns": {"omega": "omega"}}
    assert signature.frozen_structure()["settings"]["hidden_units"] == 2


def test_settings_stored_before_rate_invariance_load_at_the_native_rate():
    data = json.loads((DATA / "signature_v1.json").read_text())
    data["settings"].pop("analysis_interval")
    data["settings"].update(max_ar_order=20, max_delay=20)
    loaded = Signature.from_dict(data)
    assert loaded.settings == GrayBoxSettings(hidden_units=2, analysis_interval="native",
                                              **BEFORE_FUNCTION_SPACE)
    assert loaded.settings.trains_needed_network and loaded.settings.needed_units == 2


@pytest.mark.parametrize("mutate, message", [
    (lambda d: d["model"].update(spec=3), "ModelSpec.spec must be a string"),
    (lambda d: d["model"]["parameters"].update(gamma="fast"),
     r"ModelSpec.parameters\['gamma'\] must be a number"),
    (lambda d: d["settings"].update(hidden_units=2.5),
     "GrayBoxSettings.hidden_units must be an integer"),
    (lambda d: d["settings"].update(analysis_interval=[1]),
     "GrayBoxSettings.analysis_interval must be a number or a string"),
    (lambda d: d["settings"].update(residual="magic"), "GrayBoxSettings: residual must be one of"),
    (lambda d: d["settings"]["network"].update(iters=3),
     r"FitSettings: unknown field\(s\) \['iters'\]"),
    (lambda d: d["channels"][0]["nonlinear"].update(input_weights=[[0.1, "x"]]),
     r"NonlinearTier.input_weights\[0\]\[1\] must be a number"),
    (lambda d: d["channels"][0]["linear"].update(coefficients=None),
     "LinearTier.coefficients must not be null"),
])
def test_malformed_model_and_settings_name_the_record_and_field(mutate, message):
    data = json.loads((DATA / "signature_v1.json").read_text())
    mutate(data)
    with pytest.raises(ArtifactError, match=message):
        Signature.from_dict(data)
