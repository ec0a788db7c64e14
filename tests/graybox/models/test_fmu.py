"""An FMU as a white box (graybox.models.fmu), on a small FMI 2.0 model-exchange FMU that the
tests build (plant_fmu.py: fmu_plant/plant.c compiled with the system's C compiler and
zipped with fmu_plant/modelDescription.xml).

Known answers: the FMU computes what the same plant written as a Python white box computes;
a parameter override moves the derivatives as the formula says; simulated with measurement
noise only, a baseline fits with the defaults and the output residual is that noise,
differenced; a bad FMU is an error naming the file and what to do."""
from __future__ import annotations

import copy
import json
import os
import pathlib
import pickle
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

import fmpy   # the test extra installs it: its absence is a failure, not a skip

import graybox as gb
from graybox.exceptions import ModelSpecError
from graybox.integration import Integration
from graybox.models import ModelSpec, load_model
from graybox.models.fmu import FMUModel
from graybox.residual import residual_frame
from graybox.state_estimation import estimate_states, window_arrays
from plant_fmu import DESCRIPTION, DT, TwinPlant, build_fmu, needs_compiler, simulate


def fmu_class(path: pathlib.Path, name: str = "Plant") -> type[FMUModel]:
    return type(name, (FMUModel,), {"fmu": str(path), "__module__": __name__,
                                    "__qualname__": name})


@pytest.fixture(scope="module")
def plant_fmu(tmp_path_factory) -> pathlib.Path:
    return build_fmu(tmp_path_factory.mktemp("fmu"))


@pytest.fixture(scope="module")
def Plant(plant_fmu) -> type[FMUModel]:
    return fmu_class(plant_fmu)


def random_rows(n: int, seed: int):
    rng = np.random.default_rng(seed)
    return rng.normal(5.0, 4.0, (n, 2)), rng.uniform(0.0, 200.0, (n, 1))


# -- variables ----------------------------------------------------------------------------------

@needs_compiler
def test_the_fmus_variables_are_the_white_boxs(Plant):
    assert Plant.states == ("heater_T", "probe_T")            # heater.T, probe.T
    assert Plant.inputs == ("power",) and Plant.outputs == ("reading",)
    assert Plant.default_parameters == {"tau": 20.0, "lag": 5.0}
    assert Plant.positive == ("tau",)                           # min="0"; lag declares none
    assert Plant.initial_state == {"heater_T": 0.0, "probe_T": 0.0}
    assert Plant.fmu_variables["heater_T"] == "heater.T"
    model = Plant(columns={"reading": "probe_reading"})
    assert model.hidden_states == ("heater_T", "probe_T")
    assert model.required_columns == ("probe_reading", "power")


@needs_compiler
def test_outputs_that_are_states_are_measured_and_no_outputs_measure_every_state(tmp_path):
    # probe.T declared an output: that state is measured, the heater stays hidden
    probe_out = DESCRIPTION.replace(
        'name="probe.T" valueReference="2" causality="local"',
        'name="probe.T" valueReference="2" causality="output"').replace(
        '<Unknown index="6" dependencies="1 3"/>', '<Unknown index="3"/>\n'
        '      <Unknown index="6" dependencies="1 3"/>')
    model = fmu_class(build_fmu(tmp_path / "probe", probe_out))()
    assert model.outputs == ("probe_T", "reading") and model.hidden_states == ("heater_T",)
    x, u = random_rows(5, 4)
    np.testing.assert_allclose(model.output(x, u),
                               np.column_stack([x[:, 1], TwinPlant().output(x, u)[:, 0]]),
                               rtol=1e-12)
    # no outputs at all: the contract's default, every state measured
    no_outputs = DESCRIPTION.replace('causality="output"', 'causality="local"').replace(
        '<Outputs>\n      <Unknown index="6" dependencies="1 3"/>\n    </Outputs>\n', "")
    model = fmu_class(build_fmu(tmp_path / "none", no_outputs))()
    assert model.outputs == model.states and model.hidden_states == ()
    np.testing.assert_array_equal(model.output(x, u), x)


