"""The signature bundle: exact round trip, and every kind of tampering refused."""
from __future__ import annotations

import json
import pickle

import numpy as np
import pytest
from safetensors.numpy import load as load_tensors
from safetensors.numpy import save as save_tensors

from graybox.exceptions import ArtifactError
from registry.write.artifacts import (CALIBRATION_FILE, MANIFEST_FILE, SIGNATURE_FILE, WEIGHTS_FILE,
                                read_bundle, sha256_bytes, weight_tensors, write_bundle)


class Boom:
    """Unpickling this would create ``marker``: proof that nothing was unpickled."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (open, (str(self.marker), "w"))


def test_bundle_round_trip_is_exact(tmp_path, fits):
    digest = write_bundle(tmp_path / "b", fits.baseline, fits.calibration, "T-01")
    bundle = read_bundle(tmp_path / "b", expected_manifest_sha256=digest, expected_asset_id="T-01")
    assert bundle.signature == fits.baseline
    assert bundle.calibration == fits.calibration
    assert bundle.manifest_sha256 == digest
    stored = load_tensors((tmp_path / "b" / WEIGHTS_FILE).read_bytes())
    for name, values in weight_tensors(fits.baseline).items():
        np.testing.assert_array_equal(stored[name], values)
    assert any(name.endswith("nonlinear.input_weights") for name in stored)


def test_candidate_bundle_has_no_calibration(tmp_path, fits):
    write_bundle(tmp_path / "b", fits.candidate)
    assert not (tmp_path / "b" / CALIBRATION_FILE).exists()
    assert read_bundle(tmp_path / "b").calibration is None


def test_pickle_in_place_of_the_json_is_refused_and_never_executed(tmp_path, fits):
    write_bundle(tmp_path / "b", fits.baseline, fits.calibration)
    marker = tmp_path / "executed"
    (tmp_path / "b" / SIGNATURE_FILE).write_bytes(pickle.dumps(Boom(marker)))
    with pytest.raises(ArtifactError, match="signature.json: sha256 does not match"):
        read_bundle(tmp_path / "b")
    # even with a manifest rewritten to match, the JSON parser refuses the pickle bytes
    manifest = json.loads((tmp_path / "b" / MANIFEST_FILE).read_text())
    data = (tmp_path / "b" / SIGNATURE_FILE).read_bytes()
    manifest["files"][SIGNATURE_FILE] = {"sha256": sha256_bytes(data), "bytes": len(data)}
    (tmp_path / "b" / MANIFEST_FILE).write_text(json.dumps(manifest))
    with pytest.raises(ArtifactError, match="signature.json: .*not valid JSON"):
        read_bundle(tmp_path / "b")
    assert not marker.exists()


def test_extra_pickle_file_is_refused(tmp_path, fits):
    write_bundle(tmp_path / "b", fits.baseline, fits.calibration)
    (tmp_path / "b" / "signature.pkl").write_bytes(pickle.dumps(Boom(tmp_path / "executed")))
    with pytest.raises(ArtifactError, match="signature.pkl: unexpected file"):
        read_bundle(tmp_path / "b")
    assert not (tmp_path / "executed").exists()


@pytest.mark.parametrize("name", [SIGNATURE_FILE, WEIGHTS_FILE, MANIFEST_FILE, CALIBRATION_FILE])
def test_missing_files_are_named(tmp_path, fits, name):
    write_bundle(tmp_path / "b", fits.baseline, fits.calibration)
    (tmp_path / "b" / name).unlink()
    with pytest.raises(ArtifactError, match=f"{name}: missing"):
        read_bundle(tmp_path / "b", where="asset 'T-01' version 3")


def test_missing_bundle_directory(tmp_path):
    with pytest.raises(ArtifactError, match="not found"):
        read_bundle(tmp_path / "nowhere")


def test_weights_differing_from_the_json_are_refused(tmp_path, fits):
    write_bundle(tmp_path / "b", fits.baseline)
    tensors = weight_tensors(fits.baseline)
    name = next(n for n in tensors if n.endswith("output_weights"))
    tensors[name] = tensors[name] + 1e-9
    data = save_tensors(tensors)
    (tmp_path / "b" / WEIGHTS_FILE).write_bytes(data)
    manifest = json.loads((tmp_path / "b" / MANIFEST_FILE).read_text())
    manifest["files"][WEIGHTS_FILE] = {"sha256": sha256_bytes(data), "bytes": len(data)}
    (tmp_path / "b" / MANIFEST_FILE).write_text(json.dumps(manifest))
    with pytest.raises(ArtifactError, match=f"tensor '{name}' differs"):
        read_bundle(tmp_path / "b")


def test_rewritten_manifest_is_caught_by_the_recorded_digest(tmp_path, fits):
    digest = write_bundle(tmp_path / "b", fits.baseline)
    manifest = json.loads((tmp_path / "b" / MANIFEST_FILE).read_text())
    (tmp_path / "b" / MANIFEST_FILE).write_text(json.dumps(manifest, indent=1))
    read_bundle(tmp_path / "b")   # self-consistent...
    with pytest.raises(ArtifactError, match="digest recorded in the registry"):
        read_bundle(tmp_path / "b", expected_manifest_sha256=digest)


def test_manifest_may_not_list_other_files(tmp_path, fits):
    write_bundle(tmp_path / "b", fits.baseline)
    manifest = json.loads((tmp_path / "b" / MANIFEST_FILE).read_text())
    manifest["files"]["model.pkl"] = {"sha256": "0" * 64, "bytes": 1}
    (tmp_path / "b" / MANIFEST_FILE).write_text(json.dumps(manifest))
    (tmp_path / "b" / "model.pkl").write_bytes(b"x")
    with pytest.raises(ArtifactError, match="not a bundle file"):
        read_bundle(tmp_path / "b")


def test_wrong_asset_is_refused(tmp_path, fits):
    write_bundle(tmp_path / "b", fits.baseline, asset_id="T-02")
    with pytest.raises(ArtifactError, match="belongs to asset 'T-02'"):
        read_bundle(tmp_path / "b", expected_asset_id="T-01")


def test_the_stored_arrays_keep_their_names_and_shapes(fits):
    # bundles written before the tier kinds named their own arrays must still be read
    tensors = weight_tensors(fits.baseline)
    expected = {}
    for channel in fits.baseline.channels:
        c = channel.channel
        w, W = channel.nonlinear.weight_arrays()
        expected[f"{c}.nonlinear.input_weights"] = w.shape
        expected[f"{c}.nonlinear.output_weights"] = (len(W),)
        expected[f"{c}.linear.coefficients"] = (len(channel.linear.coefficients),)
        expected[f"{c}.noise.moments"] = (4,)
        if channel.level is not None:
            expected[f"{c}.level.level"] = (1,)
    assert {name: values.shape for name, values in tensors.items()} == expected
    assert all(values.dtype == np.float64 for values in tensors.values())
