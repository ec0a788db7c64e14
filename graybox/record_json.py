"""JSON dicts of frozen dataclass records, and the records back, driven by their fields.

:func:`to_dict` writes a record field by field; :func:`from_dict` rebuilds it from the
field types (``typing.get_type_hints``), checking every value on the way, so that every
record of an artifact (signature, calibration, settings) is read by the same code and
anything malformed raises :class:`~graybox.exceptions.ArtifactError` naming the record and
the field (:func:`to_json` and :func:`parse_json` are the same as JSON text). Supported
field types:

- ``bool``, ``int``, ``float`` (an integer is accepted and made a float), ``str``, ``Any``;
- another dataclass record (a JSON object);
- ``tuple[X, ...]`` and fixed ``tuple[X, Y]`` (a JSON array), nested to any depth;
- ``FrozenMap[str, X]`` or ``Mapping[str, X]`` (a JSON object, read as a
  :class:`~graybox.frozen_map.FrozenMap`), ``dict`` and ``dict[str, X]`` (read as a dict);
- unions such as ``float | None`` or ``float | str``: ``None`` where allowed, otherwise the
  first member the value fits.

A ``float`` must be finite (JSON's ``NaN`` and ``Infinity`` are refused: a NaN epsilon or
weight would silently disable alarms or break a fit), except in the fields a record names
in its class attribute ``non_finite_fields`` (diagnostics such as a test statistic).

Fields a record names in its class attribute ``omitted_when_none`` are left out of the dict
while None (a field added later: records without it are written as older code wrote them).

Fields a record names in its class attribute ``transient_fields`` are never written and take
their default when read (what a computation hands its caller in memory, e.g. arrays for a
plot, beside the record proper); they are unknown fields in a dict read.

A record that reads dicts stored by older code defines a classmethod ``migrate(data) ->
dict`` that turns such a dict into today's fields; :func:`from_dict` applies it first,
wherever the record is nested. (The pattern follows the ``to_dict`` / ``from_dict`` of
Merlion's ``PostRuleBase``: a config is its constructor's arguments.)
"""
from __future__ import annotations

import dataclasses
import functools
import json
import math
import types
import typing
from collections.abc import Mapping
from typing import Any, Union, get_args, get_origin, get_type_hints

from graybox.exceptions import ArtifactError
from graybox.frozen_map import FrozenMap

_KINDS = {bool: ("true or false", (bool,)), int: ("an integer", (int,)),
          float: ("a number", (int, float)), str: ("a string", (str,))}


def to_dict(record: Any) -> dict:
    """A JSON-ready dict of a dataclass record: nested records become dicts, tuples lists.

    :func:`from_dict` gives back an equal record; ``json.dumps`` writes every float exactly.
    """
    if not (dataclasses.is_dataclass(record) and not isinstance(record, type)):
        raise TypeError(f"to_dict needs a dataclass record, got {type(record).__name__}")
    omitted = getattr(record, "omitted_when_none", frozenset())
    transient = getattr(record, "transient_fields", frozenset())
    return {f.name: _encode(getattr(record, f.name)) for f in dataclasses.fields(record)
            if f.name not in transient
            and not (f.name in omitted and getattr(record, f.name) is None)}


def from_dict(cls: type, data: Any):
    """Rebuild a ``cls`` record from :func:`to_dict`'s dict (or JSON parsed from it).

    Parameters
    ----------
    cls : type
        A dataclass; fields with a default may be absent from ``data``.
    data : Any
        Expected to be a dict; checked.

    Returns
    -------
    cls

    Raises
    ------
    ArtifactError
        If ``data`` is not an object, has unknown or misses required fields, a value has
        the wrong type, or the record's own checks refuse it; the message names the record
        and the field.
    """
    name = cls.__name__
    if not isinstance(data, Mapping):
        raise ArtifactError(f"{name}: expected an object, got {type(data).__name__}")
    migrate = getattr(cls, "migrate", None)
    if migrate is not None:
        data = migrate(data)
    transient = getattr(cls, "transient_fields", frozenset())
    fields = [f for f in dataclasses.fields(cls) if f.name not in transient]
    names = {f.name for f in fields}
    required = {f.name for f in fields
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING}
    unknown, missing = set(data) - names, required - set(data)
    if unknown:
        raise ArtifactError(f"{name}: unknown field(s) {sorted(unknown)}")
    if missing:
        raise ArtifactError(f"{name}: missing field(s) {sorted(missing)}")
    hints = _type_hints(cls)
    non_finite = getattr(cls, "non_finite_fields", frozenset())
    values = {f.name: _decode(hints[f.name], data[f.name], f"{name}.{f.name}",
                              f.name not in non_finite)
              for f in fields if f.name in data}
    try:
        return cls(**values)
    except (TypeError, ValueError) as error:
        raise ArtifactError(f"{name}: {error}") from None


