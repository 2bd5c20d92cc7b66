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
"""

from __future__ import annotations

import atexit
import copy
import logging
import struct
import threading
from typing import Any, Callable

import numpy as np

from simx_client import constants as C
from simx_client import protocol as P
from simx_client.connection import DEFAULT_BLOCKING_TIMEOUT, Connection, wait_connect
from simx_client.images import ImageList

log = logging.getLogger("simx.client")

_MAX_CONNECTIONS = 255  # MAX_EXT_API_CONNECTIONS: client ids 0..254
_connections: dict[int, Connection] = {}
_registry_lock = threading.Lock()
_INT_MIN, _INT_MAX = -2**31, 2**31 - 1  # simxInt: every integer argument of the C API is an int32



# ------------------------------------------------------------------ coercion
# Each coercion tests the exact plain type first: the facade runs them on every call.
def _scalar(value: Any) -> Any:
    """A Python scalar from a Python/numpy scalar or a 1-element array."""
    if isinstance(value, (int, float, bool, str, bytes)):
        return value
    array = np.asarray(value)
    if array.size != 1:
        raise P.LocalError(f"expected a single value, got an array of shape {array.shape}")
    return array.reshape(()).item()


def _int(value: Any) -> int:
    """An int32 (the C API's simxInt), else LocalError."""
    if type(value) is int and -2147483648 <= value <= 2147483647:  # _INT_MIN, _INT_MAX as constants
        return value
    v = _scalar(value)
    if isinstance(v, bool) or not isinstance(v, int):
        raise P.LocalError(f"expected an integer, got {type(v).__name__} {P.quote(v)}")
    if not _INT_MIN <= v <= _INT_MAX:
        raise P.LocalError(f"integer {P.quote(v)} out of the int32 range")
    return int(v)


def _bool(value: Any) -> bool:
    """A truth value from a bool or a number (not NaN), as the legacy ``c_ubyte`` took them."""
    if type(value) is bool:
        return value
    v = _scalar(value)
    if not isinstance(v, (bool, int, float)) or v != v:
        raise P.LocalError(f"expected a truth value, got {type(v).__name__} {P.quote(v)}")
    return bool(v)


def _float(value: Any) -> float:
    if type(value) is float:
        return value
    v = _scalar(value)
    if isinstance(v, (bool, str, bytes)) or not isinstance(v, (int, float)):
        raise P.LocalError(f"expected a number, got {type(v).__name__} {P.quote(v)}")
    return float(v)


def _str(value: Any) -> str:
    if type(value) is str:
        return value
    v = _scalar(value)
    if isinstance(v, (bytes, bytearray)):
        return bytes(v).decode("utf-8")
    if not isinstance(v, str):
        raise P.LocalError(f"expected a string, got {type(v).__name__}")
    return v


def _bytes(value: Any) -> bytes:
    """Bytes of a str (UTF-8), a bytes-like object or integers (-128..255, as c_ubyte took them)."""
    if isinstance(value, str):
        return value.encode("utf-8")
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value)
    data = np.asarray(value)
    if data.dtype.kind not in "iub":
        raise P.LocalError(f"expected bytes, a str or integers, got {P.quote(value)}")
    return data.astype(np.int64).astype(np.uint8).tobytes()


_F32 = struct.Struct("<f")


def _f32(value: float) -> float:
    """``value`` rounded to float32, as the legacy binding's c_float did; OverflowError beyond
    float32 (ctypes made such a value inf without a word): the facade answers a local error."""
    return _F32.unpack(_F32.pack(value))[0]


def _f32_input(values: Any) -> list[float]:
    """A list of numbers rounded to float32 (FloatingPointError beyond float32)."""
    with np.errstate(over="raise"):
        return np.asarray([_float(v) for v in values], dtype=np.float32).tolist()


def _f32_list(values: list) -> list[float]:
    return np.asarray(values, dtype=np.float32).tolist()


# ------------------------------------------------------------------- plumbing
def _connection(client_id: Any) -> Connection | None:
    if type(client_id) is int:
        return _connections.get(client_id)
    try:
        return _connections.get(_int(client_id))
    except Exception:
        return None