# -- known answers ------------------------------------------------------------------------------

@needs_compiler
def test_derivatives_and_outputs_are_the_python_plants(Plant):
    x, u = random_rows(500, 0)
    model, twin = Plant(), TwinPlant()
    np.testing.assert_allclose(model.derivatives(x, u), twin.derivatives(x, u), rtol=1e-12,
                               atol=1e-12)
    np.testing.assert_allclose(model.output(x, u), twin.output(x, u), rtol=1e-12, atol=1e-12)
    # leading axes as the contract allows, and gaps stay gaps without calling the FMU
    np.testing.assert_allclose(model.derivatives(x[:6].reshape(2, 3, 2), u[:6].reshape(2, 3, 1)),
                               twin.derivatives(x[:6], u[:6]).reshape(2, 3, 2), rtol=1e-12)
    u[3] = np.nan
    rates = model.derivatives(x[:5], u[:5])
    assert np.isnan(rates[3]).all() and np.isfinite(np.delete(rates, 3, axis=0)).all()


@needs_compiler
def test_a_row_the_fmu_refuses_is_nan_and_the_residual_says_where(Plant):
    """plant.c returns fmi2Error above 1000 K: that row is NaN, the instance is made afresh
    (FMI 2.0 leaves it undefined after an error) and the rows after it are evaluated; the
    residual's finiteness check then names the state, as for any white box."""
    from graybox.integration import IntegrationError
    from graybox.state_estimation import predict_one_step

    x, u = random_rows(6, 3)
    x[2, 0] = 1500.0
    model = Plant()
    rates = model.derivatives(x, u)
    assert np.isnan(rates[2]).all()
    np.testing.assert_allclose(np.delete(rates, 2, axis=0),
                               TwinPlant().derivatives(np.delete(x, 2, axis=0),
                                                       np.delete(u, 2, axis=0)), rtol=1e-12)
    np.testing.assert_allclose(model.derivatives(x[:2], u[:2]), rates[:2], rtol=1e-12)
    with pytest.raises(IntegrationError, match=r"not finite at 1 of the data's states \(the "
                                               r"first: states \{'heater_T': 1500.0"):
        predict_one_step(model, x, u, DT, Integration("rk4", 2))


@needs_compiler
def test_a_parameter_override_moves_the_derivatives_as_the_formula_says(Plant):
    x, u = random_rows(50, 1)
    base = Plant().derivatives(x, u)
    slow = Plant({"tau": 40.0}).derivatives(x, u)
    # d heater / dt = (0.05 power - heater) / tau: doubling tau halves it; the probe is as before
    np.testing.assert_allclose(slow[:, 0], base[:, 0] / 2, rtol=1e-12)
    np.testing.assert_array_equal(slow[:, 1], base[:, 1])
    # the fixed parameter too (set before initialisation; the FMU refuses it after)
    np.testing.assert_allclose(Plant({"lag": 2.5}).derivatives(x, u)[:, 1], 2 * base[:, 1],
                               rtol=1e-12)
    # a model whose parameters were replaced afterwards (as graybox.row_parameters does on a
    # copy) is instantiated afresh; the original keeps its own
    model = Plant()
    changed = copy.copy(model)
    changed.parameters = {**model.parameters, "tau": 40.0}
    np.testing.assert_allclose(changed.derivatives(x, u), slow, rtol=1e-12)
    np.testing.assert_array_equal(model.derivatives(x, u), base)
    # one parameter set at a time: an array of them (a stacked fleet) is refused
    changed.parameters = {**model.parameters, "tau": np.array([20.0, 40.0])}
    with pytest.raises(ModelSpecError, match="one parameter set at a time"):
        changed.derivatives(x, u)