@functools.lru_cache(maxsize=None)
def _type_hints(cls: type) -> dict:
    # a record class's hints never change, and resolving them is most of a record's read
    return get_type_hints(cls)


def to_json(record: Any, indent: int | None = None) -> str:
    """:func:`to_dict` of a record as JSON text."""
    return json.dumps(to_dict(record), indent=indent)


def parse_json(text: str | bytes, what: str) -> Any:
    """JSON text of a record, parsed (for :func:`from_dict`).

    Raises
    ------
    ArtifactError
        If ``text`` is not JSON (``"<what> is not valid JSON: ..."``).
    """
    try:
        return json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise ArtifactError(f"{what} is not valid JSON: {error}") from None


def _encode(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return to_dict(value)
    if isinstance(value, (tuple, list)):
        return [_encode(item) for item in value]
    if isinstance(value, Mapping):
        return {key: _encode(item) for key, item in value.items()}
    return value


def _decode(hint: Any, value: Any, where: str, finite: bool = True) -> Any:
    origin, args = get_origin(hint), get_args(hint)
    if origin is Union or origin is types.UnionType:
        return _decode_union(args, value, where, finite)
    if hint is Any:
        return value
    if value is None:
        raise ArtifactError(f"{where} must not be null")
    if dataclasses.is_dataclass(hint):
        return from_dict(hint, value)
    if hint in _KINDS:
        return _decode_scalar(hint, value, where, finite)
    if hint is tuple or origin is tuple:
        return _decode_tuple(args, value, where, finite)
    if hint is dict or origin in (dict, FrozenMap, Mapping, typing.Mapping) or hint is FrozenMap:
        return _decode_mapping(hint, origin, args, value, where, finite)
    raise TypeError(f"{where}: records cannot read a field of type {hint!r}")


def _decode_union(args: tuple, value: Any, where: str, finite: bool) -> Any:
    if value is None:
        if type(None) in args:
            return None
        raise ArtifactError(f"{where} must not be null")
    members = [a for a in args if a is not type(None)]
    errors = []
    for member in members:
        try:
            return _decode(member, value, where, finite)
        except ArtifactError as error:
            errors.append(str(error))
    if len(errors) == 1:
        raise ArtifactError(errors[0])
    raise ArtifactError(f"{where} must be {' or '.join(_describe(m) for m in members)}, "
                        f"got {value!r}")


def _decode_scalar(kind: type, value: Any, where: str, finite: bool) -> Any:
    description, accepted = _KINDS[kind]
    if not isinstance(value, accepted) or (kind is not bool and isinstance(value, bool)):
        raise ArtifactError(f"{where} must be {description}")
    if kind is float and finite and not math.isfinite(value):
        raise ArtifactError(f"{where} must be a finite number, got {value!r}")
    return kind(value)


def _decode_tuple(args: tuple, value: Any, where: str, finite: bool) -> tuple:
    if not isinstance(value, (list, tuple)):
        raise ArtifactError(f"{where} must be an array, got {type(value).__name__}")
    if not args:
        return tuple(value)
    if len(args) == 2 and args[1] is Ellipsis:
        if args[0] is float and _all_numbers(value, finite):
            # a run of numbers (coefficients, weights) checked at once: what the item by item
            # path below returns for them, which names the first bad item otherwise
            return tuple(map(float, value))
        return tuple(_decode(args[0], item, f"{where}[{i}]", finite)
                     for i, item in enumerate(value))
    if len(value) != len(args):
        raise ArtifactError(f"{where} must have {len(args)} items, got {len(value)}")
    return tuple(_decode(arg, item, f"{where}[{i}]", finite)
                 for i, (arg, item) in enumerate(zip(args, value)))


def _all_numbers(values, finite: bool) -> bool:
    """Whether every item is a JSON number (an int or a float, not a bool), finite when
    ``finite``: what :func:`_decode_scalar` accepts as a float."""
    kinds = set(map(type, values))
    if not kinds <= {int, float}:
        return False
    return not finite or float not in kinds or all(map(math.isfinite, values))


def _decode_mapping(hint: Any, origin: Any, args: tuple, value: Any, where: str,
                    finite: bool) -> Any:
    if not isinstance(value, Mapping):
        raise ArtifactError(f"{where} must be an object, got {type(value).__name__}")
    if args:
        key_type, value_type = args
        if key_type is not str:
            raise TypeError(f"{where}: JSON objects have string keys, not {key_type!r}")
        value = {key: _decode(value_type, item, f"{where}[{key!r}]", finite)
                 for key, item in value.items()}
    return dict(value) if dict in (hint, origin) else FrozenMap(value)


def _describe(hint: Any) -> str:
    return _KINDS[hint][0] if hint in _KINDS else getattr(hint, "__name__", str(hint))