def _command(clientID: Any, name: str, make_args: Callable[[], list], operationMode: Any,
             convert: Callable[[Any], Any] = lambda v: v, default: Any = None,
             memo: Callable[[Any], Any] | None = None) -> tuple[int, Any]:
    """Run one command; returns ``(return code, converted value or default)``.

    With ``memo`` (a function copying a converted value), a value read again from the inbox
    (a ``buffer`` loop on an unchanged image) is converted once and handed out as copies.
    """
    conn = _connection(clientID)
    if conn is None:
        return C.simx_return_initialize_error_flag, default
    try:
        args = make_args()
        mode = _int(operationMode)
    except Exception as exc:  # any argument that cannot be converted: a local error, never a raise
        log.warning("simx%s: bad argument: %s: %s", name, type(exc).__name__, exc)
        return C.simx_return_local_error_flag, default
    rc, value = conn.call(name, args, mode)
    if rc or mode & P.MODE_MASK == P.MODE_REMOVE:  # remove returns no value
        if rc & C.simx_return_remote_error_flag:
            log.debug("simx%s: remote error: %s", name, value)
        elif rc & C.simx_return_local_error_flag:
            log.warning("simx%s: %s", name, value)
        return rc, default
    try:
        if memo is None or mode & P.MODE_MASK == P.MODE_BLOCKING:  # a blocking reply is always fresh
            return rc, convert(value)
        key = P.identity(name, args)
        hit = conn.converted.get(key)
        if hit is None or hit[0] is not value:
            hit = conn.converted[key] = (value, convert(value))
        return rc, memo(hit[1])
    except Exception as exc:  # a reply of the wrong shape: the server's fault, not the caller's
        log.warning("simx%s: unreadable reply %s: %s", name, P.quote(value), exc)
        return C.simx_return_remote_error_flag, default


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
        reconnect = not _bool(doNotReconnectOnceDisconnected)
    except Exception as exc:
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
        conn = wait_connect(address, port, wait, connect_wait, blocking, reconnect)
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
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle)], operationMode, _f32_list, [0.0] * 3)


def simxGetObjectOrientation(clientID, objectHandle, relativeToObjectHandle, operationMode):
    """``(returnCode, [alpha, beta, gamma])`` in rad, R = Rx(alpha) Ry(beta) Rz(gamma)."""
    return _command(clientID, "GetObjectOrientation",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle)], operationMode, _f32_list, [0.0] * 3)


def simxGetObjectQuaternion(clientID, objectHandle, relativeToObjectHandle, operationMode):
    """``(returnCode, [x, y, z, w])``."""
    return _command(clientID, "GetObjectQuaternion",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle)], operationMode, _f32_list, [0.0] * 4)


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
# The Python int of every signed byte, indexed by the byte read as unsigned. The legacy list
# is made of these shared objects: 2-3x faster than ``int8 array.tolist()``, which allocates
# an int for each byte outside CPython's small-int cache (every value below -5: most pixels).
_SIGNED_BYTES = np.array([*range(128), *range(-128, 0)], dtype=object)


def _image(value: list) -> tuple[list[int], ImageList]:
    """``[resolution, bytes]`` -> ``(resolution, flat list of signed bytes)``, as vrep.py gave;
    the list keeps the bytes as int8 for ``np.array`` (:class:`simx_client.images.ImageList`)."""
    resolution, data = value
    signed = np.frombuffer(data, dtype=np.int8)
    return list(resolution), ImageList.wrap(_SIGNED_BYTES.take(signed.view(np.uint8)).tolist(), signed)


def _copy_image(value: tuple[list, ImageList]) -> tuple[list, ImageList]:
    return value[0][:], copy.copy(value[1])


def simxGetVisionSensorImage(clientID, sensorHandle, options, operationMode):
    """``(returnCode, [resX, resY], image)``: a flat list of signed bytes (-128..127), rows
    bottom-up, R, G, B (options bit 0 = 1: one grey byte per pixel), as vrep.py returned.

    The list is an :class:`simx_client.images.ImageList`: an ordinary list to every reader,
    whose ``np.array(image, dtype=np.uint8)`` gives the unsigned bytes as NumPy 1 did (NumPy 2
    raises OverflowError on a plain list of negative ints) in well under a millisecond;
    ``np.array(image)`` is int64 as for a plain list."""
    rc, value = _command(clientID, "GetVisionSensorImage", lambda: [_int(sensorHandle), _int(options) & 1],
                         operationMode, _image, None, memo=_copy_image)
    return (rc, [], []) if value is None else (rc, *value)


def _depth(value: list) -> tuple[list[int], ImageList]:
    resolution, data = value
    floats = np.frombuffer(data, dtype=np.float32)
    return list(resolution), ImageList.wrap(floats.tolist(), floats)


def simxGetVisionSensorDepthBuffer(clientID, sensorHandle, operationMode):
    """``(returnCode, [resX, resY], buffer)``: resX*resY floats in 0..1 (near..far, linear), rows
    bottom-up. The list is an :class:`simx_client.images.ImageList` (``np.array(buffer)`` is
    float64 as for a plain list, in well under a millisecond)."""
    rc, value = _command(clientID, "GetVisionSensorDepthBuffer", lambda: [_int(sensorHandle)],
                         operationMode, _depth, None, memo=_copy_image)
    return (rc, [], []) if value is None else (rc, *value)


