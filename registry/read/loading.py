"""Loading a recorded version, safely: signature and calibration, verified; never unpickled.

A version's artifacts are read (in place from a local artifact store, else downloaded), its
``MLmodel`` file must describe the loader-module pyfunc of :mod:`registry.pyfunc` (a pickled
``python_model`` is refused), no file outside the expected set may be present, and the
signature bundle is verified against the manifest digest recorded in the registry when the
fit was recorded (:func:`registry.write.artifacts.read_bundle`). A version whose ``source`` has a
``..`` segment (a path out of the artifact store) is refused before anything is read. Given
``models`` (the asset's configured model specs), the signature's model spec must be one of
them, or name an FMU file that moved to one of them with its GUID; nothing the artifact
names is imported before that check (see :mod:`graybox.models.spec`).
"""
from __future__ import annotations

import dataclasses
import pathlib
import tempfile
import urllib.parse
from typing import Collection

import yaml
from mlflow.exceptions import MlflowException

from graybox.exceptions import ArtifactError
from graybox.models import fmu_file
from registry.store import naming
from registry.write.artifacts import read_bundle
from registry.store.backend import Backend
from registry.records import LoadedVersion, VersionInfo
from registry.exceptions import NotFoundError
from registry.write.model_files import BUNDLE_DIR, LOADER_MODULE

# what MLflow writes beside the bundle; ``registered_model_meta`` is added by MLflow itself
# (into a local artifact store, in place) when a ``models:/`` URI is loaded; none is executed
MODEL_FILES = {"MLmodel", "conda.yaml", "python_env.yaml", "requirements.txt", "constraints.txt",
               "registered_model_meta"}
_PICKLED_FLAVOR_KEYS = ("python_model", "cloudpickle_version", "artifacts")



def version_info(backend: Backend, asset_id: str, version, model=None) -> VersionInfo:
    """VersionInfo with aliases taken from the registered model (search results may lack them)."""
    info = VersionInfo.from_model_version(asset_id, version)
    if model is not None:
        aliases = tuple(sorted(a for a, v in (model.aliases or {}).items()
                               if int(v) == info.version))
        info = dataclasses.replace(info, aliases=aliases)
    return info


