"""Baselines: safe loading, promote, reject, roll back, list and history.

Aliases of the asset's registered model carry the state: ``baseline`` marks the healthy
version, ``candidate`` the newest fit. Every change is made under the asset's lock
(:meth:`registry.store.Store.asset_lock`), so promotions of one asset are serialized, and is
recorded as tags on the version concerned (who, when, why, and the baseline it replaced, so
that :func:`rollback` can restore it).

Loading never unpickles: a version's artifacts are read (in place from a local artifact
store, else downloaded), its ``MLmodel`` file must
describe the loader-module pyfunc of :mod:`registry.pyfunc` (a pickled ``python_model`` is
refused), no file outside the expected set may be present, and the signature bundle is
verified against the manifest digest recorded in the registry when the fit was recorded
(:func:`registry.artifacts.read_bundle`). Promotion and rollback load the version first and
refuse it if that fails.
"""
from __future__ import annotations

import dataclasses
import pathlib
import tempfile

import pandas as pd
import yaml
from mlflow.exceptions import MlflowException

from graybox.exceptions import ArtifactError
from registry import naming
from registry.artifacts import read_bundle
from registry.backend import Backend
from registry.entities import AssetSummary, LoadedVersion, VersionInfo
from registry.exceptions import NotFoundError, PromotionError
from registry.model_files import BUNDLE_DIR, LOADER_MODULE

# what MLflow writes beside the bundle; ``registered_model_meta`` is added by MLflow itself
# (into a local artifact store, in place) when a ``models:/`` URI is loaded; none is executed
MODEL_FILES = {"MLmodel", "conda.yaml", "python_env.yaml", "requirements.txt", "constraints.txt",
               "registered_model_meta"}
_PICKLED_FLAVOR_KEYS = ("python_model", "cloudpickle_version", "artifacts")


def _now() -> str:
    return pd.Timestamp.now(tz="UTC").isoformat(timespec="seconds")


def _reason(reason: str | None, what: str) -> str:
    if reason is None or not str(reason).strip():
        raise PromotionError(f"{what} needs a reason (it is recorded with the change)")
    return str(reason).strip()[:4000]


def _info(backend: Backend, asset_id: str, version, model=None) -> VersionInfo:
    """VersionInfo with aliases taken from the registered model (search results may lack them)."""
    info = VersionInfo.from_model_version(asset_id, version)
    if model is not None:
        aliases = tuple(sorted(a for a, v in (model.aliases or {}).items()
                               if int(v) == info.version))
        info = dataclasses.replace(info, aliases=aliases)
    return info


# -- loading ---------------------------------------------------------------------------------

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


def _resolve(backend: Backend, asset_id: str, version: int | str | None):
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


def _load(backend: Backend, asset_id: str, mv, model=None,
          keep: pathlib.Path | None = None) -> LoadedVersion:
    where = f"asset {asset_id!r} version {mv.version}"
    tags = mv.tags or {}
    if tags.get(naming.TAG_ASSET_ID) not in (None, asset_id):
        raise ArtifactError(f"{where}: recorded for asset {tags.get(naming.TAG_ASSET_ID)!r}")
    expected = tags.get(naming.TAG_MANIFEST_SHA256)
    if expected is None:
        raise ArtifactError(f"{where}: no manifest digest recorded with the version; it was "
                            f"not recorded by fleet-health and cannot be verified")
    with tempfile.TemporaryDirectory(prefix="fleet-health-load-") as scratch:
        local = None if keep is not None else _in_place(mv.source)
        if local is None:
            target = keep if keep is not None else pathlib.Path(scratch)
            local = _download(backend, mv.source, target, where)
        bundle_dir = verify_model_dir(local, where)
        bundle = read_bundle(bundle_dir, where=where, expected_manifest_sha256=expected,
                             expected_asset_id=asset_id)
    return LoadedVersion(_info(backend, asset_id, mv, model), bundle.signature,
                         bundle.calibration, bundle.manifest_sha256)


def load_version(backend: Backend, asset_id: str, version: int | str | None = None) -> LoadedVersion:
    """Load and verify one version (a number or an alias; default the baseline)."""
    return _load(backend, asset_id, _resolve(backend, asset_id, version),
                 backend.registered_model(asset_id))


def baseline(backend: Backend, asset_id: str) -> LoadedVersion | None:
    """The asset's baseline, verified, or None if it has none."""
    mv = backend.version_by_alias(asset_id, naming.BASELINE)
    return None if mv is None else _load(backend, asset_id, mv)


