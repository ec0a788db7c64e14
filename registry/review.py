"""Reviewing baselines: promote, reject, roll back, list and history (loading:
:mod:`registry.read.loading`).

Aliases of the asset's registered model carry the state: ``baseline`` marks the healthy
version, ``candidate`` the newest fit. Every change is made under the asset's lock
(:meth:`registry.store.tracking_store.Store.asset_lock`), so promotions of one asset are
serialized, and is recorded as tags on the version concerned (who, when, why, and the
baseline it replaced, so that :func:`rollback` can restore it).

Promotion and rollback load the version first (:func:`registry.read.loading.load`, which
verifies it and never unpickles) and refuse it if that fails. The runs load the version they
compare with through :func:`reference` (by the ``baseline`` alias: one version read,
whatever the asset's history), which also refuses a version without calibration
(the ``baseline`` alias can be moved by hand, e.g. in the MLflow UI): its zeta would have no
epsilon and nothing could alarm.
"""
from __future__ import annotations

from typing import Collection

import pandas as pd

from graybox.exceptions import ArtifactError
from registry.store import naming
from registry.store.backend import Backend
from registry.records import AssetSummary, LoadedVersion, VersionInfo
from registry.exceptions import NotFoundError, PromotionError, UnusableBaselineError
from registry.read.loading import load, resolve, version_info

def _now() -> str:
    return pd.Timestamp.now(tz="UTC").isoformat(timespec="seconds")


def _reason(reason: str | None, what: str) -> str:
    if reason is None or not str(reason).strip():
        raise PromotionError(f"{what} needs a reason (it is recorded with the change)")
    return str(reason).strip()[:4000]


# -- changes ---------------------------------------------------------------------------------

def _newest_promotable(backend: Backend, asset_id: str, but: int | None = None) -> int | None:
    name = naming.model_name(asset_id)
    versions = backend.paged(backend.client.search_model_versions,
                             f"name = {naming.quote(name)} and "
                             f"tags.`{naming.TAG_CALIBRATED}` = 'true'", max_results=200)
    numbers = [int(v.version) for v in versions
               if (v.tags or {}).get(naming.TAG_REJECTED) != "true" and int(v.version) != but]
    return max(numbers) if numbers else None


def _check_loads(backend: Backend, asset_id: str, mv, action: str) -> None:
    try:
        load(backend, asset_id, mv)
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
        info = version_info(backend, asset_id, mv, model)
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
        return version_info(backend, asset_id, backend.model_version(asset_id, number),
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
        info = version_info(backend, asset_id, mv, model)
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
        return version_info(backend, asset_id, backend.model_version(asset_id, number),
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
        current_info = version_info(backend, asset_id, backend.model_version(asset_id, current),
                                    model)
        previous = current_info.previous_baseline
        if previous is None:
            raise PromotionError(f"asset {asset_id!r}: baseline version {current} replaced no "
                                 f"earlier baseline; there is nothing to roll back to")
        try:
            target = backend.model_version(asset_id, previous)
        except NotFoundError:
            raise PromotionError(f"asset {asset_id!r}: previous baseline version {previous} no "
                                 f"longer exists") from None
        target_info = version_info(backend, asset_id, target, model)
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
        return version_info(backend, asset_id, backend.model_version(asset_id, previous),
                     backend.require_registered_model(asset_id))


# -- the reference of a run ------------------------------------------------------------------

def fix_hint(backend: Backend, asset_id: str, refused: int) -> str:
    """The commands that give the asset a usable baseline again."""
    newest = _newest_promotable(backend, asset_id, but=refused)
    fit = (f"fleet-health baseline fit {asset_id} --start DATE --end DATE --promote "
           f"--reason TEXT (a healthy range)")
    if newest is None:
        return f"fix: {fit}"
    return (f"fix: fleet-health baseline promote {asset_id} --version {newest} --reason TEXT "
            f"(its newest other calibrated version), or {fit}")


def reference(backend: Backend, asset_id: str, version: int | str | None = None,
              models: Collection[str] | None = None) -> LoadedVersion | None:
    """The version a run compares the asset with (default its baseline), verified and usable.

    Parameters
    ----------
    version : int or str, optional
        A number or alias; None is the ``baseline`` alias.
    models : collection of str, optional
        The model specs its signature may name (the asset's configured model).

    Returns
    -------
    LoadedVersion or None
        None when ``version`` is None and the asset has no baseline.

    Raises
    ------
    UnusableBaselineError
        If the version has no calibration (nothing could alarm against it), its artifacts
        fail verification, or it names another model; the message names the asset, the
        version, why, and the command that fixes it.
    NotFoundError
        If a named version or alias does not exist.
    """
    if version is None:
        mv = backend.version_by_alias(asset_id, naming.BASELINE)
        if mv is None:
            return None
    else:
        mv = resolve(backend, asset_id, version)
    try:
        loaded = load(backend, asset_id, mv, models=models)
    except ArtifactError as error:
        raise UnusableBaselineError(f"{error}; {fix_hint(backend, asset_id, int(mv.version))}"
                                    ) from error
    if loaded.calibration is None:
        role = (mv.tags or {}).get(naming.TAG_ROLE) or "uncalibrated"
        raise UnusableBaselineError(
            f"asset {asset_id!r} version {mv.version} has no calibration (a {role} fit): its "
            f"zeta has no epsilon, so nothing could alarm; refusing to compare with it; "
            f"{fix_hint(backend, asset_id, int(mv.version))}")
    return loaded


# -- views -----------------------------------------------------------------------------------

def history(backend: Backend, asset_id: str) -> list[VersionInfo]:
    """Every version of the asset, oldest first."""
    model = backend.require_registered_model(asset_id)
    name = naming.model_name(asset_id)
    versions = backend.paged(backend.client.search_model_versions,
                             f"name = {naming.quote(name)}", max_results=200)
    return sorted((version_info(backend, asset_id, v, model) for v in versions),
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
                views[alias] = version_info(backend, asset_id,
                                     backend.model_version(asset_id, aliases[alias]), model)
        latest = max((int(v.version) for v in (model.latest_versions or [])), default=None)
        mark = (model.tags or {}).get(naming.TAG_WATERMARK)
        out.append(AssetSummary(asset_id, (model.tags or {}).get(naming.TAG_VEHICLE_CLASS),
                                views.get(naming.BASELINE), views.get(naming.CANDIDATE), latest,
                                mark or None))
    return sorted(out, key=lambda s: ((s.vehicle_class or ""), s.asset_id))


__all__ = ["promote", "reject", "rollback", "reference", "fix_hint", "history",
           "list_baselines"]
