"""The signature bundle: JSON + safetensors + a manifest, written and read without pickle.

A bundle is a directory holding exactly::

    signature.json        graybox.signature.Signature.to_json()
    calibration.json      graybox.calibration.Calibration.to_json()   (baseline fits only)
    weights.safetensors   every tier's parameters as float64 tensors
    manifest.json         format, asset id and the sha256 and size of each file above

Reading a bundle (:func:`read_bundle`) trusts nothing in it:

* only the names above may appear; any other file (a ``.pkl`` dropped beside the JSON, a
  sub-directory, a symlink) is refused;
* every file must match its manifest entry (sha256 and size), and the manifest itself may be
  pinned by a digest kept elsewhere (the registry keeps it in a model-version tag, so
  rewriting the artifact store alone is detected);
* JSON is parsed strictly by :meth:`Signature.from_json` / :meth:`Calibration.from_json`:
  every number finite, every weight shape that of the frozen structure, one threshold per
  channel and tier of the signature;
* the safetensors tensors must equal the parameters inside the signature JSON, exactly.

Any failure raises :class:`graybox.exceptions.ArtifactError` naming the bundle (asset and
version when known) and the file. Nothing is ever unpickled: the formats involved cannot
carry code.
"""
from __future__ import annotations

import hashlib
import json
import pathlib
from dataclasses import dataclass

import numpy as np
from safetensors import SafetensorError
from safetensors.numpy import load as load_tensors
from safetensors.numpy import save as save_tensors

from graybox.calibration import Calibration
from graybox.exceptions import ArtifactError
from graybox.signature import TIER_KINDS, Signature

SIGNATURE_FILE = "signature.json"
CALIBRATION_FILE = "calibration.json"
WEIGHTS_FILE = "weights.safetensors"
MANIFEST_FILE = "manifest.json"
DRIFT_FILE = "drift.json"
DIAGNOSIS_FILE = "diagnosis.json"

BUNDLE_FORMAT = "fleet-health-signature-bundle"
BUNDLE_VERSION = 1
REQUIRED_FILES = (SIGNATURE_FILE, WEIGHTS_FILE)
OPTIONAL_FILES = (CALIBRATION_FILE,)
MAX_FILE_BYTES = 64 * 1024 * 1024


@dataclass(frozen=True)
class Bundle:
    """A bundle read back and verified.

    Attributes
    ----------
    signature : Signature
    calibration : Calibration or None
    manifest_sha256 : str
        Digest of ``manifest.json``, which pins every other file.
    """

    signature: Signature
    calibration: Calibration | None
    manifest_sha256: str


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def weight_tensors(signature: Signature) -> dict[str, np.ndarray]:
    """Every built-in tier's parameters as float64 arrays, named ``<channel>.<tier>.<part>``;
    each tier kind names its parts (:meth:`graybox.tiers.Tier.tensors`). A tier added through
    ``kinds=`` is kept in ``signature.json`` (pinned by the manifest) only: its arrays need its
    kind, which the registry is not given.

    ``<channel>.nonlinear.input_weights`` has shape (J, m), ``.output_weights`` (J,),
    ``<channel>.linear.coefficients`` (n,), ``<channel>.noise.moments`` (4,) and, when the
    channel has the level tier, ``<channel>.level.level`` (1,).
    """
    tensors: dict[str, np.ndarray] = {}
    for channel in signature.channels:
        for kind in TIER_KINDS:
            if kind.present(channel):
                for part, values in kind.tensors(channel).items():
                    tensors[f"{channel.channel}.{kind.name}.{part}"] = np.ascontiguousarray(
                        values, np.float64)
    return tensors


