"""The legacy ``simx*`` functions, with ``vrep.py`` / ``sim.py``'s exact signatures and returns.

Each function coerces its arguments to plain Python at the edge (numpy scalars and
1-element arrays are accepted, as legacy programs pass them), sends one command through the
client's :class:`~simx_client.connection.Connection`, and shapes the legacy return tuple.
Return codes are ``simx_return_*`` flags; on any code but 0 the values are the legacy
defaults (handle 0, 0.0, ``[]``, ``bytearray()``), never made-up data. Values that the legacy
binding carried as ``c_float`` are rounded to float32 as it did.
"""

from __future__ import annotations

import itertools
import logging
import struct
import threading
from typing import Any, Callable

import numpy as np

from simx_client import constants as C
from simx_client import protocol as P
from simx_client.connection import DEFAULT_BLOCKING_TIMEOUT, Connection, wait_connect

log = logging.getLogger("simx.client")

_MAX_CONNECTIONS = 255  # MAX_EXT_API_CONNECTIONS: client ids 0..254
_connections: dict[int, Connection] = {}
_connection_ids: dict[int, int] = {}
_registry_lock = threading.Lock()
_connection_counter = itertools.count(1)


# ------------------------------------------------------------------ coercion
def _scalar(value: Any) -> Any:
    """A Python scalar from a Python/numpy scalar or a 1-element array."""
    if isinstance(value, (int, float, bool, str, bytes)):
        return value
    array = np.asarray(value)
    if array.size != 1:
        raise P.LocalError(f"expected a single value, got an array of shape {array.shape}")
    return array.reshape(()).item()


def _int(value: Any) -> int:
    v = _scalar(value)
    if isinstance(v, bool) or not isinstance(v, int):
        raise P.LocalError(f"expected an integer, got {type(v).__name__} {v!r}")
    return int(v)


def _bool(value: Any) -> bool:
    return bool(_scalar(value))


def _float(value: Any) -> float:
    v = _scalar(value)
    if isinstance(v, (bool, str, bytes)) or not isinstance(v, (int, float)):
        raise P.LocalError(f"expected a number, got {type(v).__name__} {v!r}")
    return float(v)


def _str(value: Any) -> str:
    v = _scalar(value)
    if isinstance(v, (bytes, bytearray)):
        return bytes(v).decode("utf-8")
    if not isinstance(v, str):
        raise P.LocalError(f"expected a string, got {type(v).__name__}")
    return v


def _bytes(value: Any) -> bytes:
    if isinstance(value, str):
        return value.encode("utf-8")
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value)
    return np.asarray(value).astype(np.uint8).tobytes()


def _f32(value: float) -> float:
    return float(np.float32(value))


def _f32_list(values: list) -> list[float]:
    return np.asarray(values, dtype=np.float32).tolist()


# ------------------------------------------------------------------- plumbing
def _connection(client_id: Any) -> Connection | None:
    try:
        return _connections.get(_int(client_id))
    except P.LocalError:
        return None


def _command(clientID: Any, name: str, make_args: Callable[[], list], operationMode: Any,
             convert: Callable[[Any], Any] = lambda v: v, default: Any = None) -> tuple[int, Any]:
    """Run one command; returns ``(return code, converted value or default)``."""
    conn = _connection(clientID)
    if conn is None:
        return C.simx_return_initialize_error_flag, default
    try:
        args = make_args()
        mode = _int(operationMode)
    except (P.LocalError, TypeError, ValueError, UnicodeError) as exc:
        log.warning("simx%s: bad argument: %s", name, exc)
        return C.simx_return_local_error_flag, default
    rc, value = conn.call(name, args, mode)
    if rc != C.simx_return_ok:
        if rc & C.simx_return_remote_error_flag:
            log.debug("simx%s: remote error: %s", name, value)
        return rc, default
    return rc, convert(value)