# ----------------------------------------------------------------- scripts
def simxCallScriptFunction(clientID, scriptDescription, options, functionName, inputInts, inputFloats,
                           inputStrings, inputBuffer, operationMode):
    """Call a child-script function: ``(returnCode, outInts, outFloats, outStrings, outBuffer)``."""

    def args() -> list:
        return [_str(scriptDescription), _int(options), _str(functionName),
                [_int(v) for v in inputInts], _f32_input(inputFloats),
                [_str(v) for v in inputStrings], _bytes(inputBuffer)]

    def shape(value: list) -> tuple:
        ints, floats, strings, buf = value
        return list(ints), _f32_list(floats), list(strings), bytearray(buf)

    rc, value = _command(clientID, "CallScriptFunction", args, operationMode, shape, None)
    return (rc, [], [], [], bytearray()) if value is None else (rc, *value)


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


# ----------------------------------------------------------- more of joints
def simxGetJointMatrix(clientID, jointHandle, operationMode):
    """``(returnCode, matrix)``: the joint's intrinsic transform, 12 floats (3x4, row-major)."""
    return _command(clientID, "GetJointMatrix", lambda: [_int(jointHandle)], operationMode, _f32_list, [0.0] * 12)


def simxSetSphericalJointMatrix(clientID, jointHandle, matrix, operationMode):
    """Set a spherical joint's intrinsic rotation from 12 floats (3x4, row-major): returnCode."""
    return _command(clientID, "SetSphericalJointMatrix",
                    lambda: [_int(jointHandle), _floats(matrix, 12)], operationMode)[0]


# ----------------------------------------------------------------- sensors
def simxReadForceSensor(clientID, forceSensorHandle, operationMode):
    """``(returnCode, state, forceVector, torqueVector)``: state bits (0: data, 1: broken), N and N·m."""
    rc, value = _command(clientID, "ReadForceSensor", lambda: [_int(forceSensorHandle)], operationMode,
                         lambda v: (int(v[0]), _f32_list(v[1]), _f32_list(v[2])), None)
    return (rc, 0, [0.0] * 3, [0.0] * 3) if value is None else (rc, *value)


def simxBreakForceSensor(clientID, forceSensorHandle, operationMode):
    """Mark a force sensor broken: returnCode."""
    return _command(clientID, "BreakForceSensor", lambda: [_int(forceSensorHandle)], operationMode)[0]


def simxReadVisionSensor(clientID, sensorHandle, operationMode):
    """``(returnCode, detectionState, auxPackets)``: packet 1 holds min, max and average of
    intensity, red, green, blue and depth (15 floats in 0..1)."""
    rc, value = _command(clientID, "ReadVisionSensor", lambda: [_int(sensorHandle)], operationMode,
                         lambda v: (bool(v[0]), [_f32_list(p) for p in v[1]]), None)
    return (rc, False, []) if value is None else (rc, *value)


def simxSetVisionSensorImage(clientID, sensorHandle, image, options, operationMode):
    """Write an image into a passive vision sensor: returnCode. ``image``: resX*resY*3 bytes
    (R, G, B, rows bottom-up) or resX*resY with options bit 0; values -128..127 or 0..255."""

    def args() -> list:
        data = np.asarray(image)
        if data.dtype.kind not in "iub":
            raise P.LocalError(f"image values must be integers, got {data.dtype}")
        return [_int(sensorHandle), data.astype(np.int64).astype(np.uint8).tobytes(), _int(options)]

    return _command(clientID, "SetVisionSensorImage", args, operationMode)[0]


def simxReadProximitySensor(clientID, sensorHandle, operationMode):
    """``(returnCode, detectionState, detectedPoint, detectedObjectHandle, detectedSurfaceNormalVector)``;
    point (m) and normal in the sensor's frame."""
    rc, value = _command(clientID, "ReadProximitySensor", lambda: [_int(sensorHandle)], operationMode,
                         lambda v: (bool(v[0]), _f32_list(v[1]), int(v[2]), _f32_list(v[3])), None)
    return (rc, False, [0.0] * 3, 0, [0.0] * 3) if value is None else (rc, *value)


# ------------------------------------------------------------ tree and pose
def simxGetObjectChild(clientID, parentObjectHandle, childIndex, operationMode):
    """``(returnCode, childHandle)``: the child at ``childIndex`` (0-based), -1 when there is none."""
    return _command(clientID, "GetObjectChild", lambda: [_int(parentObjectHandle), _int(childIndex)],
                    operationMode, int, 0)


def simxGetObjectParent(clientID, childObjectHandle, operationMode):
    """``(returnCode, parentHandle)``: -1 when the object hangs from the world."""
    return _command(clientID, "GetObjectParent", lambda: [_int(childObjectHandle)], operationMode, int, 0)


def simxSetObjectPosition(clientID, objectHandle, relativeToObjectHandle, position, operationMode):
    """Move an object to ``position`` (3 floats, m) relative to an object / -1 / sim_handle_parent: returnCode."""
    return _command(clientID, "SetObjectPosition",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle), _floats(position, 3)], operationMode)[0]


