"""The legacy ``simx*`` functions, with ``vrep.py`` / ``sim.py``'s exact signatures and returns.

Each function coerces its arguments to plain Python at the edge (numpy scalars and
1-element arrays are accepted, as legacy programs pass them), sends one command through the
client's :class:`~simx_client.connection.Connection`, and shapes the legacy return tuple.
Return codes are ``simx_return_*`` flags; on any code but 0 the values are the legacy
defaults (handle 0, 0.0, ``[]``, ``bytearray()``), never made-up data. Values that the legacy
binding carried as ``c_float`` are rounded to float32 as it did.

No argument makes a ``simx*`` function raise: a value that cannot be converted (a dict, None,
an array of the wrong shape, a number beyond float32 or int32, a string that is not UTF-8...)
answers ``simx_return_local_error_flag`` (32) with the legacy default values, and one warning
in the ``simx.client`` log names the call and quotes the value cut short. The pure helpers
that have no return code (``simxPackInts``, ``simxPackFloats``, ``simxCreateBuffer``) raise
``LocalError`` instead, as the legacy ones raised ``struct.error`` or ``TypeError``.

This module holds the connection, simulation and pure helper functions and re-exports the
rest, grouped by concern: :mod:`simx_client.api_objects` (objects, joints, poses, parameters,
collisions), :mod:`simx_client.api_sensors`, :mod:`simx_client.api_scene` (scene editing) and
:mod:`simx_client.api_scripts` (scripts, signals, parameters, messages, GUI-only calls). They
share the argument coercions of :mod:`simx_client.coercion` and the connection registry and
command path of :mod:`simx_client.calls`.
"""

from __future__ import annotations

import atexit
import os
import struct
from typing import Any, Callable

import numpy as np

from simx_wire import constants as C
from simx_wire import protocol as P
from simx_client.connect import wait_connect
from simx_client.connection import DEFAULT_BLOCKING_TIMEOUT, PREFIX_ENV

# The simx* functions by concern; each module calls calls._command itself (no wrapper here).
from simx_client.api_objects import *  # noqa: F401,F403
from simx_client.api_scene import *  # noqa: F401,F403
from simx_client.api_scripts import *  # noqa: F401,F403
from simx_client.api_sensors import *  # noqa: F401,F403
# Private names kept importable from here (tests and benchmarks use them).
from simx_client.api_scene import _client_side  # noqa: F401
from simx_client.api_scripts import _signal_value  # noqa: F401
from simx_client.images import _LAZY_CLIENTS
from simx_client.api_sensors import _SIGNED_BYTES, _copy_image, _depth, _image  # noqa: F401
from simx_client.calls import _MAX_CONNECTIONS, _command, _connection, _connections, _registry_lock, log  # noqa: F401
from simx_client.coercion import (_F32, _INT_MAX, _INT_MIN, _bool, _bytes, _f32, _f32_input,  # noqa: F401
                                  _f32_list, _float, _floats, _int, _scalar, _str)


