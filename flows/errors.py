"""Every error the flows and the command line raise themselves, and what each one means.

The command line maps them to its exit status (``flows.cli``): a bad request or configuration
is 2, a store or lock that keeps a run from starting is 1 (nothing was run), a flow that
failed as a whole is 1. Errors of the registry are the registry's (:mod:`registry.exceptions`),
the tracking store's failures among them (a passing one is a
:class:`~registry.exceptions.TransientStoreError`: flows never read MLflow's errors); bad
telemetry and models raise :mod:`graybox.exceptions`.
"""
from __future__ import annotations


class ConfigError(ValueError):
    """``fleet.toml`` is missing, unreadable or wrong; the message names the file and key."""


class UsageError(ValueError):
    """A bad command-line request (unknown asset or class, bad date): exit status 2."""


class StoreUnavailable(RuntimeError):
    """The tracking store did not answer within the bound: nothing was run."""


class RunLockTimeout(RuntimeError):
    """Another run of the fleet held the lock for longer than the wait: nothing was run."""


class TransientError(RuntimeError):
    """A transient failure (registry unreachable or locked, I/O hiccup) that stopped a batch;
    the batch task is retried."""


class FlowFailed(RuntimeError):
    """The flow itself failed (not an asset): the message says why."""


class AssetsNotMonitored(RuntimeError):
    """A run that went through, but left an asset it should have covered unmonitored (exit
    status 1): the message is the coverage line, :attr:`summary` the run summary as a dict.

    The data of the flow run's Failed state. Prefect's engine raises a failed state's data
    when it runs a deployment (``fleet-health serve``, a worker), and only an exception can be
    raised: a summary dict there ended the run with a TypeError of Prefect's own.
    """

    def __init__(self, message: str, summary: dict):
        super().__init__(message)
        self.summary = summary

    def __reduce__(self):
        return type(self), (str(self), self.summary)