# -------------------------------------------------------------- connection
def simxStart(connectionAddress, connectionPort, waitUntilConnected, doNotReconnectOnceDisconnected,
              timeOutInMs, commThreadCycleInMs):
    """Connect to a simx server; returns a client id 0..254, or -1 (legacy ``simxStart``).

    A positive ``timeOutInMs`` bounds the connection wait; a negative one sets the blocking-call
    timeout to its absolute value and waits 5000 ms to connect. Connecting twice to the same
    address and port from one process fails (-1), as it did.
    """
    try:
        address, port = _str(connectionAddress), _int(connectionPort)
        wait, timeout_ms = _bool(waitUntilConnected), _int(timeOutInMs)
    except P.LocalError as exc:
        log.warning("simxStart: bad argument: %s", exc)
        return -1
    blocking = DEFAULT_BLOCKING_TIMEOUT if timeout_ms >= 0 else -timeout_ms / 1000.0
    connect_wait = timeout_ms / 1000.0 if timeout_ms > 0 else DEFAULT_BLOCKING_TIMEOUT
    with _registry_lock:
        if any(c.address == address and c.port == port for c in _connections.values()):
            return -1
        free = next((i for i in range(_MAX_CONNECTIONS) if i not in _connections), None)
        if free is None:
            return -1
        conn = wait_connect(address, port, wait, connect_wait, blocking)
        if conn is None:
            return -1
        _connections[free] = conn
        _connection_ids[free] = next(_connection_counter)
        return free


def simxFinish(clientID):
    """Close one connection, or all with -1; returns None (legacy ``simxFinish``). Never hangs."""
    try:
        cid = _int(clientID)
    except P.LocalError:
        return None
    with _registry_lock:
        ids = list(_connections) if cid == -1 else [cid]
        closing = [_connections.pop(i) for i in ids if i in _connections]
        for i in ids:
            _connection_ids.pop(i, None)
    for conn in closing:
        conn.close()
    return None


def simxGetConnectionId(clientID):
    """A number identifying the connection, -1 when not connected (legacy ``simxGetConnectionId``)."""
    conn = _connection(clientID)
    if conn is None or not conn.connected:
        return -1
    return _connection_ids.get(_int(clientID), -1)


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
    conn.pause_communication(_bool(enable))
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


# ----------------------------------------------------------------- objects
def simxGetObjectHandle(clientID, objectName, operationMode):
    """``(returnCode, handle)``; an unknown name gives 8 and handle 0, as V-REP did."""
    return _command(clientID, "GetObjectHandle", lambda: [_str(objectName)], operationMode, int, 0)


def simxGetObjects(clientID, objectType, operationMode):
    """``(returnCode, objectHandles)`` of a type (``sim_object_*_type``, or ``sim_handle_all``)."""
    return _command(clientID, "GetObjects", lambda: [_int(objectType)], operationMode, list, [])


def simxGetObjectPosition(clientID, objectHandle, relativeToObjectHandle, operationMode):
    """``(returnCode, [x, y, z])`` in m, relative to an object, -1 (world) or ``sim_handle_parent``."""
    return _command(clientID, "GetObjectPosition",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle)], operationMode, _f32_list, [])


def simxGetObjectOrientation(clientID, objectHandle, relativeToObjectHandle, operationMode):
    """``(returnCode, [alpha, beta, gamma])`` in rad, R = Rx(alpha) Ry(beta) Rz(gamma)."""
    return _command(clientID, "GetObjectOrientation",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle)], operationMode, _f32_list, [])


def simxGetObjectQuaternion(clientID, objectHandle, relativeToObjectHandle, operationMode):
    """``(returnCode, [x, y, z, w])``."""
    return _command(clientID, "GetObjectQuaternion",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle)], operationMode, _f32_list, [])


# ------------------------------------------------------------------ joints
def simxGetJointPosition(clientID, jointHandle, operationMode):
    """``(returnCode, position)`` in rad (revolute) or m (prismatic)."""
    return _command(clientID, "GetJointPosition", lambda: [_int(jointHandle)], operationMode, _f32, 0.0)


def simxSetJointPosition(clientID, jointHandle, position, operationMode):
    """Teleport a joint to ``position`` (rad or m): returnCode."""
    return _command(clientID, "SetJointPosition", lambda: [_int(jointHandle), _f32(_float(position))],
                    operationMode)[0]


def simxSetJointTargetPosition(clientID, jointHandle, targetPosition, operationMode):
    """Target of a position-controlled joint (rad or m): returnCode."""
    return _command(clientID, "SetJointTargetPosition",
                    lambda: [_int(jointHandle), _f32(_float(targetPosition))], operationMode)[0]


def simxSetJointTargetVelocity(clientID, jointHandle, targetVelocity, operationMode):
    """Target velocity of a velocity-mode joint (rad/s or m/s): returnCode."""
    return _command(clientID, "SetJointTargetVelocity",
                    lambda: [_int(jointHandle), _f32(_float(targetVelocity))], operationMode)[0]


