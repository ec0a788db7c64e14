"""Errors raised by the registry.

Bad or tampered artifacts raise :class:`graybox.exceptions.ArtifactError` and bad asset ids
:class:`graybox.exceptions.InvalidAssetIdError`, as everywhere else in the project; the
classes here cover what only the registry can get wrong, and the tracking store's own
failures as the registry raises them (:mod:`registry.store.boundary`): nothing above the registry
reads MLflow's errors or their codes.
"""
from __future__ import annotations


class RegistryError(Exception):
    """Base class of the registry's own errors (an operation that cannot be done)."""


class NotFoundError(RegistryError):
    """An asset, version or alias the operation needs does not exist."""


class PromotionError(RegistryError):
    """A promotion, rejection or rollback was refused; the message says why."""


class UnusableBaselineError(RegistryError):
    """The version a run compares with cannot be used (uncalibrated, tampered, or another
    model than the asset's configured one); the message names the version and the fix."""


class StoreError(RegistryError):
    """The tracking store failed an operation (an MLflow error that is not a passing one: a
    bad request, a missing resource the registry did not expect); the message is the
    store's, its ``__cause__`` the store's own error."""


class TransientStoreError(StoreError):
    """The tracking store failed in a passing way, so a later try may succeed: locked or
    asking for the transaction again after the registry's own retries, unreachable,
    temporarily unavailable, rate-limited (:func:`registry.store.retry.is_transient_store_error`
    says which). The message is the store's, its ``__cause__`` the store's own error."""
