"""Issue 12 part 5: legacy image lists that NumPy 2 and fast code can take.

``simxGetVisionSensorImage`` returns signed bytes as vrep.py did; on NumPy 2
``np.array(image, dtype=np.uint8)`` on such a plain list raises OverflowError. The returned
:class:`simx_client.images.ImageList` is an ordinary list to every reader and converts fast,
wrapping as NumPy 1 did; any mutation makes the list the truth again.
"""

from __future__ import annotations

import copy
import json
import pickle

import numpy as np
import pytest

import array
import struct

from simx_client.images import ImageList, LazyImageList, lazy_image_lists, set_lazy_image_lists
from conftest import wait_until

# Every byte value, a few times: -128..127 as vrep.py's c_byte list held them.
RAW = np.arange(256, dtype=np.uint8).repeat(3)
SIGNED = RAW.view(np.int8)


def image() -> tuple[list, ImageList]:
    plain = SIGNED.tolist()
    return plain, ImageList.wrap(list(plain), SIGNED.copy())


def depth() -> tuple[list, ImageList]:
    floats = np.linspace(0, 1, 97, dtype=np.float32) / 3
    return floats.tolist(), ImageList.wrap(floats.tolist(), floats)


def test_a_plain_list_of_negative_bytes_overflows_on_numpy_2():
    """The defect the subclass works around (NumPy 1 wrapped silently)."""
    if np.lib.NumpyVersion(np.__version__) < "2.0.0":
        pytest.skip("NumPy 1 wraps")
    with pytest.raises(OverflowError):
        np.array(SIGNED.tolist(), dtype=np.uint8)


def test_an_ordinary_list_to_every_reader():
    plain, img = image()
    assert isinstance(img, list) and img == plain and plain == img and not (img != plain)
    assert len(img) == len(plain) and img[0] == -128 + 128 and img[-1] == -1 and img[200] == plain[200]
    assert list(img) == plain and [*img] == plain and sum(img) == sum(plain)
    assert repr(img) == repr(plain) and str(img) == str(plain)
    assert type(img[1:4]) is list and img[1:4] == plain[1:4] and type(img + [1]) is list
    assert type(img.copy()) is list and type(img * 2) is list and img * 2 == plain * 2
    assert json.dumps(img) == json.dumps(plain)
    assert img.index(-1) == plain.index(-1) and img.count(5) == plain.count(5) and (-5 in img)
    restored = pickle.loads(pickle.dumps(img))
    assert type(restored) is list and restored == plain  # loads without simx installed
    for clone in (copy.copy(img), copy.deepcopy(img)):
        assert type(clone) is ImageList and clone == plain
        assert np.array_equal(np.array(clone, dtype=np.uint8), RAW)


def test_numpy_conversions_match_a_plain_list():
    plain, img = image()
    wrapped = np.array(img, dtype=np.uint8)
    assert wrapped.dtype == np.uint8 and np.array_equal(wrapped, RAW)  # -1 -> 255, as NumPy 1 did
    assert wrapped.flags.writeable
    for dtype in (None, np.int64, np.int8, np.int16, np.float32, np.float64, bool, "i4"):
        mine, theirs = np.array(img, dtype=dtype), np.array(plain, dtype=dtype)
        assert mine.dtype == theirs.dtype and np.array_equal(mine, theirs), dtype
    for dtype in (np.uint16, np.uint32):  # unsigned wider types wrap as NumPy 1 did too
        assert np.array_equal(np.array(img, dtype=dtype), SIGNED.astype(dtype))
    assert np.array(img).dtype == np.array(plain).dtype == np.int64
    assert np.asarray(img).flags.writeable  # a fresh array, as from a list
    assert np.array_equal(np.array(img, dtype=object), np.array(plain, dtype=object))
    assert np.array_equal(np.array(img, dtype=str), np.array(plain, dtype=str))
    assert np.array_equal(np.reshape(img, (-1, 3)), np.reshape(plain, (-1, 3)))
    with pytest.raises(ValueError):  # NumPy 2 refuses a copy-free view of a list too
        np.array(img, copy=False)
    with pytest.raises(ValueError):
        np.array(plain, copy=False)
    dplain, dimg = depth()
    for dtype in (None, np.float32, np.float64, np.float16):
        mine, theirs = np.array(dimg, dtype=dtype), np.array(dplain, dtype=dtype)
        assert mine.dtype == theirs.dtype and np.array_equal(mine, theirs), dtype
    assert np.array(dimg).dtype == np.float64


def test_the_converted_array_is_a_copy():
    plain, img = image()
    a = np.array(img, dtype=np.uint8)
    a[:] = 0
    b = np.asarray(img)
    b[:] = 7
    assert img == plain and np.array_equal(np.array(img, dtype=np.uint8), RAW)


