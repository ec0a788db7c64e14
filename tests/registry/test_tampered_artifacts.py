"""Tampered artifacts: each is refused for its own asset, naming asset, version, file and
field, before anything in it is unpickled or imported; nothing else is lost.

Every tampered version here is registered with a manifest and a digest tag that match its
files (see ``tampering.py``), so only the checks of the contents stand between it and a run.
Each scenario is its own ``test_fault_*`` function (part of issue 13's fault matrix).
"""
from __future__ import annotations

import math
import pickle
import subprocess
import sys
import urllib.parse

import mlflow
import pandas as pd
import pytest

from graybox.exceptions import ArtifactError, ModelSpecError
from graybox.models import LangevinShaft
from registry.exceptions import UnusableBaselineError
from store_copies import checkpointed, copy_store
from tampering import (edit_json, model_path, move_alias, snapshot, tampered_version,
                       write_bytes)

#: what fleet.toml would configure for these assets (as written, and as the class's spec)
MODELS = frozenset({"graybox.models:LangevinShaft", LangevinShaft.spec()})
ASSETS = ("T-01", "T-02")
ZEN = "Beautiful is better than ugly"
WATERMARK = pd.Timestamp("2026-01-06", tz="UTC")


class Boom:
    """Unpickling this creates ``marker``: proof of whether anything was unpickled."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (open, (str(self.marker), "w"))


@pytest.fixture(scope="module")
def recorded(tmp_path_factory, template_db, fits):
    """A store (recorded once) where T-01 and T-02 have a promoted calibrated baseline (v1),
    a nightly candidate (v2) and a watermark each."""
    from registry import Registry

    directory = tmp_path_factory.mktemp("tampered-fleet")
    registry = Registry(copy_store(template_db, directory), user="tester")
    day0 = pd.Timestamp("2026-01-01", tz="UTC")
    for asset in ASSETS:
        registry.record_fit(asset, "turbine", fits.baseline, role="baseline",
                            calibration=fits.calibration, window_start=day0,
                            window_end=day0 + pd.Timedelta(days=4), data_hash="healthy",
                            plots=False)
        registry.promote(asset, 1, reason="initial")
        registry.record_fit(asset, "turbine", fits.candidate, role="candidate", drift=fits.drift,
                            window_start=day0 + pd.Timedelta(days=5),
                            window_end=day0 + pd.Timedelta(days=6), data_hash="night",
                            plots=False)
        registry.commit_watermark(asset, WATERMARK)
    return checkpointed(directory / "mlflow.db")


@pytest.fixture
def fleet(recorded, tmp_path):
    """A fresh copy of the recorded store (its artifacts are shared and never edited)."""
    from registry import Registry

    return Registry(copy_store(recorded, tmp_path / "store"), user="tester")


def tamper_baseline(registry, tmp_path, edit, asset="T-01") -> int:
    """An edited copy of the asset's baseline v1, registered and made the baseline by hand."""
    version = tampered_version(registry, asset, 1, tmp_path, edit)
    move_alias(registry, asset, "baseline", version)
    return version


def assert_refused(registry, fits, match: str, version=None) -> UnusableBaselineError:
    """T-01's reference is refused with ``match``; T-02's still loads, and nothing moved."""
    before = snapshot(registry, ASSETS)
    with pytest.raises(UnusableBaselineError, match=match) as refused:
        registry.reference("T-01", version, models=MODELS)
    other = registry.reference("T-02", models=MODELS)
    assert other.version == 1 and other.signature == fits.baseline
    assert other.calibration == fits.calibration
    assert snapshot(registry, ASSETS) == before
    assert registry.watermark("T-01") == registry.watermark("T-02") == WATERMARK
    return refused.value


def set_value(path: tuple, value):
    """An edit_json change: set the value at a path of keys and indices."""
    def change(data: dict) -> None:
        target = data
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value
    return change


# -- pickles ---------------------------------------------------------------------------------

@pytest.mark.parametrize("file_name, refusal", [
    ("signature.json", r"signature\.json: signature is not valid JSON"),
    ("calibration.json", r"calibration\.json: calibration is not valid JSON"),
    ("model.pkl", r"model\.pkl: unexpected file, not listed in manifest\.json"),
], ids=["in_place_of_signature_json", "in_place_of_calibration_json",
        "file_added_beside_the_json"])