def write_bundle(directory: str | pathlib.Path, signature: Signature,
                 calibration: Calibration | None = None, asset_id: str | None = None) -> str:
    """Write a bundle into ``directory`` (created; must be empty or new).

    Returns
    -------
    str
        sha256 of the manifest written (pin it to detect later rewrites).
    """
    directory = pathlib.Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    if any(directory.iterdir()):
        raise ValueError(f"bundle directory {directory} is not empty")
    contents = {SIGNATURE_FILE: signature.to_json(indent=2).encode()}
    if calibration is not None:
        contents[CALIBRATION_FILE] = calibration.to_json(indent=2).encode()
    metadata = {"format": BUNDLE_FORMAT, "asset_id": asset_id or signature.asset_id or ""}
    contents[WEIGHTS_FILE] = save_tensors(weight_tensors(signature), metadata=metadata)
    manifest = {
        "format": BUNDLE_FORMAT,
        "format_version": BUNDLE_VERSION,
        "asset_id": asset_id or signature.asset_id,
        "files": {name: {"sha256": sha256_bytes(data), "bytes": len(data)}
                  for name, data in sorted(contents.items())},
    }
    contents[MANIFEST_FILE] = json.dumps(manifest, indent=2, sort_keys=True).encode()
    for name, data in contents.items():
        (directory / name).write_bytes(data)
    return sha256_bytes(contents[MANIFEST_FILE])


def read_bundle(directory: str | pathlib.Path, where: str | None = None,
                expected_manifest_sha256: str | None = None,
                expected_asset_id: str | None = None) -> Bundle:
    """Read and verify a bundle (see the module docstring for every check).

    Parameters
    ----------
    directory : path-like
    where : str, optional
        What the bundle is, for messages (e.g. ``"asset 'T-1' version 3"``).
    expected_manifest_sha256 : str, optional
        Digest the manifest must have (from the registry).
    expected_asset_id : str, optional
        Asset the bundle must belong to.

    Returns
    -------
    Bundle

    Raises
    ------
    graybox.exceptions.ArtifactError
        If anything is missing, unexpected, altered or malformed.
    """
    directory = pathlib.Path(directory)
    where = where or str(directory)

    def fail(file: str | None, problem: str) -> ArtifactError:
        location = f"{where}: {file}" if file else where
        return ArtifactError(f"{location}: {problem}")

    if not directory.is_dir():
        raise fail(None, f"signature bundle not found (no directory {directory})")
    present = {}
    for entry in sorted(directory.iterdir()):
        if entry.is_symlink() or not entry.is_file():
            raise fail(entry.name, "unexpected entry in the signature bundle (not a regular "
                                   "file); refusing to load it")
        present[entry.name] = entry
    if MANIFEST_FILE not in present:
        raise fail(MANIFEST_FILE, "missing: the bundle has no manifest; refusing to load it")
    manifest_bytes = _read(present[MANIFEST_FILE], fail)
    manifest_digest = sha256_bytes(manifest_bytes)
    if expected_manifest_sha256 is not None and manifest_digest != expected_manifest_sha256:
        raise fail(MANIFEST_FILE, "sha256 differs from the digest recorded in the registry "
                                  "(the artifacts were altered after they were recorded)")
    listed = _parse_manifest(manifest_bytes, fail)
    if expected_asset_id is not None and listed["asset_id"] not in (None, expected_asset_id):
        raise fail(MANIFEST_FILE, f"belongs to asset {listed['asset_id']!r}, "
                                  f"not {expected_asset_id!r}")
    files = listed["files"]
    unexpected = sorted(set(present) - set(files) - {MANIFEST_FILE})
    if unexpected:
        raise fail(unexpected[0], "unexpected file, not listed in manifest.json; refusing to "
                                  "load the bundle (nothing in it was read or executed)")
    contents = {}
    for name, entry in files.items():
        if name not in present:
            raise fail(name, "missing (listed in manifest.json)")
        data = _read(present[name], fail)
        if len(data) != entry["bytes"] or sha256_bytes(data) != entry["sha256"]:
            raise fail(name, "sha256 does not match manifest.json (tampered or corrupted); "
                             "refusing to load it")
        contents[name] = data
    try:
        signature = Signature.from_json(contents[SIGNATURE_FILE])
    except ArtifactError as error:
        raise fail(SIGNATURE_FILE, str(error)) from None
    calibration = None
    if CALIBRATION_FILE in contents:
        try:
            calibration = Calibration.from_json(contents[CALIBRATION_FILE])
        except ArtifactError as error:
            raise fail(CALIBRATION_FILE, str(error)) from None
    if calibration is not None:
        needed = {(c.channel, tier) for c in signature.channels for tier in c.tier_names()}
        given = {(t.channel, t.tier) for t in calibration.thresholds}
        if given != needed:
            raise fail(CALIBRATION_FILE, f"thresholds must cover exactly the signature's "
                                         f"channels and tiers: missing "
                                         f"{sorted(needed - given)}, extra "
                                         f"{sorted(given - needed)}")
    if expected_asset_id is not None and signature.asset_id not in (None, expected_asset_id):
        raise fail(SIGNATURE_FILE, f"is the signature of asset {signature.asset_id!r}, "
                                   f"not {expected_asset_id!r}")
    try:
        stored = load_tensors(contents[WEIGHTS_FILE])
    except (SafetensorError, ValueError) as error:
        raise fail(WEIGHTS_FILE, f"not a valid safetensors file: {error}") from None
    expected = weight_tensors(signature)
    if set(stored) != set(expected):
        raise fail(WEIGHTS_FILE, f"holds tensors {sorted(stored)}, the signature has "
                                 f"{sorted(expected)}")
    for name, values in expected.items():
        if stored[name].dtype != np.float64 or not np.array_equal(stored[name], values):
            raise fail(WEIGHTS_FILE, f"tensor {name!r} differs from the weights in "
                                     f"{SIGNATURE_FILE}")
    return Bundle(signature, calibration, manifest_digest)


