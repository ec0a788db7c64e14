"""Variants of one white box, differing in number parameters only, evaluated as one batch.

A diagnosis runs the white box once per hypothesis and trial value
(:mod:`graybox.diagnosis`): the same model class with one parameter changed. Where each run is
many short calls (a hidden state's start fitted over its first quarter hour, one sample after
another, a few rows at a time: the EV battery's diagnosis spent three quarters of its time
there), the calls' overhead, not their arithmetic, is the cost, and runs of several variants
side by side cost about what one does. That needs one model whose parameters are arrays with
one value per row: each row computes with its own variant's values.

A white box is written for scalar parameters, and nothing promises that it broadcasts an
array in their place (a ``math.exp`` of a parameter, an ``if`` on one, a value derived in its
constructor). :func:`row_variants` therefore probes the class: its derivatives and outputs,
at a few given states, with the per-row parameters must be *bitwise* those of each variant on
its own (elementwise arithmetic with a parameter broadcast per row is the same IEEE operation
as with the scalar), and each variant must compute differently from the first there (else
the probe could not tell a model that ignores the per-row values, one that read its
parameters once in its constructor, from one that uses them); where not, or where the call
fails, there is no row model and the caller runs the variants one by one.
"""
from __future__ import annotations

import copy
from typing import Callable, Sequence

import numpy as np

from graybox.models.base import WhiteBoxModel
from graybox.parameter_estimation import float_parameters

#: states probed per variant (rows spread over the data's own states)
PROBE_ROWS = 8


def row_variants(variants: Sequence[WhiteBoxModel], x: np.ndarray, u: np.ndarray
                 ) -> Callable[[np.ndarray], WhiteBoxModel] | None:
    """A function from each row's variant index (shape (R,)) to a model whose number
    parameters are those rows' values, or None where the class does not compute so.

    Parameters
    ----------
    variants : sequence of WhiteBoxModel
        Models of one class and column map that differ in number parameters only (as
        :func:`graybox.parameter_estimation.with_parameters` makes them).
    x : ndarray (P, n_states), u : ndarray (P, n_inputs)
        States and inputs to probe at (:data:`PROBE_ROWS` rows spread over them).

    Returns
    -------
    callable or None
        ``rows(index)``: the model for rows whose variants are ``variants[index]``; None if
        the variants are not of one class, the per-row model's derivatives or outputs at the
        probed states are not bitwise each variant's own (or raise), or a variant computes
        there exactly as the first although its parameters differ.
    """
    first = variants[0]
    if any(type(v) is not type(first) or v.columns != first.columns for v in variants):
        return None
    names = float_parameters(first)
    values = {name: np.array([float(v.parameters[name]) for v in variants]) for name in names}
    varying = {name: column for name, column in values.items()
               if np.any(column != column[0])}

    def rows(index: np.ndarray) -> WhiteBoxModel:
        model = copy.copy(first)
        model.parameters = {**first.parameters,
                            **{name: column[index] for name, column in varying.items()}}
        return model

    x, u = np.asarray(x, dtype=float), np.asarray(u, dtype=float).reshape(len(x), -1)
    if not len(x):
        return None
    probes = np.unique(np.linspace(0, len(x) - 1, PROBE_ROWS).astype(int))
    x, u = x[probes], u[probes]
    index = np.repeat(np.arange(len(variants)), len(x))
    stacked_x, stacked_u = np.tile(x, (len(variants), 1)), np.tile(u, (len(variants), 1))
    try:
        with np.errstate(all="ignore"):
            together = rows(index)
            derivatives = together.derivatives(stacked_x, stacked_u)
            outputs = together.output(stacked_x, stacked_u)
            alone = [(v.derivatives(x, u), v.output(x, u)) for v in variants]
            alone_d = np.concatenate([d for d, _ in alone])
            alone_o = np.concatenate([o for _, o in alone])
    except Exception:  # noqa: BLE001 - a class that does not broadcast: no row model
        return None
    if not (np.shape(derivatives) == alone_d.shape and np.shape(outputs) == alone_o.shape
            and np.array_equal(derivatives, alone_d, equal_nan=True)
            and np.array_equal(outputs, alone_o, equal_nan=True)):
        return None
    # every variant that differs from the first must compute differently from it
    (first_d, first_o) = alone[0]
    for b, (d, o) in enumerate(alone[1:], start=1):
        if (any(column[b] != column[0] for column in varying.values())
                and np.array_equal(d, first_d, equal_nan=True)
                and np.array_equal(o, first_o, equal_nan=True)):
            return None
    return rows