def simxSetObjectOrientation(clientID, objectHandle, relativeToObjectHandle, eulerAngles, operationMode):
    """Set an object's Euler angles (alpha, beta, gamma in rad): returnCode."""
    return _command(clientID, "SetObjectOrientation",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle), _floats(eulerAngles, 3)],
                    operationMode)[0]


def simxSetObjectQuaternion(clientID, objectHandle, relativeToObjectHandle, quaternion, operationMode):
    """Set an object's orientation from a quaternion (x, y, z, w): returnCode."""
    return _command(clientID, "SetObjectQuaternion",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle), _floats(quaternion, 4)],
                    operationMode)[0]


def simxSetObjectParent(clientID, objectHandle, parentObject, keepInPlace, operationMode):
    """Attach an object (its body subtree) to another parent (-1: the world): returnCode."""
    return _command(clientID, "SetObjectParent",
                    lambda: [_int(objectHandle), _int(parentObject), _bool(keepInPlace)], operationMode)[0]


def simxGetObjectVelocity(clientID, objectHandle, operationMode):
    """``(returnCode, linearVelocity, angularVelocity)`` in the world frame (m/s, rad/s)."""
    rc, value = _command(clientID, "GetObjectVelocity", lambda: [_int(objectHandle)], operationMode,
                         lambda v: (_f32_list(v[0]), _f32_list(v[1])), None)
    return (rc, [0.0] * 3, [0.0] * 3) if value is None else (rc, *value)


def simxGetObjectGroupData(clientID, objectType, dataType, operationMode):
    """``(returnCode, handles, intData, floatData, stringData)`` for every object of a type."""
    rc, value = _command(clientID, "GetObjectGroupData", lambda: [_int(objectType), _int(dataType)],
                         operationMode, lambda v: (list(v[0]), list(v[1]), _f32_list(v[2]), list(v[3])), None)
    return (rc, [], [], [], []) if value is None else (rc, *value)


def simxGetObjectSelection(clientID, operationMode):
    """``(returnCode, objectHandles)`` selected (shared by all clients; no GUI)."""
    return _command(clientID, "GetObjectSelection", lambda: [], operationMode, list, [])


def simxSetObjectSelection(clientID, objectHandles, operationMode):
    """Replace the selection: returnCode."""
    return _command(clientID, "SetObjectSelection", lambda: [[_int(h) for h in objectHandles]], operationMode)[0]


def simxGetModelProperty(clientID, objectHandle, operationMode):
    """``(returnCode, prop)``: sim_modelproperty_* bits (0xf000: not a model)."""
    return _command(clientID, "GetModelProperty", lambda: [_int(objectHandle)], operationMode, int, 0)


def simxSetModelProperty(clientID, objectHandle, prop, operationMode):
    """Set model property bits: returnCode."""
    return _command(clientID, "SetModelProperty", lambda: [_int(objectHandle), _int(prop)], operationMode)[0]


# -------------------------------------------------------- object parameters
def simxGetObjectFloatParameter(clientID, objectHandle, parameterID, operationMode):
    """``(returnCode, parameterValue)`` (e.g. 1000/1001 near/far clipping in m)."""
    return _command(clientID, "GetObjectFloatParameter", lambda: [_int(objectHandle), _int(parameterID)],
                    operationMode, _f32, 0.0)


def simxSetObjectFloatParameter(clientID, objectHandle, parameterID, parameterValue, operationMode):
    """Set a float parameter of an object: returnCode."""
    return _command(clientID, "SetObjectFloatParameter",
                    lambda: [_int(objectHandle), _int(parameterID), _f32(_float(parameterValue))], operationMode)[0]


def simxGetObjectIntParameter(clientID, objectHandle, parameterID, operationMode):
    """``(returnCode, parameterValue)`` (e.g. 1002/1003 vision sensor resolution)."""
    return _command(clientID, "GetObjectIntParameter", lambda: [_int(objectHandle), _int(parameterID)],
                    operationMode, int, 0)


def simxSetObjectIntParameter(clientID, objectHandle, parameterID, parameterValue, operationMode):
    """Set an integer parameter of an object: returnCode."""
    return _command(clientID, "SetObjectIntParameter",
                    lambda: [_int(objectHandle), _int(parameterID), _int(parameterValue)], operationMode)[0]


simxGetObjectFloatParam = simxGetObjectFloatParameter
simxSetObjectFloatParam = simxSetObjectFloatParameter
simxGetObjectInt32Param = simxGetObjectIntParameter
simxSetObjectInt32Param = simxSetObjectIntParameter


# ------------------------------------------------- collision and distance
def simxGetCollisionHandle(clientID, collisionObjectName, operationMode):
    """``(returnCode, handle)`` of a collision object declared in the scene."""
    return _command(clientID, "GetCollisionHandle", lambda: [_str(collisionObjectName)], operationMode, int, 0)


