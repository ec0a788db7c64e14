"""An immutable, hashable, ordered mapping: the dict of a frozen record.

A frozen record (a white box's parameters and column map in
:class:`graybox.models.spec.ModelSpec`) cannot hold a dict and stay hashable; it holds a
:class:`FrozenMap`, which compares equal to a dict with the same items and keeps their
order, so that it is written to JSON exactly as the dict was.
"""
from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any, TypeVar

K = TypeVar("K")
V = TypeVar("V")


class FrozenMap(Mapping[K, V]):
    """A read-only mapping with a hash.

    Parameters
    ----------
    items : mapping or iterable of (key, value) pairs, optional
        Copied, so later changes of the caller's dict do not reach the map. Values must be
        hashable for the map to be.

    Examples
    --------
    >>> parameters = FrozenMap({"gamma": 0.06})
    >>> parameters == {"gamma": 0.06}, hash(parameters) == hash(FrozenMap(gamma=0.06))
    (True, True)
    """

    __slots__ = ("_items",)

    def __init__(self, items: Mapping[K, V] | Any = (), **more: V):
        self._items: dict[K, V] = dict(items, **more)

    def __getitem__(self, key: K) -> V:
        return self._items[key]

    def __iter__(self) -> Iterator[K]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __hash__(self) -> int:
        return hash(frozenset(self._items.items()))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Mapping):
            return NotImplemented
        return self._items == dict(other.items())

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._items!r})"
