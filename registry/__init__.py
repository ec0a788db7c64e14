"""registry: healthy baselines and nightly candidates in MLflow (the system of record).

Start with :class:`registry.Registry`. Layout, one concept per module:

``naming``      experiment, registered-model and tag names (asset ids validated first)
``store``       tracking URIs, SQLite WAL set-up, "database is locked" retries, asset locks
``backend``     the MLflow client bound to one store, shared look-ups
``exceptions``  the registry's errors, the store's failures among them
``boundary``    MLflow's errors leave the registry as the registry's (``TransientStoreError``)
``model_headers`` registered models' tags and aliases, read without their versions
``artifacts``   the signature bundle: JSON + safetensors + manifest, verified on read
``submission``  what is submitted for recording (FitSubmission), its key and data hash
``run_content`` a recorded fit's tags, params, metrics, drift.json and description
``model_files`` the pyfunc model of a fit (logged model or the run's model/)
``runs``        logging one fit as a complete run, in few round trips
``recording``   recording fits idempotently (runs, versions, alias), one or a batch
``history``     the zeta history and the recorded alerts (made again from the stored drifts)
``loading``     safe loading of a version (verified, never unpickled)
``baselines``   promote, reject, rollback, list, history
``watermarks``  per-asset watermark on the registered model
``plots``       residual/ACF, tier fits, zeta trend (matplotlib, Agg)
``pyfunc``      loader module of the pyfunc model (no pickle)
``cli``         ``fleet-health baseline ...`` subcommands

Importing :mod:`registry` does not import MLflow; the names below load on first use.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

__all__ = ["Registry", "FitSubmission", "FitRecord", "VersionInfo", "AssetSummary",
           "LoadedVersion", "RegistryError", "NotFoundError", "PromotionError", "StoreError",
           "TransientStoreError", "RetryPolicy", "NightRatio", "night_of_window"]

_LOCATIONS = {
    "Registry": "registry.registry",
    "FitSubmission": "registry.submission",
    "FitRecord": "registry.entities",
    "VersionInfo": "registry.entities",
    "AssetSummary": "registry.entities",
    "LoadedVersion": "registry.entities",
    "RegistryError": "registry.exceptions",
    "NotFoundError": "registry.exceptions",
    "PromotionError": "registry.exceptions",
    "StoreError": "registry.exceptions",
    "TransientStoreError": "registry.exceptions",
    "RetryPolicy": "registry.retry",
    "NightRatio": "registry.fleet_ratios",
    "night_of_window": "registry.fleet_ratios",
}

if TYPE_CHECKING:  # pragma: no cover
    from registry.entities import AssetSummary, FitRecord, LoadedVersion, VersionInfo
    from registry.exceptions import (NotFoundError, PromotionError, RegistryError, StoreError,
                                     TransientStoreError)
    from registry.registry import Registry
    from registry.retry import RetryPolicy
    from registry.submission import FitSubmission


def __getattr__(name: str):
    if name in _LOCATIONS:
        import importlib

        return getattr(importlib.import_module(_LOCATIONS[name]), name)
    raise AttributeError(f"module 'registry' has no attribute {name!r}")