def simxGetDistanceHandle(clientID, distanceObjectName, operationMode):
    """``(returnCode, handle)`` of a distance object declared in the scene."""
    return _command(clientID, "GetDistanceHandle", lambda: [_str(distanceObjectName)], operationMode, int, 0)


def simxGetCollectionHandle(clientID, collectionName, operationMode):
    """``(returnCode, handle)`` of a collection (simx scenes declare none: remote error)."""
    return _command(clientID, "GetCollectionHandle", lambda: [_str(collectionName)], operationMode, int, 0)


def simxReadCollision(clientID, collisionObjectHandle, operationMode):
    """``(returnCode, collisionState)`` of a collision object."""
    return _command(clientID, "ReadCollision", lambda: [_int(collisionObjectHandle)], operationMode, bool, False)


def simxReadDistance(clientID, distanceObjectHandle, operationMode):
    """``(returnCode, minimumDistance)`` (m) of a distance object."""
    return _command(clientID, "ReadDistance", lambda: [_int(distanceObjectHandle)], operationMode, _f32, 0.0)


def simxCheckCollision(clientID, entity1, entity2, operationMode):
    """``(returnCode, collisionState)`` between two objects (entity2 may be sim_handle_all)."""
    return _command(clientID, "CheckCollision", lambda: [_int(entity1), _int(entity2)], operationMode, bool, False)


def simxCheckDistance(clientID, entity1, entity2, operationMode):
    """``(returnCode, minimumDistance)`` (m) between two objects."""
    return _command(clientID, "CheckDistance", lambda: [_int(entity1), _int(entity2)], operationMode, _f32, 0.0)


# ------------------------------------------------------------ scene editing
def simxTransferFile(clientID, filePathAndName, fileName_serverSide, timeOut, operationMode):
    """Send a local file to the server's transfer folder: returnCode (32 if it cannot be read)."""
    conn = _connection(clientID)
    if conn is None:
        return C.simx_return_initialize_error_flag
    try:
        with open(_str(filePathAndName), "rb") as f:
            data = f.read()
    except Exception as exc:  # unreadable, or not a path (OSError, LocalError, UnicodeError...)
        log.warning("simxTransferFile: %s: %s", type(exc).__name__, exc)
        return C.simx_return_local_error_flag
    return _command(clientID, "TransferFile", lambda: [_str(fileName_serverSide), data], operationMode)[0]


def simxEraseFile(clientID, fileName_serverSide, operationMode):
    """Delete a transferred file on the server: returnCode."""
    return _command(clientID, "EraseFile", lambda: [_str(fileName_serverSide)], operationMode)[0]


def _client_side(clientID, path: Any, options: Any) -> tuple[int, str]:
    """For options bit 0 (file on the client): transfer it first; returns (rc, server-side name)."""
    import os

    name, opts = _str(path), _int(options)
    if not opts & 1:
        return C.simx_return_ok, name
    remote = os.path.basename(name)
    return simxTransferFile(clientID, name, remote, 5000, C.simx_opmode_blocking), remote


def simxLoadModel(clientID, modelPathAndName, options, operationMode):
    """Load an MJCF model into the running scene: ``(returnCode, baseHandle)``; options bit 0: the
    file is on the client (it is transferred first)."""
    try:
        rc, name = _client_side(clientID, modelPathAndName, options)
    except Exception as exc:
        log.warning("simxLoadModel: bad argument: %s", exc)
        return C.simx_return_local_error_flag, 0
    if rc:
        return rc, 0
    return _command(clientID, "LoadModel", lambda: [name, _int(options)], operationMode, int, 0)


def simxLoadScene(clientID, scenePathAndName, options, operationMode):
    """Replace the scene with an MJCF file (simulation stopped): returnCode."""
    try:
        rc, name = _client_side(clientID, scenePathAndName, options)
    except Exception as exc:
        log.warning("simxLoadScene: bad argument: %s", exc)
        return C.simx_return_local_error_flag
    if rc:
        return rc
    return _command(clientID, "LoadScene", lambda: [name, _int(options)], operationMode)[0]


def simxCloseScene(clientID, operationMode):
    """Replace the scene with an empty one: returnCode."""
    return _command(clientID, "CloseScene", lambda: [], operationMode)[0]


def simxRemoveObject(clientID, objectHandle, operationMode):
    """Remove an object: returnCode."""
    return _command(clientID, "RemoveObject", lambda: [_int(objectHandle)], operationMode)[0]


def simxRemoveModel(clientID, objectHandle, operationMode):
    """Remove a model (the object and everything below it): returnCode."""
    return _command(clientID, "RemoveModel", lambda: [_int(objectHandle)], operationMode)[0]


def simxCopyPasteObjects(clientID, objectHandles, operationMode):
    """Copy objects: ``(returnCode, newObjectHandles)``."""
    return _command(clientID, "CopyPasteObjects", lambda: [[_int(h) for h in objectHandles]],
                    operationMode, list, [])


