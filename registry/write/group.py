"""A group's candidates recorded together, each asset on its own.

The nightly flow commits its assets a memory group at a time (:mod:`flows.pipeline`);
:func:`record_group` records the group's fits with what can be shared, shared: the
registered models are checked once, the assets' locks are taken together, the fit keys are
looked for in one query, and on an SQLAlchemy store every new candidate's run, version and
alias go in **one transaction** (:meth:`registry.store.sql_writes.SqlWriter.write_many`)
instead of one each. The records are those of :func:`registry.write.recording.record_fit`
of each fit (the same tags, params, metrics, artifacts, version and alias).

Each asset stays all or nothing, and on its own:

* the outcome is per fit: its :class:`~registry.records.FitRecord`, or the error that
  stopped it (as the registry raises it: :func:`registry.store.boundary.registry_error`), or
  None when an earlier fit of its asset failed and ``stop_at_error`` (the nightly run: the
  later windows wait for the next run). Every fit has one; none is dropped;
* a fit that fails before the transaction (its artifacts, a lock that cannot be taken, a
  malformed window) fails alone;
* when the group's transaction fails (nothing of it is then written), the fits are written
  one transaction each with the artifacts already written, so the good ones land and the
  bad one carries its error; a passing failure of the store (locked after the retries,
  unreachable) is raised instead: the flow retries the batch, and recording again finds
  what was recorded;
* the fit key still makes a second recording return the first (``created=False``): a fit
  whose key has runs already, or that appears twice in the group, is recorded by
  :func:`registry.write.recording.record_fit`'s own path, which finds it or finishes it.

Behind an ``mlflow server`` (no SQL writer) every asset is recorded by that path, one after
another, with the same per-fit outcomes.
"""
from __future__ import annotations

import contextlib
import logging
from typing import Sequence

from registry.records import FitRecord
from registry.store import naming
from registry.store.backend import Backend
from registry.store.boundary import registry_error
from registry.store.retry import call_with_retry, is_passing_failure
from registry.write.at_once import (PreparedFit, _surely_absent, discard, prepare,
                                   write_restoring_model)
from registry.write.model_files import PyfuncTemplate
from registry.write.recording import _Alias, _record, baseline_version_of, created_record
from registry.write.submission import FitSubmission, ResolvedFit

logger = logging.getLogger(__name__)

Outcome = FitRecord | BaseException | None


class _Outcomes:
    """Each submission's outcome, and the assets stopped by a failure."""

    def __init__(self, submissions: Sequence[FitSubmission], stop_at_error: bool):
        self.submissions, self.stop_at_error = submissions, stop_at_error
        self.items: list[Outcome] = [None] * len(submissions)
        self.stopped: dict[str, int] = {}     # asset -> its first failed fit

    def open(self, i: int) -> bool:
        """Whether fit ``i`` is still to be recorded: no outcome yet, and no earlier fit of
        its asset failed (with ``stop_at_error``)."""
        return self.items[i] is None and i < self.stopped.get(self.submissions[i].asset_id,
                                                               len(self.items))

    def done(self, i: int, record: FitRecord) -> None:
        self.items[i] = record

    def fail(self, i: int, error: BaseException) -> None:
        self.items[i] = registry_error(error)
        asset = self.submissions[i].asset_id
        if self.stop_at_error:
            self.stopped[asset] = min(i, self.stopped.get(asset, i))


def record_group(backend: Backend, submissions: Sequence[FitSubmission],
                 template: PyfuncTemplate | None = None, stop_at_error: bool = True
                 ) -> list[Outcome]:
    """Record the fits of a group of assets, each asset on its own (see the module
    docstring); fits of one asset in time order.

    Returns
    -------
    list
        Per submission, in order: its FitRecord, the error that stopped it, or None (not
        attempted: an earlier fit of its asset failed and ``stop_at_error``).

    Raises
    ------
    Exception
        A passing failure of the store for the whole group (see the module docstring).
    """
    template = template if template is not None else PyfuncTemplate()
    outcomes = _Outcomes(submissions, stop_at_error)
    fits: list[tuple[int, ResolvedFit]] = []
    for i, submission in enumerate(submissions):
        if outcomes.open(i):
            try:
                fits.append((i, submission.resolve()))
            except Exception as error:  # noqa: BLE001 - this fit's own
                outcomes.fail(i, error)
    writer = backend.sql_writer()
    assets = list(dict.fromkeys(fit.asset_id for _, fit in fits))
    if writer is None or not fits:
        for asset in assets:
            _asset_alone(backend, [f for f in fits if f[1].asset_id == asset], template,
                         outcomes, lock=True)
        return outcomes.items
    try:
        backend.ensure_registered_models({f.asset_id: f.submission.vehicle_class
                                          for _, f in fits})
    except Exception as error:  # noqa: BLE001
        if is_passing_failure(error):
            raise
        for asset in assets:     # each asset's own check names the culprit
            _asset_alone(backend, [f for f in fits if f[1].asset_id == asset], template,
                         outcomes, lock=True)
        return outcomes.items
    with backend.store.asset_locks(assets) as refused:
        for i, fit in fits:
            if fit.asset_id in refused and outcomes.open(i):
                outcomes.fail(i, refused[fit.asset_id])
        held = [(i, f) for i, f in fits if f.asset_id not in refused]
        try:
            _together(backend, writer, held, template, outcomes)
        except Exception as error:  # noqa: BLE001
            if is_passing_failure(error):
                raise
            logger.warning("recording %d fits together failed (%s: %s); recording them one "
                           "asset at a time", len(held), type(error).__name__, error)
            for asset in dict.fromkeys(f.asset_id for _, f in held):
                _asset_alone(backend, [(i, f) for i, f in held if f.asset_id == asset],
                             template, outcomes, lock=False)
    return outcomes.items


