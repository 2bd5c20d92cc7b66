"""Values kept per MuJoCo model or data (or any object), for the hot paths that would otherwise
compute the same answer at every step or call: :class:`PerObject` keeps one value per object,
weakly; :func:`entry` a bounded table of answers by key."""

from __future__ import annotations

import weakref
from collections.abc import Callable
from typing import Any

__all__ = ["PerObject", "entry"]


class PerObject:
    """Values kept per object, made by ``make(obj)`` at its first call and kept weakly (an object
    that is gone drops out with its value); the one asked for last is answered first (a step
    asks several times).

    Args:
        make: makes an object's value.
    """

    __slots__ = ("last", "make", "table")

    def __init__(self, make: Callable[[Any], Any]):
        self.make = make
        self.table: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
        self.last: tuple = (lambda: None, None)

    def __call__(self, obj: Any) -> Any:
        last = self.last
        if last[0]() is obj:
            return last[1]
        value = self.table.get(obj)
        if value is None:
            value = self.table[obj] = self.make(obj)
        self.last = (weakref.ref(obj), value)  # one assignment: a thread reads it whole
        return value


_MISSING = object()


def entry(table: dict, key: object, make: Callable[[], object], limit: int) -> Any:
    """``table[key]``, made by ``make()`` when missing (the table emptied first when it holds
    ``limit`` entries: a bound on what a scene of ever-changing keys keeps).

    Args:
        table: the kept answers.
        key: the answer's key.
        make: makes the answer.
        limit: the most entries kept.

    Returns:
        The answer.
    """
    value = table.get(key, _MISSING)
    if value is _MISSING:
        if len(table) >= limit:
            table.clear()
        value = table[key] = make()
    return value
