"""registry: healthy baselines and nightly candidates in MLflow (the system of record).

Start with :class:`registry.Registry`. Layout, one concept per module:

``naming``      experiment, registered-model and tag names (asset ids validated first)
``store``       tracking URIs, SQLite WAL set-up, "database is locked" retries, asset locks
``backend``     the MLflow client bound to one store, shared look-ups
``artifacts``   the signature bundle: JSON + safetensors + manifest, verified on read
``records``     recording fits (runs, logged models, versions); zeta history, alerts
``baselines``   safe loading, promote, reject, rollback, list, history
``watermarks``  per-asset watermark on the registered model
``plots``       residual/ACF, tier fits, zeta trend (matplotlib, Agg)
``pyfunc``      loader module of the pyfunc model (no pickle)
``cli``         ``fleet-health baseline ...`` subcommands

Importing :mod:`registry` does not import MLflow; the names below load on first use.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

__all__ = ["Registry", "FitRecord", "VersionInfo", "AssetSummary", "LoadedVersion",
           "RegistryError", "NotFoundError", "PromotionError", "RetryPolicy"]

_LOCATIONS = {
    "Registry": "registry.registry",
    "FitRecord": "registry.entities",
    "VersionInfo": "registry.entities",
    "AssetSummary": "registry.entities",
    "LoadedVersion": "registry.entities",
    "RegistryError": "registry.exceptions",
    "NotFoundError": "registry.exceptions",
    "PromotionError": "registry.exceptions",
    "RetryPolicy": "registry.store",
}

if TYPE_CHECKING:  # pragma: no cover
    from registry.entities import AssetSummary, FitRecord, LoadedVersion, VersionInfo
    from registry.exceptions import NotFoundError, PromotionError, RegistryError
    from registry.registry import Registry
    from registry.store import RetryPolicy


def __getattr__(name: str):
    if name in _LOCATIONS:
        import importlib

        return getattr(importlib.import_module(_LOCATIONS[name]), name)
    raise AttributeError(f"module 'registry' has no attribute {name!r}")
