"""Automatic switching of threaded Lua scripts anywhere in their code, as V-REP switches a threaded
script when its time slice ends (``sim.setThreadAutomaticSwitch``, on by default;
``sim.setThreadSwitchTiming``, 2 ms by default): coppeliaSimLib's
``CDetachedScript::_hookFunction_lua``, a count hook in C, calls ``lua_yield`` when
``shouldAutoYield`` finds the slice over and automatic switching allowed.

A Lua hook written in Lua cannot yield (``debug.sethook``'s hook is called through a C function:
"attempt to yield across a C-call boundary"); a hook written in C can, for count events (Lua 5.4,
``lua_yield`` with no results inside a hook: the VM undoes the instruction and yields). So when
the script's count hook (the time bound of :mod:`simx_server.scripts.lua_prelude`, in Lua) finds
the thread's slice used up, it calls :func:`arm`: the thread's hook becomes, for one instruction,
:data:`_YIELD`, a C-callable function that puts the thread's own hook back and yields the thread
if it can yield there (not inside a C function's callback such as ``table.sort``'s comparator:
then it just goes on, and the next count hook tries again). Only Lua C API calls that never raise
are made from it (``lua_sethook``, ``lua_isyieldable``, ``lua_yieldk`` after the check), so no Lua
error ever crosses this Python frame.

The Lua C API comes from lupa's own Lua 5.4 module (its shared library exports it); the thread's
``lua_State`` is its address as ``string.format("%p", co)`` writes it.
"""

from __future__ import annotations

import ctypes
from typing import Any

__all__ = ["arm", "available", "disarm"]

_LUA_MASKCOUNT = 1 << 3  # lua.h: LUA_MASKCOUNT = 1 << LUA_HOOKCOUNT
_HOOK = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)


def _library() -> Any:
    try:
        import lupa.lua54 as lua54
        lib = ctypes.CDLL(lua54.__file__)
        lib.lua_sethook.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int]
        lib.lua_sethook.restype = None
        lib.lua_gethook.argtypes = [ctypes.c_void_p]
        lib.lua_gethook.restype = ctypes.c_void_p
        lib.lua_gethookmask.argtypes = lib.lua_gethookcount.argtypes = [ctypes.c_void_p]
        lib.lua_gethookmask.restype = lib.lua_gethookcount.restype = ctypes.c_int
        lib.lua_isyieldable.argtypes = [ctypes.c_void_p]
        lib.lua_isyieldable.restype = ctypes.c_int
        lib.lua_yieldk.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p]
        lib.lua_yieldk.restype = ctypes.c_int
        return lib
    except (ImportError, OSError, AttributeError):  # no lupa, or a build that does not export the C API
        return None


_LIB = _library()
#: thread address -> (its hook, mask, count) before :func:`arm`.
_saved: dict[int, tuple[int | None, int, int]] = {}


def _yield_now(state: int, _ar: int) -> None:
    """The one-instruction hook: the thread's own hook back, then a yield where allowed."""
    hook, mask, count = _saved.pop(state, (None, 0, 0))
    _LIB.lua_sethook(state, hook, mask, count)
    if _LIB.lua_isyieldable(state):
        _LIB.lua_yieldk(state, 0, None, None)


_YIELD = _HOOK(_yield_now)
_YIELD_ADDRESS = ctypes.cast(_YIELD, ctypes.c_void_p).value


def available() -> bool:
    """Whether lupa's Lua C API could be reached (else threads switch only at ``sim`` calls)."""
    return _LIB is not None


def _address(pointer: Any) -> int | None:
    text = pointer.decode() if isinstance(pointer, bytes) else str(pointer)
    try:
        return int(text, 16)
    except ValueError:
        return None


def arm(pointer: Any) -> None:
    """Make the thread at ``pointer`` (``"%p"`` of a Lua coroutine that is running now) yield at
    its next instruction, if it can yield there.

    Args:
        pointer: the coroutine's address as Lua's ``%p`` writes it (bytes or str, hexadecimal).
    """
    state = _address(pointer)
    if _LIB is None or not state:
        return
    hook = _LIB.lua_gethook(state)
    if hook != _YIELD_ADDRESS:
        _saved[state] = (hook, _LIB.lua_gethookmask(state), _LIB.lua_gethookcount(state))
    _LIB.lua_sethook(state, _YIELD_ADDRESS, _LUA_MASKCOUNT, 1)


def disarm(pointer: Any) -> None:
    """Put back the hook of the thread at ``pointer`` if :func:`arm`'s yield did not happen (the
    thread returned, or was interrupted, first). The thread must still exist.

    Args:
        pointer: the coroutine's address, as for :func:`arm`.
    """
    state = _address(pointer)
    if _LIB is None or not state or state not in _saved:
        return
    hook, mask, count = _saved.pop(state)
    if _LIB.lua_gethook(state) == _YIELD_ADDRESS:
        _LIB.lua_sethook(state, hook, mask, count)
