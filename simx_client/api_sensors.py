"""The legacy ``simx*`` functions of sensors: vision sensor images and depth buffers, vision,
force and proximity sensor reads (re-exported by :mod:`simx_client.api`)."""

from __future__ import annotations

import copy

import numpy as np

from simx_wire import protocol as P
from simx_client.calls import _command
from simx_client.coercion import _f32_list, _int
from simx_client.images import _LAZY_CLIENTS, ImageList, LazyImageList


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
    return list(resolution), ImageList.wrap(_signed_list(signed), signed)


def _lazy(client_id: object) -> bool:
    try:
        return client_id in _LAZY_CLIENTS
    except TypeError:  # an unhashable id: the call itself answers the error
        return False


def _signed_list(signed: np.ndarray) -> list[int]:
    return _SIGNED_BYTES.take(signed.view(np.uint8)).tolist()


def _image_lazy(value: list) -> tuple[list[int], LazyImageList]:
    """As :func:`_image`, the list made on first use (:func:`simx_client.images.set_lazy_image_lists`)."""
    resolution, data = value
    return list(resolution), LazyImageList.lazy(np.frombuffer(data, dtype=np.int8), _signed_list)


def _copy_image(value: tuple[list, ImageList]) -> tuple[list, ImageList]:
    return value[0][:], copy.copy(value[1])


def simxGetVisionSensorImage(clientID, sensorHandle, options, operationMode):
    """``(returnCode, [resX, resY], image)``: a flat list of signed bytes (-128..127), rows
    bottom-up, R, G, B (options bit 0 = 1: one grey byte per pixel), as vrep.py returned.

    The list is an :class:`simx_client.images.ImageList`: an ordinary list to every reader,
    whose ``np.array(image, dtype=np.uint8)`` gives the unsigned bytes as NumPy 1 did (NumPy 2
    raises OverflowError on a plain list of negative ints) in well under a millisecond;
    ``np.array(image)`` is int64 as for a plain list."""
    convert = _image_lazy if _lazy(clientID) else _image
    rc, value = _command(clientID, "GetVisionSensorImage", lambda: [_int(sensorHandle), _int(options) & 1],
                         operationMode, convert, None, memo=_copy_image)
    return (rc, [], []) if value is None else (rc, *value)


def _depth(value: list) -> tuple[list[int], ImageList]:
    resolution, data = value
    return list(resolution), ImageList.of_floats(data)


def _depth_lazy(value: list) -> tuple[list[int], LazyImageList]:
    resolution, data = value
    return list(resolution), LazyImageList.lazy(np.frombuffer(data, dtype=np.float32), np.ndarray.tolist)


def simxGetVisionSensorDepthBuffer(clientID, sensorHandle, operationMode):
    """``(returnCode, [resX, resY], buffer)``: resX*resY floats in 0..1 (near..far, linear), rows
    bottom-up. The list is an :class:`simx_client.images.ImageList` (``np.array(buffer)`` is
    float64 as for a plain list, in well under a millisecond)."""
    convert = _depth_lazy if _lazy(clientID) else _depth
    rc, value = _command(clientID, "GetVisionSensorDepthBuffer", lambda: [_int(sensorHandle)],
                         operationMode, convert, None, memo=_copy_image)
    return (rc, [], []) if value is None else (rc, *value)


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
