"""V-REP scene files (issue 31): Huffman decoding, conversion to MJCF, cached start.

* decode: :func:`simx_server.scene.ttt.huffman.decode` of the largest file of
  ``../shared/ttt-corpus`` (a synthetic 2.4 MB body when the corpus is absent), MB/s of output;
  floor: zlib (C) inflating the same body, side by side.
* convert: read + convert + write of every corpus file, seconds per MB of file.
* cached start: ``mjcf_for`` (hash, cache hit) + ``World`` of the tutorial's ``scene.ttt``,
  against ``World`` of the same converted MJCF: the cache's cost over an MJCF start.

Run alone: ``MUJOCO_GL=egl python -m benchmarks.ttt [--quick]``.
"""

from __future__ import annotations

import sys
import tempfile
import time
import zlib
from pathlib import Path

import numpy as np

from benchmarks.common import Settings
from benchmarks.stats import Figure, summary

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT.parent / "shared" / "ttt-corpus"
TUTORIAL = CORPUS / "Ianlande+Vrep_yolov3_ddpg_pytorch__scenes_scene.ttt"


def _timed(fn, n: int) -> list[float]:
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def _floor(values: list[float], label: str) -> dict:
    return {"label": label, **summary(values)}


def _largest_body() -> tuple[str, bytes, int]:
    from simx_server.scene.ttt.records import HEADER_BYTES, read_header

    files = sorted(CORPUS.glob("*.tt[tm]"), key=lambda p: p.stat().st_size) if CORPUS.is_dir() else []
    if files:
        data = files[-1].read_bytes()
        return files[-1].name, data[HEADER_BYTES:], read_header(data, files[-1].name).body_size
    sys.path.insert(0, str(ROOT / "tests" / "scene" / "ttt"))
    import tttwriter as W  # a synthetic body: mixed text-like and float data

    rng = np.random.default_rng(0)
    body = (rng.normal(size=300_000).astype("<f4").tobytes() + b"sim.setJointTargetVelocity " * 30_000)
    return "synthetic", W.huffman_encode(body), len(body)


def run(s: Settings) -> list[Figure]:
    from simx_server.scene.ttt import cache, convert, huffman, reader
    from simx_server.sim.world import World

    figures = []
    name, stream, size = _largest_body()
    body = huffman.decode(stream, size, name)
    packed = zlib.compress(body, 6)
    n = s.n(7, 3)
    cpu = []

    def decode_once():
        t0 = time.process_time()
        huffman.decode(stream, size, name)
        cpu.append(time.process_time() - t0)

    dec = _timed(decode_once, n)
    flo = _timed(lambda: zlib.decompress(packed), n)
    mb = size / 1e6
    figures.append(Figure("ttt.decode", f"Huffman decode {name[:40]} ({len(stream) / 1e6:.2f} MB in)", "MB/s",
                          summary(mb / t for t in dec), _floor([mb / t for t in flo], "zlib inflate (C), same body"),
                          extra={"seconds": summary(dec), "cpu_seconds": summary(cpu)}))
    files = sorted(CORPUS.glob("*.tt[tm]")) if CORPUS.is_dir() else []
    if files:
        per_mb = []
        with tempfile.TemporaryDirectory() as tmp:
            for i, f in enumerate(files[: s.n(len(files), 4)]):
                t0 = time.perf_counter()
                convert.convert(reader.read(f), Path(tmp) / str(i), "scene")
                per_mb.append((time.perf_counter() - t0) / (f.stat().st_size / 1e6))
        figures.append(Figure("ttt.convert", f"read + convert, {len(per_mb)} corpus files", "s/MB",
                              summary(per_mb)))
    if TUTORIAL.is_file():
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp)
            xml = cache.mjcf_for(TUTORIAL, root)  # converted once: the later starts hit the cache
            k = s.n(5, 2)
            hit = _timed(lambda: World(cache.mjcf_for(TUTORIAL, root), 0.05), k)
            plain = _timed(lambda: World(xml, 0.05), k)
            figures.append(Figure("ttt.cached_start", "scene.ttt start, cached (hash + World)", "s", summary(hit),
                                  _floor(plain, "World of the same MJCF")))
    return figures


if __name__ == "__main__":
    quick = "--quick" in sys.argv
    for fig in run(Settings(quick=quick, log_dir=Path(tempfile.mkdtemp()))):
        floor = f"  floor {fig.floor['label']}: {fig.floor['median']:.3g}" if fig.floor else ""
        ratio = f"  ratio {fig.stats['median'] / fig.floor['median']:.2f}" if fig.floor else ""
        cpu = f"  CPU s median {fig.extra['cpu_seconds']['median']:.3g}" if "cpu_seconds" in fig.extra else ""
        print(f"{fig.label}: median {fig.stats['median']:.3g} {fig.unit} "
              f"(p10 {fig.stats['p10']:.3g}, p90 {fig.stats['p90']:.3g}){floor}{ratio}{cpu}")
