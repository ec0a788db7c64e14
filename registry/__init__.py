"""registry: healthy baselines and nightly candidates in MLflow (the system of record).

Start with :class:`registry.Registry`, the facade: the flows and the command line call its
methods and the public names below, nothing else of the registry. Layout, by concept:

``registry``      the facade, :class:`Registry`
``records``       the typed records it returns (FitRecord, VersionInfo, AssetSummary, LoadedVersion)
``exceptions``    the registry's errors, the store's failures among them
``store/``        where the registry lives and how it talks to MLflow: naming, tracking_store,
                  retry, locks, boundary, backend, model_headers, sql_writes, probe
``write/``        recording a fit: submission, run_content, artifacts, model_files, plots,
                  runs, at_once, group, recording, watermarks
``read/``         reading back: loading (a version, verified), history (zetas and alerts)
``review``        promote, reject, rollback, list, history, the reference of a run
``fleet_nights``  the fleet's nights: worst ratios per asset and night, fleet-level runs
``pyfunc``        loader module of the pyfunc model (no pickle; its name is recorded in
                  every model, so it stays ``registry.pyfunc``)

Alerts are made in :mod:`graybox.alert`, beside the drift they come from; the registry stores
them (with the candidate's run) and returns them (:meth:`Registry.alerts`).

Importing :mod:`registry` does not import MLflow; the names below load on first use.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

__all__ = ["Registry", "FitSubmission", "FitRecord", "VersionInfo", "AssetSummary",
           "LoadedVersion", "RegistryError", "NotFoundError", "PromotionError",
           "UnusableBaselineError", "StoreError", "TransientStoreError", "RetryPolicy",
           "NightRatio", "night_of_window", "resolve_store", "file_lock", "load_mlflow",
           "data_hash"]

_LOCATIONS = {
    "Registry": "registry.registry",
    "FitSubmission": "registry.write.submission",
    "data_hash": "registry.write.submission",
    "FitRecord": "registry.records",
    "VersionInfo": "registry.records",
    "AssetSummary": "registry.records",
    "LoadedVersion": "registry.records",
    "RegistryError": "registry.exceptions",
    "NotFoundError": "registry.exceptions",
    "PromotionError": "registry.exceptions",
    "UnusableBaselineError": "registry.exceptions",
    "StoreError": "registry.exceptions",
    "TransientStoreError": "registry.exceptions",
    "RetryPolicy": "registry.store.retry",
    "NightRatio": "registry.fleet_nights",
    "night_of_window": "registry.fleet_nights",
    "resolve_store": "registry.store.tracking_store",
    "load_mlflow": "registry.store.tracking_store",
    "file_lock": "registry.store.locks",
}

if TYPE_CHECKING:  # pragma: no cover
    from registry.exceptions import (NotFoundError, PromotionError, RegistryError, StoreError,
                                     TransientStoreError, UnusableBaselineError)
    from registry.fleet_nights import NightRatio, night_of_window
    from registry.records import AssetSummary, FitRecord, LoadedVersion, VersionInfo
    from registry.registry import Registry
    from registry.store.locks import file_lock
    from registry.store.retry import RetryPolicy
    from registry.store.tracking_store import load_mlflow, resolve_store
    from registry.write.submission import FitSubmission, data_hash


def __getattr__(name: str):
    if name in _LOCATIONS:
        import importlib

        return getattr(importlib.import_module(_LOCATIONS[name]), name)
    raise AttributeError(f"module 'registry' has no attribute {name!r}")
