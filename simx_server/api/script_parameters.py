"""V-REP's script simulation parameters as scripts see them (``simGetScriptSimulationParameter``,
``sim.getScriptSimulationParameter``, and the ``set`` twins).

A parameter's value is stored as bytes (the ``.ttt``'s, or what a script set). Scripts get it
typed as CoppeliaSim's ``pushCorrectTypeOntoLuaStack_old`` / ``getCorrectType_old`` push it:
``"nil"`` -> nil, ``"false"`` / ``"true"`` -> a boolean, text that reads as a number (boost's
``lexical_cast<double>``: no spaces, ``1e-3``, ``inf``, ``nan``) -> a number, anything else ->
the string, its bytes unchanged (binary data with embedded zeros included). Python scripts get
``bytes`` for a value that is not UTF-8 text, ``str`` otherwise; Lua strings carry the bytes.

``sim.handle_tree`` and ``sim.handle_chain`` name the child scripts of the objects below (tree)
or above (chain) the calling script's object, itself left out, as CoppeliaSim's
``getScriptTree_old`` / ``getScriptChain_old`` collect them for ``_simSetScriptSimulationParameter``.
"""

from __future__ import annotations

import base64
import binascii
import json
import re
from pathlib import Path
from typing import Any, Iterable

from simx_server.base import limits as L
from simx_wire.protocol import ArgumentError

#: boost::lexical_cast<double>'s accepted text (what V-REP pushes as a number).
_NUMBER = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan)", re.IGNORECASE)


def as_bytes(value: Any) -> bytes:
    """The stored bytes of a value (str as UTF-8, a number as Lua writes it)."""
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value)
    if isinstance(value, bool):
        return b"true" if value else b"false"
    if isinstance(value, float) and value.is_integer():
        return str(int(value)).encode()
    return str(value).encode("utf-8")


def _text_or_bytes(raw: bytes) -> str | bytes:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw


def typed(value: Any) -> Any:
    """The value as V-REP pushes it (module docstring): None, bool, int/float, str or bytes.

    Args:
        value: the stored value (bytes or str; numbers are taken as their text).

    Returns:
        None for ``"nil"``, a bool for ``"false"``/``"true"``, an int (integral text) or float for
        a number, else the string (str when UTF-8 text, else bytes).
    """
    raw = as_bytes(value)
    if b"\x00" in raw:
        return _text_or_bytes(raw)  # embedded zeros: always a string
    if raw == b"nil":
        return None
    if raw in (b"false", b"true"):
        return raw == b"true"
    text = raw.decode("latin-1")
    if _NUMBER.fullmatch(text):
        number = float(text)
        if re.fullmatch(r"[+-]?\d+", text) and abs(number) < 2 ** 53:
            return int(text)
        return number
    return _text_or_bytes(raw)


def as_string(value: Any) -> str | bytes:
    """The value with ``forceStringReturn``: the stored bytes as a string (bytes when not UTF-8)."""
    return _text_or_bytes(as_bytes(value))


def load(folder: Path, name: str, file: str | None) -> list[dict]:
    """The script simulation parameters of ``file`` (JSON next to the scene: a list of
    ``{"name", "value" | "value_base64", "unit"}``); [] without a file. Values are kept as
    given (text) or as bytes (``value_base64``).

    Args:
        folder: the scene's folder; name: the object's name, for errors; file: the JSON file.

    Raises:
        ValueError: a file outside the folder, missing, larger than MAX_SCRIPT_CALL_BYTES or not
            such a list (bad base64 included).
    """
    if not file:
        return []
    path = (folder / file).resolve()
    if folder.resolve() not in path.parents or not path.is_file():
        raise ValueError(f"script_parameters {file!r} of {name!r} not found in {folder}")
    if path.stat().st_size > L.MAX_SCRIPT_CALL_BYTES:
        raise ValueError(f"script_parameters {file!r} of {name!r} is larger than {L.MAX_SCRIPT_CALL_BYTES} bytes")
    try:
        items = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"script_parameters {file!r} of {name!r}: {exc}") from None
    if not isinstance(items, list) or not all(isinstance(i, dict) and isinstance(i.get("name"), str)
                                               for i in items):
        raise ValueError(f"script_parameters {file!r} of {name!r} must be a JSON list of "
                         '{"name", "value", "unit"} objects')
    out = []
    for i in items:
        value = i.get("value", "")
        if "value_base64" in i:
            try:
                value = base64.b64decode(str(i["value_base64"]), validate=True)
            except (binascii.Error, ValueError) as exc:
                raise ValueError(f"script_parameters {file!r} of {name!r}: parameter {i['name']!r}: "
                                 f"value_base64: {exc}") from None
        out.append({"name": i["name"], "value": value, "unit": i.get("unit", "")})
    return out