def verify_model_dir(path: pathlib.Path, where: str) -> pathlib.Path:
    """Check a downloaded model directory; return its bundle directory.

    Raises
    ------
    graybox.exceptions.ArtifactError
        If a file is missing or unexpected, or ``MLmodel`` is not our loader-module pyfunc.
    """
    if not path.is_dir():
        raise ArtifactError(f"{where}: model artifacts not found")
    bundle = path / "data" / BUNDLE_DIR
    for entry in sorted(path.rglob("*")):
        relative = entry.relative_to(path)
        if entry.is_symlink():
            raise ArtifactError(f"{where}: {relative}: unexpected symlink in the model; refusing "
                                f"to load it")
        if entry.is_dir():
            if relative.parts in (("data",), ("data", BUNDLE_DIR)):
                continue
            raise ArtifactError(f"{where}: {relative}/: unexpected directory in the model; "
                                f"refusing to load it")
        if len(relative.parts) == 1 and relative.name in MODEL_FILES:
            continue
        if relative.parent == pathlib.Path("data", BUNDLE_DIR):
            continue      # checked file by file against the manifest by read_bundle
        raise ArtifactError(f"{where}: {relative}: unexpected file in the model; refusing to "
                            f"load it (nothing in it was read or executed)")
    mlmodel = path / "MLmodel"
    if not mlmodel.is_file():
        raise ArtifactError(f"{where}: MLmodel: missing")
    try:
        # libyaml's safe loader when present: the same safe subset, ten times faster
        description = yaml.load(mlmodel.read_text(),
                                Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    except (yaml.YAMLError, UnicodeDecodeError) as error:
        raise ArtifactError(f"{where}: MLmodel: not valid YAML: {error}") from None
    flavors = description.get("flavors") if isinstance(description, dict) else None
    if not isinstance(flavors, dict) or set(flavors) != {"python_function"}:
        raise ArtifactError(f"{where}: MLmodel: flavors must be exactly python_function, got "
                            f"{sorted(flavors) if isinstance(flavors, dict) else flavors!r}")
    flavor = flavors["python_function"]
    if not isinstance(flavor, dict):
        raise ArtifactError(f"{where}: MLmodel: python_function must be a mapping")
    pickled = [key for key in _PICKLED_FLAVOR_KEYS if key in flavor]
    if pickled:
        raise ArtifactError(f"{where}: MLmodel: describes a pickled python_model ({pickled}); "
                            f"refusing to load it")
    if flavor.get("loader_module") != LOADER_MODULE or flavor.get("code") is not None:
        raise ArtifactError(f"{where}: MLmodel: loader_module must be {LOADER_MODULE!r} with no "
                            f"code, got {flavor.get('loader_module')!r}")
    if flavor.get("data") != f"data/{BUNDLE_DIR}":
        raise ArtifactError(f"{where}: MLmodel: data must be 'data/{BUNDLE_DIR}', got "
                            f"{flavor.get('data')!r}")
    return bundle


def resolve(backend: Backend, asset_id: str, version: int | str | None):
    """A ModelVersion from a number, an alias (default ``baseline``) or a numeric string."""
    if version is None:
        version = naming.BASELINE
    if isinstance(version, str) and not version.isdigit():
        if version not in naming.ALIASES:
            raise NotFoundError(f"unknown alias {version!r}; aliases: {naming.ALIASES}")
        found = backend.version_by_alias(asset_id, version)
        if found is None:
            backend.require_registered_model(asset_id)
            raise NotFoundError(f"asset {asset_id!r} has no {version} version")
        return found
    return backend.model_version(asset_id, version)


def _download(backend: Backend, source: str, destination: pathlib.Path, where: str) -> pathlib.Path:
    from mlflow.artifacts import download_artifacts

    try:
        local = download_artifacts(artifact_uri=source, dst_path=str(destination),
                                   tracking_uri=backend.tracking_uri,
                                   registry_uri=backend.tracking_uri)
    except (MlflowException, OSError) as error:
        raise ArtifactError(f"{where}: model artifacts missing or unreadable at {source}: "
                            f"{error}") from None
    return pathlib.Path(local)


def _in_place(source: str) -> pathlib.Path | None:
    """The directory of a ``file:`` source, read where it is: a copy would be read from the
    same files (MLflow copies them one thread per file), and every check reads them anyway."""
    if not source.startswith("file:"):
        return None
    from mlflow.utils.file_utils import local_file_uri_to_path

    path = pathlib.Path(local_file_uri_to_path(source))
    return path if path.is_dir() else None


def check_source(source: str, where: str) -> None:
    """Refuse a version ``source`` with a ``..`` segment (even percent-encoded): it would
    read a directory outside the artifact store."""
    path = urllib.parse.unquote(urllib.parse.urlparse(str(source)).path)
    if ".." in pathlib.PurePosixPath(path.replace("\\", "/")).parts:
        raise ArtifactError(f"{where}: source {source!r} leaves the artifact store ('..'); "
                            f"refusing to read it")


def check_model(loaded: LoadedVersion, models: Collection[str], where: str) -> LoadedVersion:
    """Refuse a version whose signature names another model than ``models`` (nothing of it
    is imported). An FMU file that moved (one of ``models`` names a file at another path with
    the fingerprint, the GUID, the version was fitted with) is the same model: the version is
    returned naming the file where it is now."""
    stored = loaded.signature.model
    if stored.spec in models:
        return loaded
    moved = fmu_file.moved_to(stored.spec, stored.fingerprint, models)
    if moved is not None:
        model = dataclasses.replace(stored, spec=moved)
        return dataclasses.replace(loaded, signature=dataclasses.replace(loaded.signature,
                                                                         model=model))
    configured = " or ".join(map(repr, sorted(models)))
    raise ArtifactError(f"{where}: signature.json: model {stored.spec!r} is not the asset's "
                        f"configured model ({configured}); refusing to import it (fit a "
                        f"new baseline if the class's model changed)")


def load(backend: Backend, asset_id: str, mv, model=None,
          keep: pathlib.Path | None = None,
          models: Collection[str] | None = None) -> LoadedVersion:
    """Load and verify one ModelVersion (see the module docstring); ``models``: the model
    specs its signature may name."""
    where = f"asset {asset_id!r} version {mv.version}"
    check_source(mv.source, where)
    tags = mv.tags or {}
    if tags.get(naming.TAG_ASSET_ID) not in (None, asset_id):
        raise ArtifactError(f"{where}: recorded for asset {tags.get(naming.TAG_ASSET_ID)!r}")
    expected = tags.get(naming.TAG_MANIFEST_SHA256)
    if expected is None:
        raise ArtifactError(f"{where}: no manifest digest recorded with the version; it was "
                            f"not recorded by fleet-health and cannot be verified")
    source = backend.store.local_artifact_uri(mv.source)    # rebased if the store moved
    local = None if keep is not None else _in_place(source)
    if local is not None:       # read where it is: no scratch directory to make and remove
        bundle = _verified(local, where, expected, asset_id)
    else:
        with tempfile.TemporaryDirectory(prefix="fleet-health-load-") as scratch:
            target = keep if keep is not None else pathlib.Path(scratch)
            bundle = _verified(_download(backend, source, target, where), where, expected,
                               asset_id)
    loaded = LoadedVersion(version_info(backend, asset_id, mv, model), bundle.signature,
                           bundle.calibration, bundle.manifest_sha256)
    if models is not None:
        loaded = check_model(loaded, models, where)
    return loaded


def _verified(local: pathlib.Path, where: str, expected: str, asset_id: str):
    return read_bundle(verify_model_dir(local, where), where=where,
                       expected_manifest_sha256=expected, expected_asset_id=asset_id)


def load_version(backend: Backend, asset_id: str, version: int | str | None = None,
                 models: Collection[str] | None = None) -> LoadedVersion:
    """Load and verify one version (a number or an alias; default the baseline)."""
    return load(backend, asset_id, resolve(backend, asset_id, version),
                backend.registered_model(asset_id), models=models)


def baseline(backend: Backend, asset_id: str,
             models: Collection[str] | None = None) -> LoadedVersion | None:
    """The asset's baseline, verified, or None if it has none."""
    mv = backend.version_by_alias(asset_id, naming.BASELINE)
    return None if mv is None else load(backend, asset_id, mv, models=models)


def load_pyfunc(backend: Backend, asset_id: str, version: int | str | None = None,
                models: Collection[str] | None = None):
    """The version as an MLflow pyfunc model, loaded only after its artifacts are verified.

    ``models``: the model specs the version may name; without it, the signature's model
    module must already be imported, or its FMU file loaded (a stored record never chooses
    what is imported).

    Returns
    -------
    mlflow.pyfunc.PyFuncModel
        ``predict(telemetry_frame)`` returns zeta per tier and channel (see
        :class:`registry.pyfunc.SignatureModel`).
    """
    import mlflow.pyfunc

    from graybox.models.base import model_class

    mv = resolve(backend, asset_id, version)
    with tempfile.TemporaryDirectory(prefix="fleet-health-pyfunc-") as scratch:
        root = pathlib.Path(scratch)
        loaded = load(backend, asset_id, mv, keep=root, models=models)
        if models is not None:
            # the caller trusts these: the model's module may be imported (its FMU loaded) now
            model_class(loaded.signature.model.spec)
        local = next(p.parent for p in root.rglob("MLmodel"))
        # the model reads everything it needs in its constructor; the copy can go afterwards
        return mlflow.pyfunc.load_model(str(local))


__all__ = ["MODEL_FILES", "verify_model_dir", "version_info", "check_source", "check_model",
           "load", "resolve",
           "load_version", "baseline", "load_pyfunc"]