@needs_compiler
def test_a_baseline_fits_with_the_defaults_and_the_output_residual_is_the_measurement_noise(
        Plant):
    noise = 0.01
    starts = ([4.0, 3.0], [8.0, 6.0], [2.0, 5.0])
    days = [simulate(1800, seed, start, noise) for seed, start in enumerate(starts)]
    model = Plant()
    [fitted] = gb.fit_baselines([gb.FitRequest(model, [frame for frame, _ in days],
                                               asset_id="F-1", seed=0)])
    assert not isinstance(fitted, Exception), fitted
    signature, _ = fitted
    assert signature.model.spec == model.spec() and signature.integration is not None
    # each window's hidden start, estimated from the reading alone, is the simulated one to
    # 4 of its Cramer-Rao bounds (0.0034 and 0.0066 K from the first 900 s at 0.01 K noise)
    for recorded, (_, truth) in zip(signature.hidden_starts, days):
        assert recorded.values["heater_T"] == pytest.approx(truth[0, 0], abs=4 * 0.0034)
        assert recorded.values["probe_T"] == pytest.approx(truth[0, 1], abs=4 * 0.0066)
    # the output residual with the baseline's integrator: the measurement noise, differenced
    # (variance 2 sigma^2, lag-1 correlation -1/2) to the precision of 1,800 samples (~2 %)
    frame, _ = days[0]
    window = estimate_states(model, *window_arrays(model, frame), DT, signature.integration)
    residual = residual_frame(model, frame, integration=signature.integration,
                              window=window)["reading"].to_numpy()
    assert residual.std() == pytest.approx(np.sqrt(2) * noise, rel=0.07)
    assert np.corrcoef(residual[1:], residual[:-1])[0, 1] == pytest.approx(-0.5, abs=0.06)
    # the Python plant gives the same residual through the same code
    twin = residual_frame(TwinPlant(), frame, integration=signature.integration,
                          window=estimate_states(TwinPlant(), *window_arrays(TwinPlant(), frame),
                                                 DT, signature.integration))["reading"]
    np.testing.assert_allclose(residual, twin.to_numpy(), atol=1e-9)


# -- workers: the class holds the path, never a live FMU ------------------------------------------

@needs_compiler
def test_a_worker_rebuilds_the_model_from_its_spec_by_importing_the_class(plant_fmu, tmp_path,
                                                                          monkeypatch):
    shutil.copy(plant_fmu, tmp_path / "plant.fmu")
    (tmp_path / "heated_probe.py").write_text(
        "from graybox.models.fmu import FMUModel\n\n\n"
        "class HeatedProbe(FMUModel):\n"
        "    fmu = 'plant.fmu'   # next to this file\n")
    x, u = random_rows(20, 2)
    expected = TwinPlant({"tau": 30.0}).derivatives(x, u)
    # a fresh process, as a Dask worker or the nightly compute pool: the spec and parameters
    code = ("import sys, json, numpy as np; from graybox.models import load_model; "
            "m = load_model('heated_probe:HeatedProbe', {'tau': 30.0}); "
            "x, u = (np.array(a) for a in json.loads(sys.stdin.read())); "
            "print(json.dumps(m.derivatives(x, u).tolist()))")
    env_path = f"{tmp_path}:{pathlib.Path(gb.__file__).parents[1]}"
    result = subprocess.run([sys.executable, "-c", code], input=json.dumps([x.tolist(),
                                                                          u.tolist()]),
                            capture_output=True, text=True, check=True,
                            env={**os.environ, "PYTHONPATH": env_path})
    np.testing.assert_allclose(np.array(json.loads(result.stdout)), expected, rtol=1e-12)
    # in this process: the record round-trips and a pickle carries the class's name, the
    # parameters and the columns (not the FMU instance)
    monkeypatch.syspath_prepend(str(tmp_path))
    model = load_model("heated_probe:HeatedProbe", {"tau": 30.0}, {"reading": "probe"})
    record = ModelSpec.from_model(model)
    again = ModelSpec.from_dict(record.to_dict()).load(allowed={"heated_probe:HeatedProbe"})
    unpickled = pickle.loads(pickle.dumps(model))
    for other in (again, unpickled, copy.deepcopy(model)):
        assert type(other) is type(model) and other.columns == model.columns
        np.testing.assert_array_equal(other.derivatives(x, u), model.derivatives(x, u))