def simxCreateDummy(clientID, size, color, operationMode):
    """Create a dummy (a site) at the origin: ``(returnCode, dummyHandle)``; color: 12 bytes or None."""
    return _command(clientID, "CreateDummy",
                    lambda: [_f32(_float(size)), None if color is None else [_int(c) for c in color]],
                    operationMode, int, 0)


# ------------------------------------------------------------------ signals
def _signal_value(value: Any) -> bytes:
    return _bytes(value)


def simxSetIntegerSignal(clientID, signalName, signalValue, operationMode):
    """Set an integer signal (shared by every client and script): returnCode."""
    return _command(clientID, "SetIntegerSignal", lambda: [_str(signalName), _int(signalValue)], operationMode)[0]


def simxGetIntegerSignal(clientID, signalName, operationMode):
    """``(returnCode, signalValue)``; a missing signal is a remote error."""
    return _command(clientID, "GetIntegerSignal", lambda: [_str(signalName)], operationMode, int, 0)


def simxClearIntegerSignal(clientID, signalName, operationMode):
    """Clear an integer signal ("" clears them all): returnCode."""
    return _command(clientID, "ClearIntegerSignal", lambda: [_str(signalName)], operationMode)[0]


def simxSetFloatSignal(clientID, signalName, signalValue, operationMode):
    """Set a float signal: returnCode."""
    return _command(clientID, "SetFloatSignal", lambda: [_str(signalName), _f32(_float(signalValue))],
                    operationMode)[0]


def simxGetFloatSignal(clientID, signalName, operationMode):
    """``(returnCode, signalValue)``."""
    return _command(clientID, "GetFloatSignal", lambda: [_str(signalName)], operationMode, _f32, 0.0)


def simxClearFloatSignal(clientID, signalName, operationMode):
    """Clear a float signal ("" clears them all): returnCode."""
    return _command(clientID, "ClearFloatSignal", lambda: [_str(signalName)], operationMode)[0]


def simxSetStringSignal(clientID, signalName, signalValue, operationMode):
    """Set a string signal (str is UTF-8 encoded; bytes kept as they are): returnCode."""
    return _command(clientID, "SetStringSignal", lambda: [_str(signalName), _signal_value(signalValue)],
                    operationMode)[0]


def simxGetStringSignal(clientID, signalName, operationMode):
    """``(returnCode, signalValue)`` as a bytearray."""
    return _command(clientID, "GetStringSignal", lambda: [_str(signalName)], operationMode, bytearray, bytearray())


def simxGetAndClearStringSignal(clientID, signalName, operationMode):
    """``(returnCode, signalValue)`` as a bytearray; the signal is cleared."""
    return _command(clientID, "GetAndClearStringSignal", lambda: [_str(signalName)], operationMode,
                    bytearray, bytearray())


def simxClearStringSignal(clientID, signalName, operationMode):
    """Clear a string signal ("" clears them all): returnCode."""
    return _command(clientID, "ClearStringSignal", lambda: [_str(signalName)], operationMode)[0]


def simxAppendStringSignal(clientID, signalName, signalValue, operationMode):
    """Append to a string signal (created if missing): returnCode."""
    return _command(clientID, "AppendStringSignal", lambda: [_str(signalName), _signal_value(signalValue)],
                    operationMode)[0]


def simxWriteStringStream(clientID, signalName, signalValue, operationMode):
    """Append to a string signal used as a stream: returnCode."""
    return _command(clientID, "WriteStringStream", lambda: [_str(signalName), _signal_value(signalValue)],
                    operationMode)[0]


def simxReadStringStream(clientID, signalName, operationMode):
    """``(returnCode, signalValue)``: what was written to the stream since the last read
    (streaming then buffer; blocking is refused with flag 4, as the legacy client did)."""
    try:
        if _int(operationMode) == C.simx_opmode_blocking:
            return C.simx_return_illegal_opmode_flag, bytearray()
    except Exception:  # _command answers the local error
        pass
    return _command(clientID, "ReadStringStream", lambda: [_str(signalName)], operationMode,
                    bytearray, bytearray())


simxSetInt32Signal = simxSetIntegerSignal
simxGetInt32Signal = simxGetIntegerSignal
simxClearInt32Signal = simxClearIntegerSignal


def simxQuery(clientID, signalName, signalValue, retSignalName, timeOutInMs):
    """Set a string signal, then wait up to ``timeOutInMs`` for another to appear (and clear it):
    ``(returnCode, retSignalValue)``."""
    import time

    try:
        deadline = time.monotonic() + _int(timeOutInMs) / 1000.0
    except Exception as exc:
        log.warning("simxQuery: bad argument: %s", exc)
        return C.simx_return_local_error_flag, bytearray()
    rc = simxSetStringSignal(clientID, signalName, signalValue, C.simx_opmode_blocking)
    if rc:
        return rc, bytearray()
    while True:
        rc, value = simxGetAndClearStringSignal(clientID, retSignalName, C.simx_opmode_blocking)
        if rc == 0:
            return rc, value
        if time.monotonic() >= deadline:
            return rc | C.simx_return_timeout_flag, bytearray()
        time.sleep(0.005)