def simxSetJointForce(clientID, jointHandle, force, operationMode):
    """Maximum force/torque of the joint's motor (N or N·m): returnCode."""
    return _command(clientID, "SetJointForce", lambda: [_int(jointHandle), _f32(_float(force))],
                    operationMode)[0]


def simxSetJointMaxForce(clientID, jointHandle, force, operationMode):
    """CoppeliaSim 4 name of :func:`simxSetJointForce`."""
    return simxSetJointForce(clientID, jointHandle, force, operationMode)


def simxGetJointForce(clientID, jointHandle, operationMode):
    """``(returnCode, force)``: force/torque the motor applies (N or N·m)."""
    return _command(clientID, "GetJointForce", lambda: [_int(jointHandle)], operationMode, _f32, 0.0)


def simxJointGetForce(clientID, jointHandle, operationMode):
    """Deprecated alias of :func:`simxGetJointForce`."""
    return simxGetJointForce(clientID, jointHandle, operationMode)


def simxGetJointMaxForce(clientID, jointHandle, operationMode):
    """``(returnCode, force)``: maximum force/torque of the motor (N or N·m)."""
    return _command(clientID, "GetJointMaxForce", lambda: [_int(jointHandle)], operationMode, _f32, 0.0)


# ---------------------------------------------------------- vision sensors
def _image(value: list) -> tuple[list[int], list[int]]:
    resolution, data = value
    return list(resolution), np.frombuffer(data, dtype=np.int8).tolist()


def simxGetVisionSensorImage(clientID, sensorHandle, options, operationMode):
    """``(returnCode, [resX, resY], image)``: a flat list of signed bytes (-128..127), rows
    bottom-up, R, G, B (options bit 0 = 1: one grey byte per pixel)."""
    rc, value = _command(clientID, "GetVisionSensorImage", lambda: [_int(sensorHandle), _int(options) & 1],
                         operationMode, _image, None)
    return (rc, [], []) if value is None else (rc, *value)


def _depth(value: list) -> tuple[list[int], list[float]]:
    resolution, data = value
    return list(resolution), np.frombuffer(data, dtype=np.float32).tolist()


def simxGetVisionSensorDepthBuffer(clientID, sensorHandle, operationMode):
    """``(returnCode, [resX, resY], buffer)``: resX*resY floats in 0..1 (near..far, linear), rows bottom-up."""
    rc, value = _command(clientID, "GetVisionSensorDepthBuffer", lambda: [_int(sensorHandle)],
                         operationMode, _depth, None)
    return (rc, [], []) if value is None else (rc, *value)


# ----------------------------------------------------------------- scripts
def simxCallScriptFunction(clientID, scriptDescription, options, functionName, inputInts, inputFloats,
                           inputStrings, inputBuffer, operationMode):
    """Call a child-script function: ``(returnCode, outInts, outFloats, outStrings, outBuffer)``."""

    def args() -> list:
        return [_str(scriptDescription), _int(options), _str(functionName),
                [_int(v) for v in inputInts], _f32_list([_float(v) for v in inputFloats]),
                [_str(v) for v in inputStrings], _bytes(inputBuffer)]

    def shape(value: list) -> tuple:
        ints, floats, strings, buf = value
        return list(ints), _f32_list(floats), list(strings), bytearray(buf)

    rc, value = _command(clientID, "CallScriptFunction", args, operationMode, shape, None)
    return (rc, [], [], [], bytearray()) if value is None else (rc, *value)


# ------------------------------------------------------------ pack helpers
def simxPackInts(intList):
    """Little-endian int32s as a bytearray."""
    return bytearray(struct.pack(f"<{len(intList)}i", *(_int(v) for v in intList)))


def simxUnpackInts(intsPackedInString):
    """List of int32s from a little-endian buffer."""
    return np.frombuffer(_bytes(intsPackedInString), dtype="<i4").tolist()


def simxPackFloats(floatList):
    """Little-endian float32s as a bytearray."""
    return bytearray(struct.pack(f"<{len(floatList)}f", *(_float(v) for v in floatList)))


def simxUnpackFloats(floatsPackedInString):
    """List of float32s (as Python floats) from a little-endian buffer."""
    return np.frombuffer(_bytes(floatsPackedInString), dtype="<f4").tolist()