def tree(world: Any, owner: int) -> list[int]:
    """The objects below ``owner`` (any depth), in handle order: ``sim.handle_tree``'s scripts'
    objects (``getScriptTree_old``, the caller left out)."""
    out = []
    for h in sorted(world.objects):
        p, steps = world.objects[h].parent, 0
        while p in world.objects and p != owner and steps < len(world.objects):
            p, steps = world.objects[p].parent, steps + 1
        if p == owner and h != owner:
            out.append(h)
    return out


def chain(world: Any, owner: int) -> list[int]:
    """The objects above ``owner``, nearest first: ``sim.handle_chain``'s scripts' objects
    (``getScriptChain_old``, the caller left out)."""
    out, p = [], world.objects[owner].parent if owner in world.objects else -1
    while p in world.objects and p not in out:
        out.append(p)
        p = world.objects[p].parent
    return out


def stored(lists: Iterable[list]) -> tuple[int, int]:
    """``(entries, bytes)`` of parameter lists (names and values)."""
    entries = size = 0
    for params in lists:
        entries += len(params)
        size += sum(len(p.get("name", "")) + len(as_bytes(p.get("value") or b"")) for p in params)
    return entries, size


def admit(lists: Iterable[list], params: list, name: str, value: bytes, room: int | None = None) -> None:
    """Check that setting ``name`` to ``value`` in ``params`` keeps the parameters of ``lists``
    (every list of the scene's scripts and objects, ``params`` among them) within their bounds.

    Args:
        room: bytes the scripts' memory has left (limits.MAX_SCRIPTS_MEMORY less what the Lua
            states and the parameters hold), or None.

    Raises:
        ArgumentError: past limits.MAX_SIGNAL_NAME, MAX_PARAMETER_BYTES, MAX_PARAMETERS,
            MAX_PARAMETER_STORE_BYTES or the scripts' memory; nothing is set.
    """
    if len(name) > L.MAX_SIGNAL_NAME:
        raise ArgumentError(f"parameter name of {len(name)} characters: at most {L.MAX_SIGNAL_NAME} "
                            "(limits.MAX_SIGNAL_NAME)")
    if len(value) > L.MAX_PARAMETER_BYTES:
        raise ArgumentError(f"parameter {name[:100]!r}: a value of {len(value)} bytes, at most "
                            f"{L.MAX_PARAMETER_BYTES} (limits.MAX_PARAMETER_BYTES)")
    entries, size = stored(lists)
    old = next((p for p in params if p.get("name") == name), None)
    grow = len(value) - (len(as_bytes(old.get("value") or b"")) if old is not None else -len(name))
    if old is None and entries >= L.MAX_PARAMETERS:
        raise ArgumentError(f"parameter {name[:100]!r} not added: the scene's scripts and objects have "
                            f"{entries} parameters already (limits.MAX_PARAMETERS)")
    if size + grow > L.MAX_PARAMETER_STORE_BYTES:
        raise ArgumentError(f"parameter {name[:100]!r} not set: the scene's parameters would hold {size + grow} "
                            f"bytes, more than {L.MAX_PARAMETER_STORE_BYTES} (limits.MAX_PARAMETER_STORE_BYTES)")
    if room is not None and grow > room:
        raise ArgumentError(f"parameter {name[:100]!r} not set: {grow} more bytes would pass the memory of the "
                            f"scene's scripts ({room} left; limits.MAX_SCRIPTS_MEMORY, their Lua states and "
                            "parameters together)")
