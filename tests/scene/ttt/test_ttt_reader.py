"""The .ttt/.ttm reader on synthetic files (tttwriter): Huffman decoding, records, the object
model, scripts; and bad input: every truncated or corrupted file is one SceneFileError."""

from __future__ import annotations

import random
import struct
import tracemalloc

import numpy as np
import pytest

from simx_server.scene.ttt import huffman, reader
from simx_server.scene.ttt.errors import SceneFileError
from simx_server.scene.ttt.records import light_decode, unpack_indices, Records

import tttwriter as W

#: Most memory one read of a fuzzed 3-4 kB file may take (bytes).
FUZZ_PEAK_BYTES = 16 << 20


@pytest.mark.parametrize("data", [
    b"a", b"ab" * 1000, bytes(range(256)) * 40,
    np.random.default_rng(1).integers(0, 256, 50_000, dtype=np.uint8).tobytes(),
    # skewed: long codes, long runs of one symbol (periodic data keeps chunk walkers out of phase)
    np.random.default_rng(2).geometric(0.08, 200_000).clip(0, 255).astype(np.uint8).tobytes(),
    b"\x00" * 100_000 + b"\x01\x02\x03" * 30_000,
])
def test_huffman_round_trip(data):
    assert huffman.decode(W.huffman_encode(data), len(data), "x.ttt") == data


def test_huffman_stream_too_short_is_an_error():
    data = bytes(range(256)) * 100
    enc = W.huffman_encode(data)
    with pytest.raises(SceneFileError, match="ends after"):
        huffman.decode(enc[: len(enc) // 2], len(data), "x.ttt")


def test_light_decode_undoes_vrep_encoding():
    text = b"function sysCall_init()\n  sim.setInt32Signal('a', 1) -- \xc3\xa9\nend\n"
    assert W.light_encode(text) != text
    assert light_decode(W.light_encode(text)) == text


def test_packed_indices():
    values = [0, 5, 3, 40000, 2, 70_000_000, 7]
    out = bytearray(struct.pack("<i", len(values)))
    prev = 0
    for v in values:
        d = v - prev
        prev = v
        for n, bias in enumerate((31, 8191, 2097151, 536870911)):
            x = d + bias
            if 0 <= x < (1 << (6 + 8 * n)):
                out.append((x & 0x3F) | (n << 6))
                for k in range(n):
                    out.append((x >> (6 + 8 * k)) & 0xFF)
                break
    r = Records(b"EOO", "x.ttt")
    assert unpack_indices(memoryview(bytes(out)), r, "In2").tolist() == values


def test_read_synthetic_scene(tmp_path):
    f = tmp_path / "cell.ttt"
    f.write_bytes(W.simple_scene())
    s = reader.read(f)
    assert s.serialization == 22 and s.program_version == 40100
    assert {o.name: o.kind for o in s.objects.values()} == {
        "Floor": "shape", "Base": "shape", "Base_joint1": "joint", "Link#0": "shape", "Tip": "dummy", "Cube": "shape"}
    link = s.objects[4]
    assert link.parent == 3 and link.alias == "Link"
    assert s.objects[3].data.position == pytest.approx(0.3) and s.objects[3].data.motor
    assert link.data.mass == pytest.approx(0.5) and not link.data.static
    assert link.data.meshes[0].primitive == 3 and link.data.meshes[0].faces.shape == (12, 3)
    assert s.objects[1].data.static
    assert s.time_step == pytest.approx(0.05) and s.gravity[2] == pytest.approx(-9.81)
    child, threaded, custom = s.scripts
    assert child.object == 4 and child.type == 1 and not child.threaded and "sysCall_init" in child.text
    assert threaded.object == 2 and threaded.threaded and threaded.text == "simRemoteApi.start(19999)\n"
    assert threaded.parameters == [{"name": "port", "value": b"19999", "unit": "int"}]  # bytes as stored
    assert custom.object == 6 and custom.type == 6


def test_unknown_records_and_object_types_are_skipped(tmp_path):
    extra = W.rec("ZZZ", b"\x01\x02\x03") + W.rec("QQQ", W.common(50, -1, "Mystery") + W.lst(W.rec("Foo", b"1")))
    f = tmp_path / "x.ttt"
    f.write_bytes(W.ttt_file(extra + W.cuboid_shape(1, -1, "Box")))
    s = reader.read(f)
    assert s.objects[50].kind == "other" and s.objects[1].name == "Box"


def test_declared_size_beyond_the_file(tmp_path):
    body = W.cuboid_shape(1, -1, "Box")
    bad = body[:3] + struct.pack("<i", 10**8) + body[7:]
    f = tmp_path / "bad.ttt"
    f.write_bytes(W.ttt_file(bad))
    with pytest.raises(SceneFileError, match=r"bad\.ttt: record SHP: declared size"):
        reader.read(f)


def test_huffman_header_size_beyond_bound(tmp_path):
    data = bytearray(W.simple_scene())
    struct.pack_into("<i", data, 13, 2**31 - 1)
    f = tmp_path / "big.ttt"
    f.write_bytes(bytes(data))
    with pytest.raises(SceneFileError, match="big.ttt: record header: body size"):
        reader.read(f)


def test_deep_nesting_is_bounded(tmp_path):
    inner = W.rec("Wrp", b"EOO")
    for _ in range(60):
        inner = W.rec("Wrp", inner + b"EOO")
    info = W.lst(W.rec("Nme", W.string("x"))) + W.lst()
    shape = W.rec("SHP", W.common(1, -1, "Deep") + W.lst(W.rec("Ge2", W.lst(W.rec("Gsg", inner[7:])))))
    f = tmp_path / "deep.ttt"
    f.write_bytes(W.ttt_file(shape))
    del info
    with pytest.raises(SceneFileError, match="MAX_NESTING"):
        reader.read(f)


def test_not_a_vrep_file(tmp_path):
    f = tmp_path / "x.ttt"
    f.write_bytes(b"<mujoco/>")
    with pytest.raises(SceneFileError, match="not a V-REP"):
        reader.read(f)


def test_fuzz_truncated_and_corrupted(tmp_path):
    """Bounded fuzz: 150 cut or bit-flipped files (seeded, the same every run) each end in a
    SceneFileError or read, never another exception, and each read's memory stays within
    FUZZ_PEAK_BYTES (tracemalloc, numpy's arrays included): a flipped size or count field is
    checked against the file's bounds before anything of that size is allocated or decoded.
    Counted in bytes, not seconds: a read that hung would end at pytest's timeout."""
    rng = random.Random(31)
    good = W.simple_scene()
    raw = W.simple_scene(compress=False)
    peaks = []
    for i in range(150):
        base = good if i % 2 else raw
        data = bytearray(base)
        if i % 3 == 0:
            data = data[: rng.randrange(1, len(data))]
        else:
            for _ in range(rng.randrange(1, 8)):
                k = rng.randrange(0, len(data))
                data[k] ^= 1 << rng.randrange(8)
        f = tmp_path / f"f{i}.ttt"
        f.write_bytes(bytes(data))
        tracemalloc.start()
        try:
            reader.read(f)
        except SceneFileError as exc:
            assert str(exc).startswith(f"f{i}.ttt: record ")
        finally:
            peaks.append(tracemalloc.get_traced_memory()[1])
            tracemalloc.stop()
    assert max(peaks) < FUZZ_PEAK_BYTES, max(peaks)  # 0.4 MB on 2026-11-24, for files of 3-4 kB