# --------------------------------------------------------------- parameters
def simxGetIntegerParameter(clientID, paramIdentifier, operationMode):
    """``(returnCode, paramValue)`` of a sim_intparam_*."""
    return _command(clientID, "GetIntegerParameter", lambda: [_int(paramIdentifier)], operationMode, int, 0)


def simxSetIntegerParameter(clientID, paramIdentifier, paramValue, operationMode):
    """Set a sim_intparam_*: returnCode."""
    return _command(clientID, "SetIntegerParameter", lambda: [_int(paramIdentifier), _int(paramValue)],
                    operationMode)[0]


def simxGetFloatingParameter(clientID, paramIdentifier, operationMode):
    """``(returnCode, paramValue)`` of a sim_floatparam_* (1: the simulation step in s)."""
    return _command(clientID, "GetFloatingParameter", lambda: [_int(paramIdentifier)], operationMode, _f32, 0.0)


def simxSetFloatingParameter(clientID, paramIdentifier, paramValue, operationMode):
    """Set a sim_floatparam_*: returnCode."""
    return _command(clientID, "SetFloatingParameter",
                    lambda: [_int(paramIdentifier), _f32(_float(paramValue))], operationMode)[0]


def simxGetBooleanParameter(clientID, paramIdentifier, operationMode):
    """``(returnCode, paramValue)`` of a sim_boolparam_*."""
    return _command(clientID, "GetBooleanParameter", lambda: [_int(paramIdentifier)], operationMode, bool, False)


def simxSetBooleanParameter(clientID, paramIdentifier, paramValue, operationMode):
    """Set a sim_boolparam_*: returnCode."""
    return _command(clientID, "SetBooleanParameter", lambda: [_int(paramIdentifier), _bool(paramValue)],
                    operationMode)[0]


def simxGetStringParameter(clientID, paramIdentifier, operationMode):
    """``(returnCode, paramValue)`` of a sim_stringparam_*."""
    return _command(clientID, "GetStringParameter", lambda: [_int(paramIdentifier)], operationMode, str, "")


def simxGetArrayParameter(clientID, paramIdentifier, operationMode):
    """``(returnCode, paramValues)``: 3 floats (sim_arrayparam_gravity = 0: m/s²)."""
    return _command(clientID, "GetArrayParameter", lambda: [_int(paramIdentifier)], operationMode,
                    _f32_list, [0.0] * 3)


def simxSetArrayParameter(clientID, paramIdentifier, paramValues, operationMode):
    """Set 3 floats of a sim_arrayparam_*: returnCode."""
    return _command(clientID, "SetArrayParameter", lambda: [_int(paramIdentifier), _floats(paramValues, 3)],
                    operationMode)[0]


simxGetInt32Param = simxGetIntegerParameter
simxSetInt32Param = simxSetIntegerParameter
simxGetFloatParam = simxGetFloatingParameter
simxSetFloatParam = simxSetFloatingParameter
simxGetBoolParam = simxGetBooleanParameter
simxSetBoolParam = simxSetBooleanParameter
simxGetStringParam = simxGetStringParameter
simxGetArrayParam = simxGetArrayParameter
simxSetArrayParam = simxSetArrayParameter


# -------------------------------------------------------- messages and errors
def simxAddStatusbarMessage(clientID, message, operationMode):
    """Write a message to the server's log, prefixed by this client: returnCode."""
    return _command(clientID, "AddStatusbarMessage", lambda: [_str(message)], operationMode)[0]


def simxAuxiliaryConsoleOpen(clientID, title, maxLines, mode, position, size, textColor, backgroundColor,
                             operationMode):
    """Open an auxiliary console (its lines go to the server's log): ``(returnCode, consoleHandle)``."""
    return _command(clientID, "AuxiliaryConsoleOpen", lambda: [_str(title), _int(maxLines), _int(mode)],
                    operationMode, int, 0)


def simxAuxiliaryConsoleClose(clientID, consoleHandle, operationMode):
    """Close an auxiliary console: returnCode."""
    return _command(clientID, "AuxiliaryConsoleClose", lambda: [_int(consoleHandle)], operationMode)[0]


def simxAuxiliaryConsolePrint(clientID, consoleHandle, txt, operationMode):
    """Print to an auxiliary console (None clears it): returnCode."""
    return _command(clientID, "AuxiliaryConsolePrint",
                    lambda: [_int(consoleHandle), None if txt is None else _str(txt)], operationMode)[0]


