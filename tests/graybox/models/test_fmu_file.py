"""An FMU named by its file, ``fmu:<path>`` (graybox.models.fmu_file): the white box of the
two-line subclass without the subclass, one class per file and process, a record that holds
the path and the GUID, and a spec that a worker, a pickle and a record rebuild it from."""
from __future__ import annotations

import copy
import json
import os
import pickle
import shutil
import sys

import numpy as np
import pytest

from graybox.exceptions import ModelChangedError, ModelSpecError
from graybox.models import ModelSpec, load_model
from graybox.models.base import model_class
from graybox.models.fmu_file import FMUFileModel, file_model_class, fmu_spec, made
from plant_fmu import GUID, TwinPlant, build_fmu, needs_compiler

pytestmark = needs_compiler
OTHER_GUID = "{0000e810-0000-4a00-8276-176fa3c9128f}"


@pytest.fixture(scope="module")
def plant_fmu(tmp_path_factory):
    return build_fmu(tmp_path_factory.mktemp("fmu_file"))


def rows(n: int = 40, seed: int = 5):
    rng = np.random.default_rng(seed)
    return rng.normal(5.0, 4.0, (n, 2)), rng.uniform(0.0, 200.0, (n, 1))


def test_the_file_is_the_white_box_and_its_spec_is_the_absolute_path(plant_fmu, monkeypatch):
    monkeypatch.chdir(plant_fmu.parent.parent)
    relative = f"fmu:{plant_fmu.parent.name}/plant.fmu"
    model = load_model(relative, {"tau": 30.0}, {"reading": "probe"})
    assert isinstance(model, FMUFileModel)
    assert model.spec() == f"fmu:{plant_fmu}" == fmu_spec(relative)
    assert model.states == ("heater_T", "probe_T") and model.required_columns == ("probe", "power")
    assert model.parameters == {"tau": 30.0, "lag": 5.0} and model.positive == ("tau",)
    x, u = rows()
    np.testing.assert_allclose(model.derivatives(x, u), TwinPlant({"tau": 30.0}).derivatives(x, u),
                               rtol=1e-12)
    # one class per file: the absolute spec, the relative one and ~ all find it
    monkeypatch.setenv("HOME", str(plant_fmu.parent))
    assert type(load_model("fmu:~/plant.fmu")) is type(model) is model_class(model.spec())
    assert type(model).__name__ == "plant.fmu" and made(model.spec())


def test_a_pickle_a_copy_and_a_record_rebuild_the_same_white_box(plant_fmu):
    model = load_model(f"fmu:{plant_fmu}", {"tau": 30.0}, {"reading": "probe"})
    record = ModelSpec.from_model(model)
    assert (record.spec, record.fingerprint) == (f"fmu:{plant_fmu}", f"fmi2 guid {GUID}")
    again = ModelSpec.from_dict(json.loads(json.dumps(record.to_dict())))
    x, u = rows()
    expected = model.derivatives(x, u)
    for other in (again.load(allowed={record.spec}), again.load(),   # made in this process
                  pickle.loads(pickle.dumps(model)), copy.deepcopy(model)):
        assert type(other) is type(model) and other.columns == model.columns
        assert other.parameters == model.parameters
        np.testing.assert_array_equal(other.derivatives(x, u), expected)


def test_a_record_alone_loads_no_file_this_process_has_not_loaded(plant_fmu, tmp_path):
    copied = tmp_path / "copy.fmu"           # as a fresh worker sees any file: not made yet
    shutil.copy(plant_fmu, copied)
    record = ModelSpec(f"fmu:{copied}", {"tau": 30.0})
    assert not made(record.spec)
    with pytest.raises(ModelSpecError, match=f"model spec 'fmu:{copied}': this process has not "
                                             f"loaded that FMU"):
        record.load()
    assert not made(record.spec)
    # the spec alone rebuilds it, as a worker does (load_model; a pickle's unpickling)
    x, u = rows()
    np.testing.assert_allclose(record.load(allowed={record.spec}).derivatives(x, u),
                               TwinPlant({"tau": 30.0}).derivatives(x, u), rtol=1e-12)
    assert made(record.spec) and record.load().spec() == record.spec


def test_a_file_replaced_by_another_fmu_is_read_afresh_and_an_old_record_refused(tmp_path):
    path = build_fmu(tmp_path / "site")
    record = ModelSpec.from_model(load_model(f"fmu:{path}"))
    first = file_model_class(record.spec)
    # re-exported under another GUID, to the same path
    replaced = build_fmu(tmp_path / "export", guid=OTHER_GUID)
    os.replace(replaced, path)
    second = file_model_class(record.spec)
    assert second is not first and second.fingerprint() == f"fmi2 guid {OTHER_GUID}"
    with pytest.raises(ModelChangedError, match=r"was fitted as 'fmi2 guid \{8c4e.* and is now "
                                                r"'fmi2 guid \{0000e810"):
        record.load(allowed={record.spec})


def test_a_missing_file_a_file_that_is_no_fmu_and_no_fmpy_name_the_file(tmp_path, monkeypatch):
    with pytest.raises(ModelSpecError, match=f"FMU {tmp_path / 'gone.fmu'}: no such file"):
        load_model(f"fmu:{tmp_path / 'gone.fmu'}")
    (tmp_path / "notes.fmu").write_text("not a zip archive")
    with pytest.raises(ModelSpecError, match=f"FMU {tmp_path / 'notes.fmu'}: cannot read its "
                                             f"modelDescription.xml .*; is it an FMU\\?"):
        load_model(f"fmu:{tmp_path / 'notes.fmu'}")
    with pytest.raises(ModelSpecError, match="model spec 'fmu: ' names no file"):
        load_model("fmu: ")
    monkeypatch.setitem(sys.modules, "fmpy", None)
    with pytest.raises(ModelSpecError, match=f"FMU {tmp_path / 'notes.fmu'}: FMU models need the "
                                             f"fmpy package .*pip install 'fleet-health\\[fmu\\]'"):
        load_model(f"fmu:{tmp_path / 'notes.fmu'}")
