"""fleet.toml naming an FMU file as a class's white box, ``model = "fmu:<path>"``: the path
read from the file's directory, the class's other keys as for a Python white box, and errors
that name the class's key, the file and what to do."""
from __future__ import annotations

import json
import re
import sys

import pytest

from flows.config import ConfigError, load_config
from flows.discovery import AssetRef
from flows.pipeline import configured_models
from flowtest_fmu import plant_fmu

PLANT = plant_fmu()
pytestmark = PLANT.needs_compiler


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    return PLANT.build_fmu(tmp_path_factory.mktemp("fmu_config"))


def site(tmp_path, built, model: str, extra: str = ""):
    """``tmp_path/site/fleet.toml`` with a pump class of ``model``; the FMU at
    ``site/models/pump.fmu``."""
    (tmp_path / "site" / "models").mkdir(parents=True, exist_ok=True)
    fmu = tmp_path / "site" / "models" / "pump.fmu"
    if not fmu.exists():
        fmu.write_bytes(built.read_bytes())
    config = tmp_path / "site" / "fleet.toml"
    config.write_text(f'[classes.pump]\nmodel = "{model}"\nassets = ["P-*"]\n{extra}')
    return config, fmu.resolve()


def test_the_path_is_read_from_the_files_directory_and_the_class_keys_apply(tmp_path, built,
                                                                           monkeypatch):
    monkeypatch.chdir(tmp_path)            # not the file's directory
    config, fmu = site(tmp_path, built, "fmu:models/pump.fmu",
                       'parameters = { tau = 25.0 }\ncolumns = { reading = "probe_temp" }\n'
                       'estimate = ["tau"]\n')
    loaded = load_config(config)
    pump = loaded.classes["pump"]
    assert pump.model == f"fmu:{fmu}" and pump.estimate == ("tau",)
    model = pump.load_model()
    assert model.spec() == pump.model and model.fingerprint() == f"fmi2 guid {PLANT.GUID}"
    assert model.parameters == {"tau": 25.0, "lag": 5.0}
    assert model.required_columns == ("probe_temp", "power")
    assert configured_models(loaded, AssetRef("P-001", "pump")) == {pump.model}
    # absolute, and ~, name the same file
    for written in (str(fmu), "~/models/pump.fmu"):
        monkeypatch.setenv("HOME", str(tmp_path / "site"))
        assert load_config(site(tmp_path, built, f"fmu:{written}")[0]).classes["pump"].model \
            == pump.model


@pytest.mark.parametrize("model, extra, where, message", [
    ("fmu:models/gone.fmu", "", "model",
     r"FMU {site}/models/gone.fmu: no such file \('models/gone.fmu' is read from the "
     r"directory of fleet.toml\)"),
    ("fmu:models/notes.fmu", "", "model",
     r"FMU {site}/models/notes.fmu: cannot read its modelDescription.xml .*; is it an FMU\?"),
    ("fmu:", "", "model", r"model spec 'fmu:' names no file"),
    ("fmu:models/pump.fmu", "parameters = { gain = 0.1 }\n", "parameters",
     r"fmu:{site}/models/pump.fmu: unknown parameter 'gain'; known parameters: lag, tau"),
    ("fmu:models/pump.fmu", "parameters = { tau = -1.0 }\n", "parameters",
     r"FMU {site}/models/pump.fmu: fmi2SetReal of the parameters failed .*tau must be > 0"),
    ("fmu:models/pump.fmu", 'columns = { temperature = "t" }\n', "columns",
     r"fmu:{site}/models/pump.fmu: column map names 'temperature', which is not a model "
     r"variable; variables: reading, power"),
    ("fmu:models/pump.fmu", 'estimate = ["gain"]\n', "estimate[0]",
     r"'gain' is not a number parameter of fmu:{site}/models/pump.fmu; they are: tau, lag"),
], ids=["missing", "not an fmu", "no path", "parameter", "refused parameter", "column",
        "estimate"])
def test_errors_name_the_class_key_and_the_file(tmp_path, built, model, extra, where, message):
    config, fmu = site(tmp_path, built, model, extra)
    (fmu.parent / "notes.fmu").write_text("not a zip archive")
    with pytest.raises(ConfigError) as error:
        load_config(config)
    expected = re.escape(f"fleet.toml: classes.pump.{where}: ") + message.format(
        site=fmu.parent.parent)
    assert re.match(expected, str(error.value)), str(error.value)


def test_without_fmpy_the_check_names_the_class_the_file_and_the_extra(tmp_path, built, capsys,
                                                                      monkeypatch):
    from flows.cli import main

    config, fmu = site(tmp_path, built, "fmu:models/pump.fmu")
    monkeypatch.setitem(sys.modules, "fmpy", None)
    status = main(["--config", str(config), "check", "--json"])
    assert status == 2
    (finding,) = json.loads(capsys.readouterr().out)["findings"]
    assert finding["area"] == "config"
    assert finding["detail"].startswith(f"fleet.toml: classes.pump.model: FMU {fmu}: FMU models "
                                        f"need the fmpy package")
    assert finding["detail"].endswith("install it with: pip install 'fleet-health[fmu]'")
