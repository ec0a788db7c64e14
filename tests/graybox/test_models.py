import numpy as np
import pytest

from graybox.exceptions import ModelSpecError, TelemetryError
from graybox.models import (DriveTrain, GasTurbineShaft, LangevinShaft, LinearStateSpace,
                            WhiteBoxModel, linear_parameters, load_model)


def test_load_by_spec_with_overrides_and_column_map():
    model = load_model("graybox.models:GasTurbineShaft", {"inertia": 40},
                       {"omega": "shaft_speed"})
    assert isinstance(model, GasTurbineShaft)
    assert model.parameters["inertia"] == 40.0
    assert model.parameters["turbine_gain"] == GasTurbineShaft.default_parameters["turbine_gain"]
    assert model.required_columns == ("shaft_speed", "fuel_rate")
    assert load_model(model.spec(), model.parameters, model.columns).parameters == model.parameters


@pytest.mark.parametrize("spec, fragment", [
    ("graybox.models.GasTurbineShaft", "not of the form"),
    ("no_such_module_xyz:Model", "cannot import 'no_such_module_xyz'.*PYTHONPATH=. when it "
                                 "sits beside fleet.toml"),
    ("graybox.no_such_module_xyz:Model", "cannot import(?!.*PYTHONPATH)"),
    ("graybox.models:NoSuchModel", "has no"),
    ("graybox.exceptions:GrayBoxError", "not a WhiteBoxModel"),
    ("graybox.models:LinearStateSpace", "abstract"),
])
def test_bad_specs_are_named(spec, fragment):
    with pytest.raises(ModelSpecError, match=fragment):
        load_model(spec)


def test_unknown_parameter_and_column_are_rejected():
    with pytest.raises(ModelSpecError, match="unknown parameter 'gama'"):
        LangevinShaft({"gama": 0.1})
    with pytest.raises(ModelSpecError, match="not a model variable"):
        LangevinShaft(columns={"speed": "x"})
    with pytest.raises(ModelSpecError, match="finite number"):
        LangevinShaft({"gamma": float("nan")})


def test_stability_conditions_are_checked():
    with pytest.raises(ModelSpecError, match="6a/6b"):
        GasTurbineShaft({"turbine_slope": -1.0})
    with pytest.raises(ModelSpecError, match="gamma must be > 0"):
        LangevinShaft({"gamma": 0.0})
    with pytest.raises(ModelSpecError, match="stable"):
        DriveTrain({"A_omega_turbine_omega_turbine": 0.5})


def test_declarations_are_checked_when_the_class_is_defined():
    with pytest.raises(ModelSpecError, match="at least one state"):
        class NoStates(WhiteBoxModel):
            states = ()

            def derivatives(self, x, u):
                return x
    with pytest.raises(ModelSpecError, match="must implement derivatives"):
        class NoDerivatives(WhiteBoxModel):
            states = ("x",)
    with pytest.raises(ModelSpecError, match="both as state and input"):
        class Overlap(WhiteBoxModel):
            states = ("x",)
            inputs = ("x",)

            def derivatives(self, x, u):
                return x
    with pytest.raises(ModelSpecError, match=r"controlled_inputs names \['heater'\], which are "
                                             r"not inputs; inputs: outdoor"):
        class ControlsAState(WhiteBoxModel):
            states = ("air",)
            inputs = ("outdoor",)
            controlled_inputs = ("heater",)

            def derivatives(self, x, u):
                return x


class _Lag(WhiteBoxModel):
    """One state following its input: written the natural way, ``(T,)`` for ``(T, 1)``."""

    states = ("level",)
    inputs = ("target",)
    default_parameters = {"tau": 10.0}

    def derivatives(self, x, u):
        return (u[..., 0] - x[..., 0]) / self.parameters["tau"]


class _TwoStates(WhiteBoxModel):
    states = ("a", "b")
    outputs = ("a", "total")
    inputs = ("drive",)

    def derivatives(self, x, u):
        return u[..., 0] - x[..., 0]            # one column for two states: a mistake

    def output(self, x, u):
        return np.stack([x[..., 0], x[..., 0] + x[..., 1]], axis=-1)


