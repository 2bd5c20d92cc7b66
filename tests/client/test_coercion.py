"""Arguments are coerced at the facade: legacy programs pass numpy scalars and 1-element arrays."""

import numpy as np
import pytest

import vrep
from simx_client import api
from simx_client.protocol import LocalError


@pytest.mark.parametrize("value", [5, np.int64(5), np.int32(5), np.array([5]), np.array([[5]]), np.zeros((1, 1), int) + 5])
def test_int_accepts_numpy(value):
    assert api._int(value) == 5 and type(api._int(value)) is int


@pytest.mark.parametrize("value", [0.25, np.float64(0.25), np.float32(0.25), np.array([0.25]), 1, np.array([1])])
def test_float_accepts_numpy(value):
    out = api._float(value)
    assert type(out) is float and out in (0.25, 1.0)


@pytest.mark.parametrize("value", ["3", 3.5, np.array([1, 2]), None, b"x", True])
def test_int_refuses(value):
    with pytest.raises(LocalError):
        api._int(value)


@pytest.mark.parametrize("value", ["0.1", np.array([0.1, 0.2]), None, np.array([])])
def test_float_refuses(value):
    with pytest.raises(LocalError):
        api._float(value)


def test_strings_and_buffers():
    assert api._str(np.str_("UR5")) == "UR5"
    assert api._str(b"UR5") == "UR5"
    assert api._bytes("ab") == b"ab"
    assert api._bytes(bytearray(b"\x00\xff")) == b"\x00\xff"
    assert api._bytes(np.array([1, 255], dtype=np.uint8)) == b"\x01\xff"


def test_not_connected_is_initialize_error():
    assert vrep.simxGetObjectHandle(123, "UR5", vrep.simx_opmode_blocking) == (64, 0)
    assert vrep.simxPauseCommunication(123, True) == 64
    assert vrep.simxGetConnectionId(123) == -1
    assert vrep.simxGetPingTime(123) == (0, 0)


def test_pack_unpack_round_trip():
    packed = vrep.simxPackFloats([1.5, -2.25])
    assert isinstance(packed, bytearray) and len(packed) == 8
    assert vrep.simxUnpackFloats(packed) == [1.5, -2.25]
    assert vrep.simxUnpackInts(vrep.simxPackInts([1, -7, 2**31 - 1])) == [1, -7, 2**31 - 1]


def test_numpy_aliases_restored_by_legacy_import():
    import sim  # noqa: F401

    assert np.int is int and np.float is float and np.object is object and np.str is str


def test_legacy_modules_export_the_same_surface():
    import sim

    assert vrep.simxGetJointPosition is sim.simxGetJointPosition
    assert "simxGetVisionSensorImage" in vrep.__all__ and "simx_opmode_buffer" in vrep.__all__
    assert vrep.__all__ == sorted(vrep.__all__)


def test_image_bytes_become_the_legacy_signed_list():
    """Every byte value converts as vrep.py's c_byte copy did: 0..127 as is, 128..255 negative."""
    import ctypes

    data = bytes(range(256)) * 3
    resolution, image = api._image([[16, 16], data])
    legacy = list((ctypes.c_byte * len(data)).from_buffer_copy(data))
    assert resolution == [16, 16] and image == legacy and type(image[200]) is int
    assert image[:3] == [0, 1, 2] and image[128] == -128 and image[255] == -1