MUTATIONS = {
    "setitem": lambda l: l.__setitem__(0, 5),
    "setslice": lambda l: l.__setitem__(slice(0, 2), [9, 9]),
    "delitem": lambda l: l.__delitem__(0),
    "append": lambda l: l.append(-3),
    "extend": lambda l: l.extend([1, 2]),
    "iadd": lambda l: l.__iadd__([4]),
    "imul": lambda l: l.__imul__(2),
    "insert": lambda l: l.insert(3, -7),
    "pop": lambda l: l.pop(),
    "remove": lambda l: l.remove(-1),
    "clear": lambda l: l.clear(),
    "sort": lambda l: l.sort(),
    "reverse": lambda l: l.reverse(),
    "init": lambda l: l.__init__([1, -2, 3]),
}


@pytest.mark.parametrize("name", sorted(MUTATIONS))
def test_any_mutation_makes_the_list_the_truth(name):
    plain, img = image()
    np.array(img, dtype=np.uint8)  # convert once before the change
    MUTATIONS[name](plain)
    MUTATIONS[name](img)
    assert img == plain and type(img) is ImageList
    assert np.array_equal(np.array(img), np.array(plain)) and np.array(img).dtype == np.array(plain).dtype
    expected = np.array(plain, dtype=np.int64).astype(np.uint8)  # wrapped, as NumPy 1 did
    assert np.array_equal(np.array(img, dtype=np.uint8), expected)


def test_augmented_assignment_keeps_the_object():
    plain, img = image()
    alias = img
    img += [1]
    img *= 1
    assert img is alias and img == plain + [1] and np.array(img, dtype=np.uint8)[-1] == 1


def test_a_list_built_by_hand_converts_from_its_values():
    img = ImageList([1, -1, 3])
    assert img == [1, -1, 3] and np.array_equal(np.array(img, dtype=np.uint8), [1, 255, 3])
    mixed = ImageList([1, 2.5])
    assert np.array(mixed).dtype == np.float64
    strings = ImageList(["a", "b"])
    assert np.array_equal(np.array(strings), np.array(["a", "b"]))


def test_conversion_reads_the_kept_array_not_the_list():
    """np.array of an ImageList casts the received bytes it keeps, without walking the list
    (what makes it fast: benchmarks/README.md, images suite). White-box: a change made behind
    the list's back (list.__setitem__, which does not drop the kept array) is not seen."""
    raw = np.random.default_rng(0).integers(0, 256, 640 * 480 * 3, dtype=np.uint8)
    img = ImageList.wrap(raw.view(np.int8).tolist(), raw.view(np.int8))
    list.__setitem__(img, 0, (int(raw[0]) + 1) % 128)
    assert np.array_equal(np.array(img, dtype=np.uint8), raw)  # the kept bytes, element 0 too
    img[0] = 7  # through the list's own method: the list is the truth again
    assert np.array(img, dtype=np.uint8)[0] == 7


# ------------------------------------------------------------- through a real server
def test_images_and_depth_from_a_real_server(vrep_client):
    import vrep

    cid = vrep_client
    rc, rgb = vrep.simxGetObjectHandle(cid, "kinect_rgb", vrep.simx_opmode_blocking)
    assert rc == 0
    rc, res, img = vrep.simxGetVisionSensorImage(cid, rgb, 0, vrep.simx_opmode_blocking)
    assert rc == 0 and res == [640, 480] and type(img) is ImageList and len(img) == 640 * 480 * 3
    assert min(img) >= -128 and max(img) <= 127  # signed bytes, as vrep.py returned
    unsigned = np.array(list(img), dtype=np.int64) % 256
    assert np.array_equal(np.array(img, dtype=np.uint8), unsigned)
    assert np.array_equal(np.array(img), np.array(list(img))) and np.array(img).dtype == np.int64
    rc, res, dep = vrep.simxGetVisionSensorDepthBuffer(cid, rgb, vrep.simx_opmode_blocking)
    assert rc == 0 and type(dep) is ImageList and len(dep) == res[0] * res[1]
    assert np.array_equal(np.array(dep), np.array(list(dep))) and np.array(dep).dtype == np.float64
    assert 0.0 <= min(dep) and max(dep) <= 1.0

    # Streamed, the simulation stopped (every update shows the same state): every buffer read
    # is its own list; changing one changes neither the next read nor its conversion.
    assert vrep.simxStopSimulation(cid, vrep.simx_opmode_blocking) == 0
    try:
        assert vrep.simxGetVisionSensorImage(cid, rgb, 1, vrep.simx_opmode_streaming)[0] == 1

        def read():
            return vrep.simxGetVisionSensorImage(cid, rgb, 1, vrep.simx_opmode_buffer)

        wait_until(lambda: read()[0] == 0, 10, what="a streamed grey image")
        _, res, first = read()
        assert type(first) is ImageList and len(first) == res[0] * res[1] == 640 * 480
        values = list(first)
        first[0] = 99
        del first[-1]
        assert np.array(first, dtype=np.uint8)[0] == 99 and len(np.array(first)) == len(values) - 1
        for _ in range(2):  # the inbox's value converted once, handed out as copies
            _, _, again = read()
            assert type(again) is ImageList and again == values
            assert np.array_equal(np.array(again, dtype=np.uint8), np.array(values, dtype=np.int64) % 256)
            again.append(1)
        vrep.simxGetVisionSensorImage(cid, rgb, 1, vrep.simx_opmode_discontinue)
    finally:
        assert vrep.simxStartSimulation(cid, vrep.simx_opmode_blocking) == 0