def simxAuxiliaryConsoleShow(clientID, consoleHandle, showState, operationMode):
    """Show or hide an auxiliary console (headless: only checks the handle): returnCode."""
    return _command(clientID, "AuxiliaryConsoleShow", lambda: [_int(consoleHandle), _bool(showState)],
                    operationMode)[0]


def simxGetLastErrors(clientID, operationMode):
    """``(returnCode, errors)``: this client's remote errors since the last call (then cleared)."""
    return _command(clientID, "GetLastErrors", lambda: [], operationMode, list, [])


# ------------------------------------------- GUI-only calls (honestly refused)
def simxLoadUI(clientID, uiPathAndName, options, operationMode):
    """Custom UIs need V-REP's GUI: remote error. ``(returnCode, uiHandles)``."""
    return _command(clientID, "LoadUI", lambda: [_str(uiPathAndName), _int(options)], operationMode, list, [])


def simxGetUIHandle(clientID, uiName, operationMode):
    """Custom UIs need V-REP's GUI: remote error. ``(returnCode, handle)``."""
    return _command(clientID, "GetUIHandle", lambda: [_str(uiName)], operationMode, int, 0)


def simxGetUISlider(clientID, uiHandle, uiButtonID, operationMode):
    """Custom UIs need V-REP's GUI: remote error. ``(returnCode, position)``."""
    return _command(clientID, "GetUISlider", lambda: [_int(uiHandle), _int(uiButtonID)], operationMode, int, 0)


def simxSetUISlider(clientID, uiHandle, uiButtonID, position, operationMode):
    """Custom UIs need V-REP's GUI: remote error."""
    return _command(clientID, "SetUISlider", lambda: [_int(uiHandle), _int(uiButtonID), _int(position)],
                    operationMode)[0]


def simxGetUIEventButton(clientID, uiHandle, operationMode):
    """Custom UIs need V-REP's GUI: remote error. ``(returnCode, uiEventButtonID, auxValues)``."""
    rc, value = _command(clientID, "GetUIEventButton", lambda: [_int(uiHandle)], operationMode, tuple, None)
    return (rc, 0, [0, 0]) if value is None else (rc, *value)


def simxGetUIButtonProperty(clientID, uiHandle, uiButtonID, operationMode):
    """Custom UIs need V-REP's GUI: remote error. ``(returnCode, prop)``."""
    return _command(clientID, "GetUIButtonProperty", lambda: [_int(uiHandle), _int(uiButtonID)],
                    operationMode, int, 0)


def simxSetUIButtonProperty(clientID, uiHandle, uiButtonID, prop, operationMode):
    """Custom UIs need V-REP's GUI: remote error."""
    return _command(clientID, "SetUIButtonProperty", lambda: [_int(uiHandle), _int(uiButtonID), _int(prop)],
                    operationMode)[0]


def simxSetUIButtonLabel(clientID, uiHandle, uiButtonID, upStateLabel, downStateLabel, operationMode):
    """Custom UIs need V-REP's GUI: remote error."""
    return _command(clientID, "SetUIButtonLabel",
                    lambda: [_int(uiHandle), _int(uiButtonID), _str(upStateLabel), _str(downStateLabel)],
                    operationMode)[0]


def simxRemoveUI(clientID, uiHandle, operationMode):
    """Custom UIs need V-REP's GUI: remote error."""
    return _command(clientID, "RemoveUI", lambda: [_int(uiHandle)], operationMode)[0]


def simxDisplayDialog(clientID, titleText, mainText, dialogType, initialText, titleColors, dialogColors,
                      operationMode):
    """Dialogs need V-REP's GUI: remote error. ``(returnCode, dialogHandle, uiHandle)``."""
    rc, value = _command(clientID, "DisplayDialog",
                         lambda: [_str(titleText), _str(mainText), _int(dialogType), _str(initialText)],
                         operationMode, tuple, None)
    return (rc, 0, 0) if value is None else (rc, *value)


def simxEndDialog(clientID, dialogHandle, operationMode):
    """Dialogs need V-REP's GUI: remote error."""
    return _command(clientID, "EndDialog", lambda: [_int(dialogHandle)], operationMode)[0]


def simxGetDialogInput(clientID, dialogHandle, operationMode):
    """Dialogs need V-REP's GUI: remote error. ``(returnCode, inputText)``."""
    return _command(clientID, "GetDialogInput", lambda: [_int(dialogHandle)], operationMode, str, "")


def simxGetDialogResult(clientID, dialogHandle, operationMode):
    """Dialogs need V-REP's GUI: remote error. ``(returnCode, result)``."""
    return _command(clientID, "GetDialogResult", lambda: [_int(dialogHandle)], operationMode, int, 0)


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


def _floats(values: Any, n: int) -> list[float]:
    out = [_f32(_float(v)) for v in np.asarray(values, dtype=object).reshape(-1)]
    if len(out) != n:
        raise P.LocalError(f"expected {n} values, got {len(out)}")
    return out