# -------------------------------------------------------------- connection
def simxStart(connectionAddress, connectionPort, waitUntilConnected, doNotReconnectOnceDisconnected,
              timeOutInMs, commThreadCycleInMs):
    """Connect to a simx server; returns a client id 0..254, or -1 (legacy ``simxStart``).

    A positive ``timeOutInMs`` bounds the connection wait; a negative one sets the blocking-call
    timeout to its absolute value and waits 5000 ms to connect. Connecting twice to the same
    address and port from one process fails (-1), as it did.

    ``commThreadCycleInMs`` (ms, usually 5) is the communication cycle: non-blocking commands
    wait in the client's outbox and leave together at most once per cycle (a blocking call takes
    them with it at once); 0 or less sends each batch as soon as the previous one is answered.

    The server's key-expression prefix (its ``--prefix``) is ``$SIMX_PREFIX``, ``simx`` when
    unset: several servers reached through one Zenoh router differ by prefix only.
    """
    try:
        address, port = _str(connectionAddress), _int(connectionPort)
        wait, timeout_ms = _bool(waitUntilConnected), _int(timeOutInMs)
        reconnect = not _bool(doNotReconnectOnceDisconnected)
        cycle = max(0, _int(commThreadCycleInMs)) / 1000.0
    except Exception as exc:
        log.warning("simxStart: bad argument: %s", exc)
        return -1
    prefix = os.environ.get(PREFIX_ENV) or P.DEFAULT_PREFIX
    blocking = DEFAULT_BLOCKING_TIMEOUT if timeout_ms >= 0 else -timeout_ms / 1000.0
    connect_wait = timeout_ms / 1000.0 if timeout_ms > 0 else DEFAULT_BLOCKING_TIMEOUT
    with _registry_lock:
        if any(c.address == address and c.port == port and c.prefix == prefix for c in _connections.values()):
            return -1
        free = next((i for i in range(_MAX_CONNECTIONS) if i not in _connections), None)
        if free is None:
            return -1
        conn = wait_connect(address, port, wait, connect_wait, blocking, reconnect, prefix, cycle)
        if conn is None:
            return -1
        _connections[free] = conn
        return free


def simxFinish(clientID):
    """Close one connection, or all with -1; returns None (legacy ``simxFinish``). Never hangs."""
    try:
        cid = _int(clientID)
    except Exception:
        return None
    with _registry_lock:
        ids = list(_connections) if cid == -1 else [cid]
        closing = [_connections.pop(i) for i in ids if i in _connections]
        _LAZY_CLIENTS.difference_update(ids)  # a later connection may get the same id
    for conn in closing:
        conn.close()
    return None


@atexit.register
def _finish_at_exit() -> None:
    """Close what the program left open: an open Zenoh session would hold up interpreter exit."""
    simxFinish(-1)


def simxGetConnectionId(clientID):
    """A number identifying the connection, -1 when not connected (legacy ``simxGetConnectionId``)."""
    conn = _connection(clientID)
    return conn.connection_id if conn is not None and conn.connected else -1


def simxGetPingTime(clientID):
    """Round trip of a no-op command in ms: ``(returnCode, pingTime)`` (legacy ``simxGetPingTime``).

    Executed in order with everything sent before it, so in synchronous mode it returns after
    the triggered step completed.
    """
    import time

    conn = _connection(clientID)
    if conn is None:
        return 0, 0  # the legacy client answers 0 here, not flag 64
    start = time.perf_counter()
    rc, _ = conn.call("GetPingTime", [], C.simx_opmode_blocking)
    return rc, int(round((time.perf_counter() - start) * 1000))


def simxGetLastCmdTime(clientID):
    """Simulation time in ms of the last reply read (legacy ``simxGetLastCmdTime``)."""
    conn = _connection(clientID)
    return 0 if conn is None else int(conn.last_cmd_time)


def simxPauseCommunication(clientID, enable):
    """Hold non-blocking commands (True), then send them together (False): 0, or 64."""
    conn = _connection(clientID)
    if conn is None:
        return C.simx_return_initialize_error_flag
    try:
        enable = _bool(enable)
    except Exception as exc:
        log.warning("simxPauseCommunication: bad argument: %s", exc)
        return C.simx_return_local_error_flag
    conn.pause_communication(enable)
    return C.simx_return_ok


def simxSynchronous(clientID, enable):
    """Enable or disable synchronous (stepped) mode; blocking (legacy ``simxSynchronous``)."""
    return _command(clientID, "Synchronous", lambda: [_bool(enable)], C.simx_opmode_blocking)[0]


def simxSynchronousTrigger(clientID):
    """Run one simulation step in synchronous mode; blocking (legacy ``simxSynchronousTrigger``)."""
    return _command(clientID, "SynchronousTrigger", lambda: [], C.simx_opmode_blocking)[0]


