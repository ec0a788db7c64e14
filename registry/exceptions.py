"""Errors raised by the registry.

Bad or tampered artifacts raise :class:`graybox.exceptions.ArtifactError` and bad asset ids
:class:`graybox.exceptions.InvalidAssetIdError`, as everywhere else in the project; the
classes here cover what only the registry can get wrong.
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
