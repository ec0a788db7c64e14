"""The registry's edge: what MLflow and its database drivers raise leaves the registry as the
registry's own errors (:mod:`registry.exceptions`), so nothing above it reads MLflow's.

A passing failure of the store (:func:`registry.store.retry.is_transient_store_error`: locked or
asking for the transaction again after the retries, unreachable, temporarily unavailable)
becomes :class:`~registry.exceptions.TransientStoreError`; any other MLflow error
:class:`~registry.exceptions.StoreError`; the store's error is the new one's ``__cause__``
and its message is kept. The registry's own errors, bad artifacts and ids
(:mod:`graybox.exceptions`) and bad arguments (``ValueError``, ``TypeError``,
``KeyError``) pass unchanged: they say what is wrong, whatever the store did on the way.

Inside the registry MLflow's errors are read as they come (``registry.store.backend.is_not_found``
and the like); :func:`raises_registry_errors` marks the functions the flows and the command
line call, and :func:`facade` every public method of a class (:class:`registry.Registry`).
"""
from __future__ import annotations

import functools
import inspect
from typing import Callable, TypeVar

from mlflow.exceptions import MlflowException

from graybox.exceptions import GrayBoxError
from registry.exceptions import RegistryError, StoreError, TransientStoreError
from registry.store.retry import is_transient_store_error

F = TypeVar("F", bound=Callable)
C = TypeVar("C", bound=type)

#: errors that say what is wrong themselves: never translated
_KEPT = (RegistryError, GrayBoxError, ValueError, TypeError, KeyError)


def registry_error(error: BaseException) -> BaseException:
    """``error`` as the registry raises it: a :class:`TransientStoreError` or
    :class:`StoreError` for a store's error (with its message), else
    ``error`` itself."""
    if isinstance(error, _KEPT):
        return error
    if is_transient_store_error(error):
        return TransientStoreError(str(error) or type(error).__name__)
    if isinstance(error, MlflowException):
        return StoreError(str(error) or type(error).__name__)
    return error


def raises_registry_errors(function: F) -> F:
    """``function``, raising the store's errors as the registry's (:func:`registry_error`,
    from the store's error)."""
    @functools.wraps(function)
    def call(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except Exception as error:
            translated = registry_error(error)
            if translated is error:
                raise
            raise translated from error
    return call


def facade(cls: C) -> C:
    """Class decorator: the constructor and every public method of ``cls`` raise the
    registry's errors (:func:`raises_registry_errors`); properties, static and class methods
    are left as they are."""
    for name, member in list(vars(cls).items()):
        if inspect.isfunction(member) and (name == "__init__" or not name.startswith("_")):
            setattr(cls, name, raises_registry_errors(member))
    return cls