def load_pyfunc(backend: Backend, asset_id: str, version: int | str | None = None):
    """The version as an MLflow pyfunc model, loaded only after its artifacts are verified.

    Returns
    -------
    mlflow.pyfunc.PyFuncModel
        ``predict(telemetry_frame)`` returns zeta per tier and channel (see
        :class:`registry.pyfunc.SignatureModel`).
    """
    import mlflow.pyfunc

    mv = _resolve(backend, asset_id, version)
    with tempfile.TemporaryDirectory(prefix="fleet-health-pyfunc-") as scratch:
        root = pathlib.Path(scratch)
        _load(backend, asset_id, mv, keep=root)
        local = next(p.parent for p in root.rglob("MLmodel"))
        # the model reads everything it needs in its constructor; the copy can go afterwards
        return mlflow.pyfunc.load_model(str(local))


# -- changes ---------------------------------------------------------------------------------

def _newest_promotable(backend: Backend, asset_id: str) -> int | None:
    name = naming.model_name(asset_id)
    versions = backend.paged(backend.client.search_model_versions,
                             f"name = {naming.quote(name)} and "
                             f"tags.`{naming.TAG_CALIBRATED}` = 'true'", max_results=200)
    numbers = [int(v.version) for v in versions if (v.tags or {}).get(naming.TAG_REJECTED) != "true"]
    return max(numbers) if numbers else None


def _check_loads(backend: Backend, asset_id: str, mv, action: str) -> None:
    try:
        _load(backend, asset_id, mv)
    except ArtifactError as error:
        raise PromotionError(f"cannot {action} asset {asset_id!r} version {mv.version}: its "
                             f"artifacts do not load: {error}") from error


def promote(backend: Backend, asset_id: str, version: int | None = None, *, reason: str,
            user: str | None = None) -> VersionInfo:
    """Make ``version`` (default: the ``candidate``) the asset's baseline.

    Refused (PromotionError) for a rejected version, a version without a calibration (a
    nightly candidate) or one whose artifacts do not load. Promoting the current baseline
    again changes nothing.
    """
    reason = _reason(reason, "promotion")
    name = naming.model_name(asset_id)
    with backend.store.asset_lock(asset_id):
        model = backend.require_registered_model(asset_id)
        aliases = model.aliases or {}
        if version is None:
            if naming.CANDIDATE not in aliases:
                raise PromotionError(f"asset {asset_id!r} has no candidate version; name the "
                                     f"version to promote")
            version = int(aliases[naming.CANDIDATE])
        mv = backend.model_version(asset_id, version)
        info = _info(backend, asset_id, mv, model)
        if info.rejected:
            raise PromotionError(f"asset {asset_id!r} version {info.version} was rejected "
                                 f"({info.rejection_reason}); it cannot become the baseline")
        if not info.calibrated:
            newest = _newest_promotable(backend, asset_id)
            hint = (f"; the newest promotable version is {newest}" if newest is not None else
                    "; fit a baseline from a healthy range first")
            raise PromotionError(f"asset {asset_id!r} version {info.version} has no calibration "
                                 f"(a {info.role or 'uncalibrated'} fit) and cannot become the "
                                 f"baseline{hint}")
        current = aliases.get(naming.BASELINE)
        if current is not None and int(current) == info.version:
            return info
        _check_loads(backend, asset_id, mv, "promote")
        number = str(info.version)
        for key, value in ((naming.TAG_PROMOTED_AT, _now()),
                           (naming.TAG_PROMOTED_BY, user or backend.user),
                           (naming.TAG_PROMOTION_REASON, reason),
                           (naming.TAG_PREVIOUS_BASELINE, "" if current is None else str(current))):
            backend.client.set_model_version_tag(name, number, key, value)
        backend.client.set_registered_model_alias(name, naming.BASELINE, number)
        return _info(backend, asset_id, backend.model_version(asset_id, number),
                     backend.require_registered_model(asset_id))


def reject(backend: Backend, asset_id: str, version: int, *, reason: str,
           user: str | None = None) -> VersionInfo:
    """Mark ``version`` rejected (never to be promoted); it loses the ``candidate`` alias.

    The current baseline cannot be rejected: promote another version or roll back first.
    """
    reason = _reason(reason, "rejection")
    name = naming.model_name(asset_id)
    with backend.store.asset_lock(asset_id):
        model = backend.require_registered_model(asset_id)
        mv = backend.model_version(asset_id, version)
        info = _info(backend, asset_id, mv, model)
        if naming.BASELINE in info.aliases:
            raise PromotionError(f"asset {asset_id!r} version {info.version} is the baseline; "
                                 f"promote another version or roll back before rejecting it")
        if info.rejected:
            return info
        number = str(info.version)
        for key, value in ((naming.TAG_REJECTED, "true"), (naming.TAG_REJECTED_AT, _now()),
                           (naming.TAG_REJECTED_BY, user or backend.user),
                           (naming.TAG_REJECTION_REASON, reason)):
            backend.client.set_model_version_tag(name, number, key, value)
        if naming.CANDIDATE in info.aliases:
            backend.client.delete_registered_model_alias(name, naming.CANDIDATE)
        return _info(backend, asset_id, backend.model_version(asset_id, number),
                     backend.require_registered_model(asset_id))