def test_fault_pickle(fleet, fits, tmp_path, file_name, refusal):
    marker = tmp_path / "executed"
    version = tamper_baseline(fleet, tmp_path, write_bytes(file_name, pickle.dumps(Boom(marker))))
    error = assert_refused(fleet, fits, rf"asset 'T-01' version {version}: {refusal}")
    assert "fleet-health baseline promote T-01 --version 1" in str(error)
    assert not marker.exists()


def test_fault_pickled_python_model_mlflow_unpickles_the_registry_refuses(fleet, fits,
                                                                          tmp_path):
    """What docs/baselines.md says: MLflow's own loader runs a pickled model a tampered store holds;
    the registry's loader refuses it before MLflow sees it."""
    import cloudpickle
    import yaml

    marker = tmp_path / "executed"

    def pickled_model(bundle):
        root = bundle.parents[1]
        (root / "python_model.pkl").write_bytes(pickle.dumps(Boom(marker)))
        description = yaml.safe_load((root / "MLmodel").read_text())
        flavor = description["flavors"]["python_function"]
        flavor.update(loader_module="mlflow.pyfunc.model", python_model="python_model.pkl",
                      cloudpickle_version=cloudpickle.__version__)
        flavor.pop("data", None)
        (root / "MLmodel").write_text(yaml.safe_dump(description))
    version = tamper_baseline(fleet, tmp_path, pickled_model)
    assert_refused(fleet, fits, rf"asset 'T-01' version {version}: python_model\.pkl: "
                                r"unexpected file in the model")
    with pytest.raises(ArtifactError, match="python_model.pkl: unexpected file"):
        fleet.load_pyfunc("T-01", version)
    assert not marker.exists()
    # the object it unpickled (the file Boom opened) is no PythonModel...
    with pytest.raises(AttributeError, match="load_context"):
        mlflow.pyfunc.load_model(str(model_path(fleet, "T-01", version)))
    assert marker.exists()                  # ...but its code already ran


# -- shapes ----------------------------------------------------------------------------------

def test_fault_input_weights_shape_disagrees_with_structure(fleet, fits, tmp_path):
    def drop_a_delay(data):
        network = data["channels"][0]["nonlinear"]
        network["input_weights"] = [row[:-1] for row in network["input_weights"]]
    version = tamper_baseline(fleet, tmp_path, edit_json("signature.json", drop_a_delay))
    channel = fits.baseline.channels[0]
    assert_refused(fleet, fits, rf"asset 'T-01' version {version}: signature\.json: Signature "
                                rf"channel '{channel.channel}': nonlinear\.input_weights must "
                                rf"have shape \(hidden_units, embedding_dim\) = "
                                rf"\({channel.structure.hidden_units}, "
                                rf"{channel.structure.embedding_dim}\)")


def test_fault_output_weights_disagree_with_hidden_units(fleet, fits, tmp_path):
    def one_more_unit(data):
        data["channels"][0]["nonlinear"]["output_weights"].append(0.5)
    version = tamper_baseline(fleet, tmp_path, edit_json("signature.json", one_more_unit))
    units = fits.baseline.channels[0].structure.hidden_units
    assert_refused(fleet, fits, rf"version {version}: signature\.json: .*nonlinear\."
                                rf"output_weights must have hidden_units = {units} items, got "
                                rf"{units + 1}")


def test_fault_ar_coefficients_disagree_with_ar_order(fleet, fits, tmp_path):
    order = fits.baseline.channels[0].structure.ar_order
    version = tamper_baseline(fleet, tmp_path, edit_json(
        "signature.json", set_value(("channels", 0, "structure", "ar_order"), order + 3)))
    assert_refused(fleet, fits, rf"version {version}: signature\.json: .*linear\.coefficients "
                                rf"and standard_errors must have ar_order = {order + 3} items")


def test_fault_weights_file_disagrees_with_signature_json(fleet, fits, tmp_path):
    def scale_weights(data):
        network = data["channels"][0]["nonlinear"]
        network["output_weights"] = [2 * w for w in network["output_weights"]]
    version = tamper_baseline(fleet, tmp_path, edit_json("signature.json", scale_weights))
    channel = fits.baseline.channels[0].channel
    assert_refused(fleet, fits, rf"version {version}: weights\.safetensors: tensor "
                                rf"'{channel}\.nonlinear\.output_weights' differs")