# ------------------------------------------------------------- lazy lists (opt-in per client)
def lazy_image() -> tuple[list, LazyImageList]:
    plain = SIGNED.tolist()
    return plain, LazyImageList.lazy(SIGNED.copy(), lambda a: a.tolist())


def lazy_depth() -> tuple[list, LazyImageList]:
    floats = np.linspace(0, 1, 97, dtype=np.float32) / 3
    return floats.tolist(), LazyImageList.lazy(floats.copy(), np.ndarray.tolist)


def made(img: ImageList) -> bool:
    return type(img) is ImageList and list.__len__(img) > 0


# Each reader, on a fresh lazy list and on the plain list: same answer, and the lazy one made.
READERS = {
    "len": len, "bool": bool, "index0": lambda l: l[0], "index-1": lambda l: l[-1],
    "slice": lambda l: (type(l[1:7]), l[1:7]), "iter": lambda l: [*l], "list": list, "tuple": tuple,
    "reversed": lambda l: list(reversed(l)), "in": lambda l: -5 in l, "eq": lambda l: l == SIGNED.tolist(),
    "eq_reflected": lambda l: SIGNED.tolist() == l, "ne": lambda l: l != SIGNED.tolist(),
    "lt": lambda l: l < [200], "repr": repr, "str": str, "format": lambda l: f"{l}"[:40],
    "add": lambda l: (type(l + [1]), l + [1]), "radd": lambda l: (type([1] + l), [1] + l),
    "mul": lambda l: l * 2, "rmul": lambda l: 2 * l, "sum": sum, "max": max, "sorted": sorted,
    "copy_method": lambda l: (type(l.copy()), l.copy()), "index": lambda l: l.index(-1), "count": lambda l: l.count(5),
    "json": json.dumps, "pickle": lambda l: (type(pickle.loads(pickle.dumps(l))), pickle.loads(pickle.dumps(l))),
    "array_module": lambda l: array.array("b", list(l)).tolist(), "struct": lambda l: struct.pack(f"{len(l)}b", *l),
    "unpack_call": lambda l: (lambda *a: len(a))(*l), "extend_other": lambda l: [0].__add__(list(l)),
    "list_extend": lambda l: (lambda x: (x.extend(l), x)[1])([7]),
    "slice_assign": lambda l: (lambda x: (x.__setitem__(slice(0, 1), l), x)[1])([7, 8]),
    "bytes_of_unsigned": lambda l: bytes(v % 256 for v in l),
}


BYTES_ONLY = {"array_module", "struct", "bytes_of_unsigned", "index"}  # readers of images only


@pytest.mark.parametrize("name", sorted(READERS))
def test_a_lazy_list_reads_as_the_plain_list(name):
    for factory in (lazy_image, lazy_depth):
        if factory is lazy_depth and name in BYTES_ONLY:
            continue
        plain, img = factory()
        assert type(img) is LazyImageList and list.__len__(img) == 0  # nothing made yet
        assert READERS[name](img) == READERS[name](plain), (name, factory.__name__)
        assert made(img), name


@pytest.mark.parametrize("name", sorted(MUTATIONS))
def test_a_lazy_list_mutates_as_the_plain_list(name):
    plain, img = lazy_image()
    MUTATIONS[name](plain)
    MUTATIONS[name](img)
    assert isinstance(img, ImageList) and img == plain and type(img) is ImageList
    expected = np.array(plain, dtype=np.int64).astype(np.uint8)
    assert np.array_equal(np.array(img, dtype=np.uint8), expected)


