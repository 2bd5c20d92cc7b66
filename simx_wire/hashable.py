"""Hashable stand-ins for the arguments that identify a legacy command (:func:`simx_wire.protocol.identity`):
any msgpack value a client sends, nested to any depth, made hashable without deep recursion.
"""

from __future__ import annotations

from typing import Any

#: Container levels of an identifying argument kept as nested tuples; deeper levels are
#: flattened into one tuple of tokens (built without recursion). Legacy arguments are flat.
IDENTITY_DEPTH = 16


def _hashable(value: Any, depth: int = IDENTITY_DEPTH) -> Any:
    """A hashable stand-in for ``value``: lists (and tuples) become tuples, dicts the tuple
    ``(key1, value1, key2, value2, ...)``, other unhashable values (never from msgpack) their type and repr.
    Levels deeper than ``depth`` become one flat tuple of tokens, so that a value nested 1,000
    deep costs no deep recursion (here, nor when hashing or comparing the result).

    Sent through msgpack and read back (tuples as arrays), the result maps to itself: the
    identity a server puts in a stream update is the one its client computed.
    """
    t = type(value)
    if t is list or t is tuple:
        if depth > 0:
            return tuple([_hashable(v, depth - 1) for v in value])
        if not any(type(v) in _CONTAINERS for v in value):
            return tuple([_leaf(v) for v in value])  # as flat as _flat's tokens read back
        return _flat(value)
    if t is dict:
        if depth > 0:
            return tuple([_hashable(x, depth - 1) for item in value.items() for x in item])
        return _flat(value)
    if depth > 0:
        try:
            hash(value)
        except TypeError:
            return (t.__name__, repr(value))
    return _leaf(value)


_CONTAINERS = (list, tuple, dict)


def _leaf(value: Any) -> Any:
    try:
        hash(value)
    except TypeError:
        return f"<{type(value).__name__}> {value!r}"
    return value


def _flat(value: Any) -> tuple[Any, ...]:
    """Tokens of a nested value in depth-first order (``"["`` or ``"{"`` and the size open a
    container), built with an explicit stack."""
    tokens: list[Any] = []
    stack = [value]
    while stack:
        v = stack.pop()
        t = type(v)
        if t is list or t is tuple:
            tokens += ("[", len(v))
            stack.extend(reversed(v))
        elif t is dict:
            tokens += ("{", len(v))
            for k, item in reversed(list(v.items())):
                stack += (item, k)
        else:
            tokens.append(_leaf(v))
    return tuple(tokens)