def _read(path: pathlib.Path, fail) -> bytes:
    size = path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise fail(path.name, f"is {size} bytes, more than a signature bundle can hold")
    return path.read_bytes()


def _parse_manifest(data: bytes, fail) -> dict:
    try:
        manifest = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise fail(MANIFEST_FILE, f"not valid JSON: {error}") from None
    if not isinstance(manifest, dict):
        raise fail(MANIFEST_FILE, "must be a JSON object")
    known = {"format", "format_version", "asset_id", "files"}
    if set(manifest) != known:
        raise fail(MANIFEST_FILE, f"fields must be {sorted(known)}, got {sorted(manifest)}")
    if manifest["format"] != BUNDLE_FORMAT or manifest["format_version"] != BUNDLE_VERSION:
        raise fail(MANIFEST_FILE, f"format {manifest['format']!r} version "
                                  f"{manifest['format_version']!r} is not supported "
                                  f"(this code reads {BUNDLE_FORMAT!r} {BUNDLE_VERSION})")
    if manifest["asset_id"] is not None and not isinstance(manifest["asset_id"], str):
        raise fail(MANIFEST_FILE, "asset_id must be a string or null")
    files = manifest["files"]
    if not isinstance(files, dict):
        raise fail(MANIFEST_FILE, "files must be an object")
    allowed = set(REQUIRED_FILES) | set(OPTIONAL_FILES)
    for name, entry in files.items():
        if name not in allowed:
            raise fail(MANIFEST_FILE, f"lists {name!r}, which is not a bundle file "
                                      f"(allowed: {sorted(allowed)})")
        if (not isinstance(entry, dict) or set(entry) != {"sha256", "bytes"}
                or not isinstance(entry["sha256"], str) or len(entry["sha256"]) != 64
                or isinstance(entry["bytes"], bool) or not isinstance(entry["bytes"], int)):
            raise fail(MANIFEST_FILE, f"entry for {name!r} must be {{'sha256': hex, 'bytes': int}}")
    for name in REQUIRED_FILES:
        if name not in files:
            raise fail(name, "missing from manifest.json (required)")
    return manifest