@needs_compiler
def test_the_docs_examples_load_the_fmu_with_their_fleet_toml_settings(plant_fmu, tmp_path,
                                                                      monkeypatch):
    """docs/models.md's fleet.toml class naming the file, and its subclass, with the test FMU
    as the file."""
    import tomllib

    from graybox.models.fmu_file import fmu_spec

    section = (pathlib.Path(gb.__file__).parents[1] / "docs" / "models.md").read_text() \
        .split("## An FMU as the white box", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    table = tomllib.loads(re.search(r"```toml\n(.*?)```", section, re.S).group(1))
    loop = table["classes"]["loop"]
    assert loop["model"] == "fmu:models/cooling_loop.fmu"
    (tmp_path / "models").mkdir()
    shutil.copy(plant_fmu, tmp_path / "models" / "cooling_loop.fmu")
    # fleet.toml in tmp_path: its relative path is read from there
    by_file = load_model(fmu_spec(loop["model"], tmp_path), loop["parameters"], loop["columns"])
    # the subclass, named as the page says
    assert 'model = "myplants.cooling:CoolingLoop"' in section
    (tmp_path / "cooling.py").write_text(code)
    shutil.copy(plant_fmu, tmp_path / "cooling_loop.fmu")
    monkeypatch.syspath_prepend(str(tmp_path))
    by_class = load_model("cooling:CoolingLoop", loop["parameters"], loop["columns"])
    for model in (by_file, by_class):
        assert model.parameters == {"tau": 25.0, "lag": 5.0}
        assert model.required_columns == ("probe_temp", "power")
        assert model.fmu_variables["heater_T"] == "heater.T"


# -- bad FMUs -----------------------------------------------------------------------------------

#: a valid FMI 1.0 model description of the same plant's states
FMI_1 = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="1.0" modelName="plant" modelIdentifier="plant"
    guid="{8c4e810f-3df3-4a00-8276-176fa3c9128f}" numberOfContinuousStates="2"
    numberOfEventIndicators="0">
  <ModelVariables>
    <ScalarVariable name="heater.T" valueReference="0"><Real start="0"/></ScalarVariable>
  </ModelVariables>
</fmiModelDescription>
"""


@needs_compiler
@pytest.mark.parametrize("change, message", [
    (lambda d: FMI_1, "is FMI 1.0; only FMI 2.0 model exchange is supported"),
    (lambda d: d.replace("<ModelExchange", "<CoSimulation"),
     "is not for model exchange \\(it is for co-simulation only"),
    (lambda d: d.replace("<ModelExchange modelIdentifier=\"plant\"/>", ""),
     "is not for model exchange; the white box needs the derivatives at any state"),
    (lambda d: d.replace("<Derivatives>", "<Derivatives>\n<Unknown index=\"1\"/>"),
     r"its <Derivatives> list \['heater.T'\], which are not the derivative of a state"),
    (lambda d: d.replace('guid="{8c4e', 'guid="{0000'),
     "fmi2Instantiate failed .* is its GUID the one its binary was built with"),
], ids=["fmi 1", "co-simulation", "neither", "not a derivative", "guid"])
def test_a_bad_fmu_is_an_error_naming_the_file_and_what_to_do(tmp_path, change, message):
    path = build_fmu(tmp_path, change(DESCRIPTION))
    with pytest.raises(ModelSpecError, match=message) as error:
        fmu_class(path)()
    assert str(path) in str(error.value)


@needs_compiler
def test_an_fmu_without_this_platforms_binary_or_with_nan_derivatives_is_refused(tmp_path,
                                                                                Plant):
    windows_only = build_fmu(tmp_path / "win", binary="binaries/win64/plant.dll")
    with pytest.raises(ModelSpecError, match=r"has no binary for linux64 \(it has: win64\); "
                                             r"export it with a linux64 binary"):
        fmu_class(windows_only)
    # lag = 0: der(probe.T) = (heater - probe) / 0 is NaN at the FMU's own start (0, 0)
    with pytest.raises(ModelSpecError, match=r"its derivatives are \[0.0, nan\] at its own start "
                                             r"state \[0.0, 0.0\]"):
        Plant({"lag": 0.0})
    # a parameter the FMU itself refuses (fmi2SetReal returns fmi2Error), with its message
    with pytest.raises(ModelSpecError, match=r"fmi2SetReal of the parameters failed \(status "
                                             r"error\) with the parameters \[-1.0, 5.0\]; the "
                                             r"FMU logged: \[error\] tau must be > 0"):
        Plant({"tau": -1.0})
    with pytest.raises(ModelSpecError, match="unknown parameter 'gain'"):
        Plant({"gain": 0.1})
    with pytest.raises(ModelSpecError, match=r"Missing.fmu: no file .*missing.fmu"):
        fmu_class(tmp_path / "missing.fmu", "Missing")
    (tmp_path / "notes.fmu").write_text("not a zip archive")
    with pytest.raises(ModelSpecError, match=r"cannot read its modelDescription.xml .*; is it "
                                             r"an FMU\?"):
        fmu_class(tmp_path / "notes.fmu")


def test_without_fmpy_an_fmu_model_says_how_to_install_it():
    code = ("import sys; sys.modules['fmpy'] = None\n"
            "from graybox.models.fmu import FMUModel\n"
            "try:\n"
            "    type('P', (FMUModel,), {'fmu': '/nowhere/p.fmu'})\n"
            "except Exception as error:\n"
            "    print(type(error).__name__, error)\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True, cwd=pathlib.Path(gb.__file__).parents[1])
    assert result.stdout.startswith("ModelSpecError FMU models need the fmpy package")
    assert "pip install 'fleet-health[fmu]'" in result.stdout


@needs_compiler
def test_a_record_remembers_its_fmus_guid_and_a_replaced_fmu_is_refused(plant_fmu,
                                                                       monkeypatch):
    from graybox.exceptions import ModelChangedError

    recorded = fmu_class(plant_fmu, "RecordedPlant")    # importable by its spec
    monkeypatch.setattr(sys.modules[__name__], "RecordedPlant", recorded, raising=False)
    guid = fmpy.read_model_description(str(plant_fmu)).guid
    record = ModelSpec.from_model(recorded())
    assert record.fingerprint == f"fmi2 guid {guid}"
    again = ModelSpec.from_dict(json.loads(json.dumps(record.to_dict())))
    assert again == record and again.load().fingerprint() == record.fingerprint
    # the class now reads a re-exported FMU (another GUID): the record's fit is not its
    fitted = ModelSpec(record.spec, record.parameters, record.columns,
                       "fmi2 guid {0000e810-0000-4a00-8276-176fa3c9128f}")
    with pytest.raises(ModelChangedError, match="was fitted as .* replaced or re-exported"):
        fitted.load()
    # a record written before fingerprints existed loads as it did
    older = {k: v for k, v in record.to_dict().items() if k != "fingerprint"}
    assert ModelSpec.from_dict(older).load().fingerprint() == record.fingerprint


def test_a_python_white_box_records_no_fingerprint():
    record = ModelSpec.from_model(TwinPlant())
    assert record.fingerprint is None and "fingerprint" not in record.to_dict()


@needs_compiler
def test_instances_made_in_many_threads_at_once_leave_the_working_directory_as_it_was(Plant):
    """FMPy changes the working directory while it loads an FMU's library: loads at once in
    several threads (a thread task runner) must not leave it changed."""
    import concurrent.futures

    before = os.getcwd()
    with concurrent.futures.ThreadPoolExecutor(8) as pool:
        models = list(pool.map(lambda k: Plant({"tau": 20.0 + k}), range(32)))
        list(pool.map(lambda m: m.derivatives(np.zeros((4, 2)), np.ones((4, 1))), models))
    assert os.getcwd() == before