def _asset_alone(backend: Backend, fits: list[tuple[int, ResolvedFit]],
                 template: PyfuncTemplate, outcomes: _Outcomes, lock: bool) -> None:
    """One asset's fits by :func:`registry.write.recording.record_fit`'s path (under its
    lock, taken here when ``lock``), each fit's error its own."""
    if not fits:
        return
    asset = fits[0][1].asset_id
    try:
        if lock:
            backend.ensure_registered_models({asset: fits[0][1].submission.vehicle_class})
        with backend.store.asset_lock(asset) if lock else contextlib.nullcontext():
            alias = _Alias(backend, asset)
            for i, fit in fits:
                if not outcomes.open(i):
                    continue
                try:
                    outcomes.done(i, _record(backend, fit, template, alias))
                except Exception as error:  # noqa: BLE001 - this fit's own
                    if is_passing_failure(error):
                        raise
                    outcomes.fail(i, error)
            alias.flush()
    except Exception as error:  # noqa: BLE001 - the asset's: its open fits carry it
        if is_passing_failure(error):
            raise
        pending = [i for i, _ in fits if outcomes.open(i)] or [fits[-1][0]]
        for i in pending[:1] if outcomes.stop_at_error else pending:
            outcomes.fail(i, error)


def _together(backend: Backend, writer, fits: list[tuple[int, ResolvedFit]],
              template: PyfuncTemplate, outcomes: _Outcomes) -> None:
    """The held assets' fits: new candidates in one transaction, the others (already
    recorded, or a key seen twice) by the one-fit path; under the assets' locks."""
    experiments = {f.submission.vehicle_class: backend.experiment_id(
        f.submission.vehicle_class, create=True) for _, f in fits}
    found: dict[str, list] = {}
    for vehicle_class, experiment_id in experiments.items():
        keys = [f.key for _, f in fits if f.submission.vehicle_class == vehicle_class]
        found.update(call_with_retry(writer.runs_with_tags, experiment_id, naming.TAG_FIT_KEY,
                                     keys, policy=backend.retry, what="find the fits' runs"))
    new: list[tuple[int, ResolvedFit]] = []
    alone: list[tuple[int, ResolvedFit]] = []
    keys_new: set[str] = set()
    for i, fit in fits:
        s = fit.submission
        if fit.key in found or fit.key in keys_new or s.role != naming.CANDIDATE:
            alone.append((i, fit))
        else:
            new.append((i, fit))
            keys_new.add(fit.key)
    prepared: list[tuple[int, PreparedFit]] = []
    for i, fit in new:
        if not outcomes.open(i):
            continue
        s = fit.submission
        try:
            prepared.append((i, prepare(backend, writer, experiments[s.vehicle_class], fit,
                                        baseline_version_of(backend, s), template)))
        except Exception as error:  # noqa: BLE001 - this fit's own
            if is_passing_failure(error):
                _discard_all(writer, prepared)
                raise
            outcomes.fail(i, error)
    if prepared:
        try:
            numbers = call_with_retry(writer.write_many,
                                      [(p.run, p.version) for _, p in prepared],
                                      policy=backend.retry, what="record the group's fits")
        except Exception as error:  # noqa: BLE001
            if is_passing_failure(error) or not _surely_absent(writer,
                                                               prepared[0][1].run.run_id):
                _discard_all(writer, prepared)
                raise      # perhaps committed: the next attempt finds what was written
            logger.warning("recording %d fits in one transaction failed (%s: %s); writing "
                           "them one by one", len(prepared), type(error).__name__, error)
            numbers = None
        if numbers is not None:
            for (i, p), number in zip(prepared, numbers):
                outcomes.done(i, created_record(p.fit, p.run.run_id, number))
        else:
            for i, p in prepared:
                _write_alone(backend, writer, i, p, outcomes)
    for asset in dict.fromkeys(f.asset_id for _, f in alone):
        _asset_alone(backend, [(i, f) for i, f in alone if f.asset_id == asset], template,
                     outcomes, lock=False)


def _discard_all(writer, prepared: list[tuple[int, PreparedFit]]) -> None:
    for _, p in prepared:
        discard(writer, p)


def _write_alone(backend: Backend, writer, i: int, p: PreparedFit,
                 outcomes: _Outcomes) -> None:
    """One prepared fit in its own transaction (the group's failed); its error its own."""
    if not outcomes.open(i):
        discard(writer, p)
        return
    try:
        number = write_restoring_model(
            backend, p.fit.submission, p.run.experiment_id,
            lambda: call_with_retry(writer.write, p.run, p.version, policy=backend.retry,
                                    what="record the fit"))
    except Exception as error:  # noqa: BLE001 - this fit's own
        discard(writer, p)
        if is_passing_failure(error):
            raise
        outcomes.fail(i, error)
        return
    outcomes.done(i, created_record(p.fit, p.run.run_id, number))


__all__ = ["record_group"]