def rollback(backend: Backend, asset_id: str, *, reason: str, user: str | None = None) -> VersionInfo:
    """Move ``baseline`` back to the version it replaced when it was promoted.

    Returns
    -------
    VersionInfo
        The restored baseline.
    """
    reason = _reason(reason, "rollback")
    name = naming.model_name(asset_id)
    with backend.store.asset_lock(asset_id):
        model = backend.require_registered_model(asset_id)
        current = (model.aliases or {}).get(naming.BASELINE)
        if current is None:
            raise PromotionError(f"asset {asset_id!r} has no baseline to roll back")
        current_info = _info(backend, asset_id, backend.model_version(asset_id, current), model)
        previous = current_info.previous_baseline
        if previous is None:
            raise PromotionError(f"asset {asset_id!r}: baseline version {current} replaced no "
                                 f"earlier baseline; there is nothing to roll back to")
        try:
            target = backend.model_version(asset_id, previous)
        except NotFoundError:
            raise PromotionError(f"asset {asset_id!r}: previous baseline version {previous} no "
                                 f"longer exists") from None
        target_info = _info(backend, asset_id, target, model)
        if target_info.rejected:
            raise PromotionError(f"asset {asset_id!r}: previous baseline version {previous} was "
                                 f"rejected since ({target_info.rejection_reason}); promote a "
                                 f"version explicitly")
        _check_loads(backend, asset_id, target, "roll back to")
        for key, value in ((naming.TAG_ROLLED_BACK_AT, _now()),
                           (naming.TAG_ROLLED_BACK_BY, user or backend.user),
                           (naming.TAG_ROLLBACK_REASON, reason)):
            backend.client.set_model_version_tag(name, str(current), key, value)
        backend.client.set_registered_model_alias(name, naming.BASELINE, str(previous))
        return _info(backend, asset_id, backend.model_version(asset_id, previous),
                     backend.require_registered_model(asset_id))


# -- views -----------------------------------------------------------------------------------

def history(backend: Backend, asset_id: str) -> list[VersionInfo]:
    """Every version of the asset, oldest first."""
    model = backend.require_registered_model(asset_id)
    name = naming.model_name(asset_id)
    versions = backend.paged(backend.client.search_model_versions,
                             f"name = {naming.quote(name)}", max_results=200)
    return sorted((_info(backend, asset_id, v, model) for v in versions),
                  key=lambda i: i.version)


def list_baselines(backend: Backend, vehicle_class: str | None = None) -> list[AssetSummary]:
    """Every asset in the registry (optionally of one class) with its baseline and candidate."""
    clause = f"name LIKE '{naming.MODEL_PREFIX}%'"
    if vehicle_class is not None:
        clause += (f" and tags.`{naming.TAG_VEHICLE_CLASS}` = "
                   f"{naming.quote(naming.validate_vehicle_class(vehicle_class))}")
    out = []
    for model in backend.paged(backend.client.search_registered_models, clause, max_results=200):
        asset_id = naming.asset_from_model_name(model.name)
        if asset_id is None:
            continue
        aliases = model.aliases or {}
        views = {}
        for alias in naming.ALIASES:
            if alias in aliases:
                views[alias] = _info(backend, asset_id,
                                     backend.model_version(asset_id, aliases[alias]), model)
        latest = max((int(v.version) for v in (model.latest_versions or [])), default=None)
        mark = (model.tags or {}).get(naming.TAG_WATERMARK)
        out.append(AssetSummary(asset_id, (model.tags or {}).get(naming.TAG_VEHICLE_CLASS),
                                views.get(naming.BASELINE), views.get(naming.CANDIDATE), latest,
                                mark or None))
    return sorted(out, key=lambda s: ((s.vehicle_class or ""), s.asset_id))


__all__ = ["verify_model_dir", "load_version", "baseline", "load_pyfunc", "promote", "reject",
           "rollback", "history", "list_baselines"]
