"""Scene-file loads and the other clients (issue 40): another client's blocking-call latency
while a client loads large in-bounds V-REP files.

Each case runs against a simx server of its own (stopped, a one-cuboid start scene, the
conversion cache in a fresh folder): one client loads the file (``simxLoadScene`` or, for a
``.ttm``, ``simxLoadModel``, options 0: a file of the scene folder), while this process's
other client makes a blocking ``simxGetObjectHandle("Floor")`` (answered on the simulation
thread; after a scene load, with its error: no Floor there) every 0.1 s from 1 s before the load
until 1 s after its reply. Figures: the other client's median, p99 and worst latency during
that window, against the same calls' p99 unloaded (measured just before, same server), and
the load's own time.

The files (written with the tests' writer, ``tests/scene/ttt/tttwriter.py``):

* ``pool``: 100 shapes on one pool mesh of 100,000 vertices and 190,000 triangles;
* ``packed``: four shapes of 199,000 triangles each, packed (``In2``) index arrays;
* ``texture``: a cuboid with a 4096x4096 texture;
* ``pool.ttm``: the pool file as a model.

Run alone: ``MUJOCO_GL=egl python -m benchmarks.scene_loads [--quick] [case ...]`` (quick:
pool and pool.ttm only). Every process is started here and stopped by its own PID; loopback only.
"""

from __future__ import annotations

import os
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from benchmarks.procs import ROOT, Proc, child_env, free_port
from simx_client import api
from simx_client import constants as C

sys.path.insert(0, str(ROOT / "tests" / "scene" / "ttt"))
import tttwriter as W  # noqa: E402  (the tests' own .ttt writer)

B = C.simx_opmode_blocking
PERIOD = 0.1  # s between the other client's calls


def _pool() -> bytes:
    rng = np.random.default_rng(40)
    pool = W.mesh_pool(rng.random((100_000, 3)), rng.integers(0, 100_000, 3 * 190_000))
    return W.ttt_file(pool + b"".join(W.pool_shape(k + 1, -1, f"S{k}", pos=(0.05 * k, 0, 0)) for k in range(100)),
                      compress=False)


def _packed() -> bytes:
    rng = np.random.default_rng(41)
    pool = W.mesh_pool(rng.random((100_000, 3)), W.packed(rng.integers(0, 100_000, 3 * 199_000)))
    more = b"".join(W.rec("VIN", W.lst(W.rec("In2", W.packed(rng.integers(0, 100_000, 3 * 199_000)))))
                    for _ in range(3))
    return W.ttt_file(pool + more + b"".join(W.pool_shape(k + 1, -1, f"S{k}", 0, k) for k in range(4)), compress=False)


def _texture() -> bytes:
    rgb = np.random.default_rng(42).integers(0, 255, (4096, 4096, 3), dtype=np.uint8)
    return W.ttt_file(W.texture(7, "big", rgb) + W.cuboid_shape(1, -1, "Tex", (1, 1, 1)), compress=False)


CASES = {"pool": ("pool.ttt", _pool), "packed": ("packed.ttt", _packed), "texture": ("texture.ttt", _texture),
         "pool.ttm": ("pool.ttm", _pool)}


def _p(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) * 1000 if values else float("nan")


def _calls(cid: int, seconds: float | None, stop: threading.Event | None = None) -> list[float]:
    """Blocking calls every PERIOD s for ``seconds`` (or until ``stop``): their latencies."""
    out: list[float] = []
    end = time.monotonic() + seconds if seconds is not None else None
    while (end is None or time.monotonic() < end) and not (stop is not None and stop.is_set()):
        t0 = time.perf_counter()
        rc = api.simxGetObjectHandle(cid, "Floor", B)[0]
        out.append(time.perf_counter() - t0)
        if rc not in (0, C.simx_return_remote_error_flag):  # no Floor in the loaded scene: still answered
            raise RuntimeError(f"simxGetObjectHandle answered {rc}")
        time.sleep(max(0.0, PERIOD - out[-1]))
    return out


def run_case(case: str, folder: Path, log_dir: Path) -> dict:
    """One server, one load of ``case`` while the other client calls; the figures."""
    name, make = CASES[case]
    (folder / name).write_bytes(make())
    port, other_port = free_port(), free_port()
    cmd = [sys.executable, "-m", "simx_server.cli", str(folder / "start.ttt"), "--port", str(port),
           "--port", str(other_port), "--stopped", "--renderers", "on-demand", "--no-zmq", "--log-level", "WARNING"]
    env = child_env(XDG_CACHE_HOME=str(folder / f"cache-{case}"))
    with Proc(f"server-{case}", cmd, log_dir, env=env, cwd=ROOT, timeout=60):
        loader = api.simxStart("127.0.0.1", port, True, True, -120_000, 5)
        other = api.simxStart("127.0.0.1", other_port, True, True, 30_000, 5)
        if loader < 0 or other < 0:
            raise RuntimeError("cannot connect")
        try:
            unloaded = _calls(other, 5.0)
            stop, result = threading.Event(), {}

            def load() -> None:
                time.sleep(1.0)
                t0 = time.perf_counter()
                if name.endswith(".ttm"):
                    result["rc"] = api.simxLoadModel(loader, name, 0, B)[0]
                else:
                    result["rc"] = api.simxLoadScene(loader, name, 0, B)
                result["s"] = time.perf_counter() - t0
                time.sleep(1.0)
                stop.set()

            thread = threading.Thread(target=load)
            thread.start()
            loaded = _calls(other, None, stop)
            thread.join()
        finally:
            api.simxFinish(loader)
            api.simxFinish(other)
    return {"case": case, "rc": result.get("rc"), "load_s": round(result.get("s", float("nan")), 2),
            "unloaded_p99_ms": round(_p(unloaded, 99), 1), "median_ms": round(_p(loaded, 50), 1),
            "p99_ms": round(_p(loaded, 99), 1), "worst_ms": round(max(loaded) * 1000, 1), "calls": len(loaded)}


def main(argv: list[str]) -> None:
    """Run the cases named in ``argv`` (none: all; ``--quick``: pool and pool.ttm) and print
    one line of figures each."""
    cases = [a for a in argv if a in CASES] or (["pool", "pool.ttm"] if "--quick" in argv else list(CASES))
    os.environ.setdefault("MUJOCO_GL", "egl")
    with tempfile.TemporaryDirectory(prefix="simx-bench-loads-") as tmp:
        folder = Path(tmp)
        (folder / "start.ttt").write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Floor", (2, 2, 0.1), dynamic=False)))
        for case in cases:
            print(run_case(case, folder, folder), flush=True)
    print(f"load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main(sys.argv[1:])