def test_a_lazy_list_converts_without_being_made():
    plain, img = lazy_image()
    for dtype in (np.uint8, None, np.int8, np.float32, "i4"):
        mine, theirs = np.array(img, dtype=dtype), np.array(plain, dtype=None if dtype is np.uint8 else dtype)
        if dtype is np.uint8:
            theirs = theirs.astype(np.uint8)  # wrapped, as NumPy 1 did
        assert mine.dtype == theirs.dtype and np.array_equal(mine, theirs), dtype
    assert np.asarray(img, dtype=np.uint8).flags.writeable
    assert np.array_equal(np.reshape(img, (-1, 3)), np.reshape(plain, (-1, 3)))
    assert type(img) is LazyImageList and list.__len__(img) == 0  # still not made
    clone = copy.copy(img)
    assert type(clone) is LazyImageList and clone is not img and list.__len__(img) == 0
    assert np.array_equal(np.array(img, dtype=object), np.array(plain, dtype=object))  # object: made
    assert made(img) and clone == plain


def test_a_lazy_reply_is_the_legacy_reply_unmade():
    """The client's converters: the lazy image of a reply holds the received bytes and no
    list until read; then it equals the legacy list (speed: benchmarks/README.md, envs)."""
    from simx_client.api_sensors import _depth, _depth_lazy, _image, _image_lazy

    raw = np.random.default_rng(0).integers(0, 256, 64 * 48 * 3, dtype=np.uint8).tobytes()
    res, img = _image_lazy([[64, 48], raw])
    assert res == [64, 48] and type(img) is LazyImageList and list.__len__(img) == 0
    assert np.array_equal(np.array(img, dtype=np.uint8), np.frombuffer(raw, np.uint8))
    assert list.__len__(img) == 0 and img == _image([[64, 48], raw])[1]
    floats = np.linspace(0, 1, 64 * 48, dtype=np.float32).tobytes()
    res, dep = _depth_lazy([[64, 48], floats])
    assert type(dep) is LazyImageList and list.__len__(dep) == 0 and dep == _depth([[64, 48], floats])[1]


def test_depth_lists_are_made_in_one_pass_with_the_same_values(monkeypatch):
    """``ImageList.of_floats`` (the depth reply's list, made from the bytes in one C loop)
    equals the float32 values' ``tolist()``, keeps them as the array, and a host whose float
    is not the wire's little-endian float32 takes NumPy's path to the same list."""
    import simx_client.images as images

    raw = np.random.default_rng(1).random(64 * 48, dtype=np.float32)
    raw[:5] = [0.0, 1.0, np.float32(1 / 3), np.nextafter(np.float32(1), np.float32(0)), 1e-30]
    fast = ImageList.of_floats(raw.tobytes())
    assert type(fast) is ImageList and fast == raw.tolist() and all(type(v) is float for v in fast[:5])
    assert np.array(fast, dtype=np.float32).tobytes() == raw.tobytes()
    monkeypatch.setattr(images, "_LITTLE", False)
    slow = ImageList.of_floats(raw.tobytes())
    assert slow == fast and np.array_equal(np.array(slow, dtype=np.float32), raw)


def test_lazy_lists_from_a_real_server_are_per_client(vrep_client):
    import vrep

    cid = vrep_client
    rc, rgb = vrep.simxGetObjectHandle(cid, "kinect_rgb", vrep.simx_opmode_blocking)
    assert rc == 0 and not lazy_image_lists(cid)
    rc, res, eager = vrep.simxGetVisionSensorImage(cid, rgb, 0, vrep.simx_opmode_blocking)
    assert rc == 0 and type(eager) is ImageList
    assert vrep.simxStopSimulation(cid, vrep.simx_opmode_blocking) == 0  # the same state twice
    rc, res, eager = vrep.simxGetVisionSensorImage(cid, rgb, 0, vrep.simx_opmode_blocking)
    rc, dres, eager_depth = vrep.simxGetVisionSensorDepthBuffer(cid, rgb, vrep.simx_opmode_blocking)
    set_lazy_image_lists(cid)
    try:
        assert lazy_image_lists(cid) and not lazy_image_lists(cid + 1)
        rc, res2, img = vrep.simxGetVisionSensorImage(cid, rgb, 0, vrep.simx_opmode_blocking)
        rc2, dres2, dep = vrep.simxGetVisionSensorDepthBuffer(cid, rgb, vrep.simx_opmode_blocking)
        assert rc == rc2 == 0 and res2 == res and dres2 == dres
        assert type(img) is LazyImageList and type(dep) is LazyImageList
        assert np.array_equal(np.array(img, dtype=np.uint8), np.array(eager, dtype=np.uint8))
        assert np.array_equal(np.asarray(dep, dtype=np.float32), np.asarray(eager_depth, dtype=np.float32))
        assert type(img) is LazyImageList  # converting did not make the list
        assert img == eager and dep == eager_depth and type(img) is ImageList
        assert vrep.simxGetVisionSensorImage({cid: 1}, rgb, 0, vrep.simx_opmode_blocking)[0] != 0  # no raise
    finally:
        set_lazy_image_lists(cid, False)
    assert not lazy_image_lists(cid)