# -------------------------------------------------------------- simulation
def simxStartSimulation(clientID, operationMode):
    """Start (or resume) the simulation: returnCode."""
    return _command(clientID, "StartSimulation", lambda: [], operationMode)[0]


def simxPauseSimulation(clientID, operationMode):
    """Pause the simulation: returnCode."""
    return _command(clientID, "PauseSimulation", lambda: [], operationMode)[0]


def simxStopSimulation(clientID, operationMode):
    """Stop the simulation; the scene returns to its initial state: returnCode."""
    return _command(clientID, "StopSimulation", lambda: [], operationMode)[0]


# ------------------------------------------------------------ pack helpers
def _helper(name: str, make: Callable[[], Any]) -> Any:
    """Run a pure helper; any failure on its input raises LocalError naming the helper."""
    try:
        return make()
    except Exception as exc:
        raise P.LocalError(f"{name}: {type(exc).__name__}: {exc}") from exc


def simxPackInts(intList):
    """Little-endian int32s as a bytearray. Raises LocalError for a value that is not an int32
    (the legacy helper raised struct.error)."""
    return _helper("simxPackInts", lambda: bytearray(
        struct.pack(f"<{len(intList)}i", *[_int(v) for v in intList])))


def _unpack(name: str, data: Any, dtype: str) -> list:
    def make() -> list:
        raw = _bytes(data)
        return np.frombuffer(raw, dtype=dtype, count=len(raw) // 4).tolist()

    return _helper(name, make)


def simxUnpackInts(intsPackedInString):
    """List of int32s from a little-endian buffer (a trailing partial value is ignored, as the
    legacy helper did). Raises LocalError for a value that is not a buffer or a string."""
    return _unpack("simxUnpackInts", intsPackedInString, "<i4")


def simxPackFloats(floatList):
    """Little-endian float32s as a bytearray. Raises LocalError for a value that is not a
    number or is beyond float32 (the legacy helper raised struct.error or OverflowError)."""
    return _helper("simxPackFloats", lambda: bytearray(
        struct.pack(f"<{len(floatList)}f", *[_float(v) for v in floatList])))


def simxUnpackFloats(floatsPackedInString):
    """List of float32s (as Python floats) from a little-endian buffer (a trailing partial value
    is ignored, as the legacy helper did). Raises LocalError for a value that is not a buffer."""
    return _unpack("simxUnpackFloats", floatsPackedInString, "<f4")


# ------------------------------------------------------ connection details
def _message_info(clientID: Any, infoType: Any, incoming: bool) -> tuple[int, int]:
    conn = _connection(clientID)
    try:
        info = None if conn is None else (conn.in_message_info if incoming else conn.out_message_info)(_int(infoType))
    except Exception:
        info = None
    return (-1, 0) if info is None else (1, info)


def simxGetInMessageInfo(clientID, infoType):
    """``(result, info)`` about the last message received: result 1, or -1 when not connected or
    ``infoType`` is not a simx_headeroffset_* field."""
    return _message_info(clientID, infoType, incoming=True)


def simxGetOutMessageInfo(clientID, infoType):
    """``(result, info)`` about the last message sent: result 1, or -1."""
    return _message_info(clientID, infoType, incoming=False)


def simxCreateBuffer(bufferSize):
    """A zeroed ctypes ``c_ubyte`` buffer of ``bufferSize`` bytes (pointer), as the legacy call
    gave. Raises LocalError for a size that is not a non-negative int32."""
    import ctypes

    return _helper("simxCreateBuffer", lambda: ctypes.cast(
        (ctypes.c_ubyte * _int(bufferSize))(), ctypes.POINTER(ctypes.c_ubyte)))


def simxReleaseBuffer(buffer):
    """Release a buffer of :func:`simxCreateBuffer` (Python's memory management frees it): None."""
    return None