# -- non-finite numbers ----------------------------------------------------------------------

def test_fault_nan_in_signature(fleet, fits, tmp_path):
    version = tamper_baseline(fleet, tmp_path, edit_json(
        "signature.json", set_value(("channels", 0, "noise", "variance"), math.nan)))
    assert_refused(fleet, fits, rf"asset 'T-01' version {version}: signature\.json: "
                                r"NoiseTier\.variance must be a finite number, got nan")


def test_fault_infinity_in_signature_structure(fleet, fits, tmp_path):
    version = tamper_baseline(fleet, tmp_path, edit_json(
        "signature.json", set_value(("channels", 0, "structure", "scale"), math.inf)))
    assert_refused(fleet, fits, rf"version {version}: signature\.json: ChannelStructure\.scale "
                                r"must be a finite number, got inf")


def test_fault_nan_weight_in_signature(fleet, fits, tmp_path):
    def poison(data):
        data["channels"][0]["nonlinear"]["input_weights"][0][0] = math.nan
    version = tamper_baseline(fleet, tmp_path, edit_json("signature.json", poison))
    assert_refused(fleet, fits, rf"version {version}: signature\.json: NonlinearTier\."
                                r"input_weights\[0\]\[0\] must be a finite number, got nan")


def test_fault_nan_epsilon_in_calibration(fleet, fits, tmp_path):
    version = tamper_baseline(fleet, tmp_path, edit_json(
        "calibration.json", set_value(("thresholds", 0, "epsilon"), math.nan)))
    error = assert_refused(fleet, fits, rf"asset 'T-01' version {version}: calibration\.json: "
                                        r"TierThreshold\.epsilon must be a finite number, got "
                                        r"nan")
    assert "fleet-health baseline promote T-01 --version 1" in str(error)


def test_fault_infinite_epsilon_in_calibration(fleet, fits, tmp_path):
    version = tamper_baseline(fleet, tmp_path, edit_json(
        "calibration.json", set_value(("thresholds", 2, "epsilon"), math.inf)))
    assert_refused(fleet, fits, rf"version {version}: calibration\.json: TierThreshold\.epsilon "
                                r"must be a finite number, got inf")


def test_fault_negative_epsilon_in_calibration(fleet, fits, tmp_path):
    version = tamper_baseline(fleet, tmp_path, edit_json(
        "calibration.json", set_value(("thresholds", 1, "epsilon"), -1.0)))
    entry = fits.calibration.thresholds[1]
    assert_refused(fleet, fits, rf"version {version}: calibration\.json: Calibration threshold "
                                rf"of channel '{entry.channel}', tier '{entry.tier}': epsilon "
                                r"must be >= 0, got -1\.0")


def test_fault_calibration_missing_a_threshold(fleet, fits, tmp_path):
    def drop(data):
        del data["thresholds"][0]
    version = tamper_baseline(fleet, tmp_path, edit_json("calibration.json", drop))
    entry = fits.calibration.thresholds[0]
    assert_refused(fleet, fits, rf"version {version}: calibration\.json: thresholds must cover "
                                rf"exactly the signature's channels and tiers: missing "
                                rf"\[\('{entry.channel}', '{entry.tier}'\)\]")


# -- what gets imported ----------------------------------------------------------------------

def test_fault_spec_naming_another_module_is_never_imported(fleet, fits, tmp_path, capfd):
    assert "this" not in sys.modules
    version = tamper_baseline(fleet, tmp_path, edit_json(
        "signature.json", set_value(("model", "spec"), "this:Zen")))
    assert_refused(fleet, fits, rf"asset 'T-01' version {version}: signature\.json: model "
                                r"'this:Zen' is not the asset's configured model "
                                r"\('graybox\.models\.gas_turbine:LangevinShaft' or "
                                r"'graybox\.models:LangevinShaft'\); refusing to "
                                r"import it")
    # without a configured model the record still chooses nothing: neither the registry's
    # loader, nor its record, nor MLflow's own loader (which calls registry.pyfunc) imports it
    stored = fleet.load_version("T-01", version)
    with pytest.raises(ModelSpecError, match="'this:Zen': its module is not imported"):
        stored.signature.model.load()
    with pytest.raises(ModelSpecError, match="'this:Zen' is not an allowed model"):
        stored.signature.model.load(MODELS)
    with pytest.raises(ModelSpecError, match="'this:Zen'"):
        fleet.load_pyfunc("T-01", version)
    with pytest.raises(ModelSpecError, match="'this:Zen'"):
        mlflow.pyfunc.load_model(str(model_path(fleet, "T-01", version)))
    assert "this" not in sys.modules
    out = capfd.readouterr().out
    assert ZEN not in out and out == ""


