"""Several independent solver runs side by side, their function evaluations batched.

A solver such as ``scipy.optimize.least_squares`` calls its function once per point,
one point after another. Fitting many independent problems whose functions are cheap to
evaluate together (a vectorised white box runs a batch of states in about the time of one)
would otherwise pay one evaluation per problem per point. :func:`run_in_lockstep` runs each
problem's own solver in its own thread, unchanged, and gathers their evaluation requests:
when every unfinished solver waits for a point, one batched call evaluates them all. Each
solver sees exactly the values it would see alone, so each result is the one it would give
alone; only the evaluations are shared. The threads do not compute in parallel (the
solvers' own work between evaluations is small); they are the solvers' places to wait, and
the batches are computed in the caller's thread.
"""
from __future__ import annotations

import threading
from typing import Callable, Sequence, TypeVar

Point = TypeVar("Point")
Value = TypeVar("Value")
Result = TypeVar("Result")


class _Gather:
    """Requests of the unfinished solvers, evaluated together when all of them wait."""

    def __init__(self, count: int):
        self.live = count
        self.pending: dict[int, object] = {}
        self.results: dict[int, tuple[bool, object]] = {}
        self.condition = threading.Condition()

    def evaluate(self, index: int, point):
        with self.condition:
            self.pending[index] = point
            self.condition.notify_all()
            while index not in self.results:
                self.condition.wait()
            ok, value = self.results.pop(index)
        if not ok:
            raise value
        return value

    def finished(self) -> None:
        with self.condition:
            self.live -= 1
            self.condition.notify_all()

    def serve(self, batch: Callable[[list[int], list], list]) -> None:
        """Evaluate the requests, in the calling thread, until every solver has finished."""
        with self.condition:
            while True:
                self.condition.wait_for(lambda: self.live == 0 or (
                    self.pending and len(self.pending) == self.live))
                if self.live == 0:
                    return
                indices = list(self.pending)
                points = [self.pending[i] for i in indices]
                self.pending.clear()
                try:
                    values = [(True, v) for v in batch(indices, points)]
                except Exception as error:  # noqa: BLE001 - raised in every waiting solver
                    values = [(False, error)] * len(indices)
                self.results.update(zip(indices, values))
                self.condition.notify_all()


def run_in_lockstep(solvers: Sequence[Callable[[Callable], Result]],
                    batch: Callable[[list[int], list[Point]], list[Value]]) -> list[Result]:
    """Run ``solvers[i](evaluate)`` side by side; ``evaluate(point)`` of solver ``i`` returns
    ``batch([.., i, ..], [.., point, ..])``'s value for it, computed once every unfinished
    solver has asked for one.

    Returns
    -------
    list
        Each solver's result, in order.

    Raises
    ------
    Exception
        The first solver's error (by index), after every solver has stopped.
    """
    gather = _Gather(len(solvers))
    results: list = [None] * len(solvers)
    errors: list = [None] * len(solvers)

    def run(index: int) -> None:
        try:
            results[index] = solvers[index](lambda point: gather.evaluate(index, point))
        except Exception as error:  # noqa: BLE001 - re-raised below
            errors[index] = error
        finally:
            gather.finished()

    threads = [threading.Thread(target=run, args=(i,), daemon=True) for i in range(len(solvers))]
    for thread in threads:
        thread.start()
    # the batches are computed here, in one thread: computed in the solvers' threads, their
    # large arrays spread over glibc's per-thread heaps, which kept them (the battery's cost
    # benchmark peaked 400 MiB higher)
    gather.serve(batch)
    for thread in threads:
        thread.join()
    for error in errors:
        if error is not None:
            raise error
    return results