def test_a_one_state_model_may_return_its_rows_alone_and_a_wrong_shape_is_named():
    x, u = np.array([[1.0], [3.0]]), np.array([[2.0], [2.0]])
    np.testing.assert_allclose(_Lag().derivatives(x, u), [[0.1], [-0.1]])
    # the simulator's stacked form, (rows, vehicles, states), keeps its shape too
    assert _Lag().derivatives(np.ones((5, 3, 1)), np.ones((5, 3, 1))).shape == (5, 3, 1)
    x2 = np.ones((4, 2))
    assert _TwoStates().output(x2, np.ones((4, 1))).shape == (4, 2)
    with pytest.raises(ModelSpecError, match=r"_TwoStates.derivatives\(x, u\) returned an "
                       r"array of shape \(4,\) for x of shape \(4, 2\); it must return "
                       r"\(4, 2\): one column per name of states \('a', 'b'\)"):
        _TwoStates().derivatives(x2, np.ones((4, 1)))


def test_missing_columns_name_column_and_variable():
    model = GasTurbineShaft(columns={"omega": "shaft_speed"})
    with pytest.raises(TelemetryError) as info:
        model.check_columns(["fuel_rate", "timestamp"], asset_id="T-1", file="x.parquet")
    assert info.value.kind == "schema" and info.value.asset_id == "T-1"
    assert "'shaft_speed' (model variable 'omega')" in str(info.value)


def test_gas_turbine_equilibrium_and_damping():
    model = GasTurbineShaft()
    omega = model.equilibrium_speed(1.0)
    assert omega == pytest.approx(1000.0)
    assert model.derivatives(np.array([[omega]]), np.array([[1.0]]))[0, 0] == pytest.approx(0, abs=1e-9)
    # gamma is minus the slope of the net moment over J (Eq. 9, stable sign)
    h = 1e-3
    slope = (model.derivatives(np.array([[omega + h]]), np.array([[1.0]]))
             - model.derivatives(np.array([[omega - h]]), np.array([[1.0]])))[0, 0] / (2 * h)
    assert model.damping_rate(omega) == pytest.approx(-slope) == pytest.approx(0.06)


def test_langevin_is_equation_8_at_the_origin():
    model = LangevinShaft({"omega_ref": 0.0, "fuel_gain": 0.0, "gamma": 0.3})
    x = np.linspace(-2, 2, 5)[:, None]
    np.testing.assert_allclose(model.derivatives(x, np.ones_like(x)), -0.3 * x)


def test_linear_state_space_parameters_and_derivatives():
    model = DriveTrain()
    assert model.A.shape == (2, 2) and model.B.shape == (2, 1)
    x = np.array([[1.0, 2.0], [0.5, -1.0]])
    u = np.array([[3.0], [1.0]])
    np.testing.assert_allclose(model.derivatives(x, u), x @ model.A.T + u @ model.B.T)
    with pytest.raises(ModelSpecError, match="A_/B_ entries"):
        class Bad(LinearStateSpace):
            states = ("a",)
            inputs = ()
            default_parameters = {"gain": 1.0}
    assert linear_parameters(("a",), ("u",), [[-1.0]], [[2.0]]) == {"A_a_a": -1.0, "B_a_u": 2.0}


def test_stacked_models_evaluate_every_vehicle_in_one_call():
    models = [GasTurbineShaft(), GasTurbineShaft({"inertia": 40.0, "compressor_quadratic": 0.0})]
    stack = GasTurbineShaft.stacked(models)
    np.testing.assert_array_equal(stack.parameters["inertia"], [50.0, 40.0])
    x = np.array([[[900.0], [1100.0]], [[1000.0], [950.0]]])     # (time, vehicle, state)
    u = np.array([[[0.9], [1.1]], [[1.0], [1.2]]])
    together = stack.derivatives(x, u)
    for i, model in enumerate(models):
        np.testing.assert_allclose(together[:, i], model.derivatives(x[:, i], u[:, i]),
                                   rtol=1e-15)
        assert stack.subset(i).parameters == pytest.approx(model.parameters)
    # d = 0 has the linear equilibrium a mu / (b + c); d > 0 the quadratic root
    np.testing.assert_allclose(stack.equilibrium_speed(1.0), [1000.0, 2250.0 / 1.5])
    with pytest.raises(ModelSpecError, match="stacked"):
        GasTurbineShaft.stacked([GasTurbineShaft(), LangevinShaft()])