def test_fault_spec_naming_another_model_class(fleet, fits, tmp_path):
    version = tamper_baseline(fleet, tmp_path, edit_json(
        "signature.json", set_value(("model", "spec"),
                                    "graybox.models.gas_turbine:GasTurbineShaft")))
    assert_refused(fleet, fits, rf"asset 'T-01' version {version}: signature\.json: model "
                                r"'graybox\.models\.gas_turbine:GasTurbineShaft' is not the "
                                r"asset's configured model")


def test_fault_zen_spec_in_a_fresh_process_prints_nothing(fleet, tmp_path):
    """MLflow's own loader in a new interpreter: the record's module is not imported."""
    version = tampered_version(fleet, "T-01", 1, tmp_path, edit_json(
        "signature.json", set_value(("model", "spec"), "this:Zen")))
    code = ("import mlflow.pyfunc, sys\n"
            "try:\n"
            f"    mlflow.pyfunc.load_model({str(model_path(fleet, 'T-01', version))!r})\n"
            "except Exception as error:\n"
            "    print('refused:', type(error).__name__, file=sys.stderr)\n"
            "print('this' in sys.modules, file=sys.stderr)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.stdout == ""
    assert "refused: ModelSpecError" in done.stderr and "False" in done.stderr


# -- where the artifacts are -----------------------------------------------------------------

def test_fault_source_with_dotdot_escapes_the_store(fleet, fits, tmp_path):
    (tmp_path / "elsewhere").mkdir()
    copy = tmp_path / "tampered-T-01-v1"
    escaping = f"file://{tmp_path}/elsewhere/../{copy.name}"
    version = tampered_version(fleet, "T-01", 1, tmp_path, lambda bundle: None,
                               source=escaping)
    move_alias(fleet, "T-01", "baseline", version)
    assert_refused(fleet, fits, rf"asset 'T-01' version {version}: source '.*elsewhere/\.\./"
                                r"tampered-T-01-v1' leaves the artifact store")


def test_fault_percent_encoded_dotdot_source(fleet, fits, tmp_path):
    (tmp_path / "elsewhere").mkdir()
    escaping = f"file://{urllib.parse.quote(str(tmp_path))}/elsewhere/%2e%2e/tampered-T-01-v1"
    version = tampered_version(fleet, "T-01", 1, tmp_path, lambda bundle: None,
                               source=escaping)
    move_alias(fleet, "T-01", "baseline", version)
    assert_refused(fleet, fits, rf"version {version}: source .* leaves the artifact store")


# -- unusable references ---------------------------------------------------------------------

def test_fault_baseline_alias_on_uncalibrated_version(fleet, fits):
    move_alias(fleet, "T-01", "baseline", 2)           # the nightly candidate, by hand
    error = assert_refused(fleet, fits, r"asset 'T-01' version 2 has no calibration \(a "
                                        r"candidate fit\): its zeta has no epsilon, so nothing "
                                        r"could alarm")
    assert "fix: fleet-health baseline promote T-01 --version 1 --reason" in str(error)
    assert "fleet-health baseline fit T-01" in str(error)


def test_fault_named_reference_without_calibration(fleet, fits):
    error = assert_refused(fleet, fits, r"asset 'T-01' version 2 has no calibration", version=2)
    assert "--version 1" in str(error)


def test_untampered_reference_loads(fleet, fits):
    loaded = fleet.reference("T-01", models=MODELS)
    assert loaded.version == 1 and loaded.signature == fits.baseline
    assert loaded.calibration == fits.calibration
    assert type(loaded.signature.model.load(MODELS)) is LangevinShaft
    with pytest.raises(UnusableBaselineError, match="is not the asset's configured model"):
        fleet.reference("T-01", models={"graybox.models:GasTurbineShaft"})
    with pytest.raises(ArtifactError, match="is not the asset's configured model"):
        fleet.load_version("T-01", 1, models={"graybox.models:GasTurbineShaft"})
