"""replies.pack_large: the encoding of replies and stream updates with images is msgpack's, byte
for byte, with the large binaries copied by bytes.join (which CPython does without the GIL)."""

from __future__ import annotations

import msgpack
import numpy as np
import pytest

from simx_client import protocol as P
from simx_server.legacy.replies import LARGE_BINARY, encode_response, pack_large


def _update(*images: bytes) -> list:
    entries = [["GetVisionSensorImage", [7 + k], True, [[4, 4], image]] for k, image in enumerate(images)]
    entries += [["GetJointPosition", [3], True, 0.25], ["GetStringSignal", ["s"], False, "no value"],
                ["GetObjectGroupData", [1, 2], True, [[1, 2], [0.5, -1.0], ["a", "é"], {"k": None}]]]
    return [P.PROTOCOL_VERSION, 1234, entries]


@pytest.mark.parametrize("sizes", [(), (10,), (LARGE_BINARY - 1,), (LARGE_BINARY,), (LARGE_BINARY + 1, 0),
                                   (3 * LARGE_BINARY, 255, 65_536, 2 * LARGE_BINARY)])
def test_the_same_bytes_as_msgpack(sizes):
    rng = np.random.default_rng(len(sizes))
    message = _update(*(rng.integers(0, 256, n, dtype=np.uint8).tobytes() for n in sizes))
    encoded = pack_large(message)
    assert encoded == P.pack(message) == msgpack.packb(message, use_bin_type=True)
    assert msgpack.unpackb(encoded) == message


def test_replies_and_stream_updates_with_images_decode_as_before():
    image = bytes(range(256)) * (2 * LARGE_BINARY // 256)
    results = [[True, [[1024, 512], image]], [False, "handle 99 is not a vision sensor"], [True, 0.5]]
    reply = encode_response(10, 1, results, 5, 2, "client", large=True)
    assert reply == encode_response(10, 1, results, 5, 2, "client")
    assert P.unpack_response(reply)[5] == results
    t, entries = P.unpack_stream_update(P.stream_update(50, _update(image)[2], pack_large))
    assert t == 50 and entries[0][3][1] == image


def test_values_msgpack_refuses_are_refused():
    with pytest.raises(TypeError):
        pack_large([1, object()])
