"""V-HACD (the ``vhacdx`` package) in a worker process with memory and CPU bounds.

``vhacdx.compute_vhacd`` holds Python's GIL for its whole run (seconds for a mesh of a few
thousand triangles): in the server's process it would stop every other thread that runs Python
code, the front doors' included, for that long. So the mesh goes to a fresh interpreter
(``python -m simx_server.base.vhacd_worker``, started with ``subprocess``) on its standard input,
which bounds itself (``RLIMIT_AS`` :data:`MEMORY_BYTES`, ``RLIMIT_CPU`` :data:`CPU_SECONDS`)
before it reads anything and writes the hulls back; the calling thread waits on the pipe
(without the GIL) at most :data:`WALL_SECONDS`, as ``scene/ttt/worker.py`` converts ``.ttt``
files.
"""

from __future__ import annotations

import io
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from simx_server.base import job_ring

#: Address-space bound of a worker, bytes; CPU-time bound, s; wall time the caller waits, s.
MEMORY_BYTES = 2 * 1024 * 1024 * 1024
CPU_SECONDS = 60
WALL_SECONDS = 180
_MISSING = 3  # exit code: vhacdx is not installed
_SLICE_SECONDS = 0.25  # how often the wait looks whether its job was asked to stop


class DecompositionError(RuntimeError):
    """The worker could not decompose the mesh (its reason in the message)."""


class MissingPackageError(DecompositionError):
    """vhacdx is not installed where the worker runs."""


def decompose(vertices: np.ndarray, faces: np.ndarray, resolution: int, vertices_per_hull: int,
              max_hulls: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The convex hulls of a mesh's approximate convex decomposition (V-HACD 4).

    Args:
        vertices: (n, 3) m.
        faces: (t, 3) vertex indices.
        resolution: V-HACD's voxel resolution.
        vertices_per_hull: at most this many vertices per hull.
        max_hulls: at most this many hulls.

    Returns:
        ``[(hull vertices (k, 3), hull faces (h, 3)), ...]``.

    Raises:
        MissingPackageError: vhacdx is not installed.
        DecompositionError: the worker failed or went past a bound.
    """
    buffer = io.BytesIO()
    np.savez(buffer, vertices=np.asarray(vertices, np.float64), faces=np.asarray(faces, np.uint32),
             params=np.array([resolution, vertices_per_hull, max_hulls], np.int64))
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join(filter(None, [str(Path(__file__).resolve().parents[2]),
                                                        os.environ.get("PYTHONPATH")])))
    proc = subprocess.Popen([sys.executable, "-m", "simx_server.base.vhacd_worker"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, close_fds=True,
                            start_new_session=True)
    end, data = time.monotonic() + WALL_SECONDS, buffer.getvalue()
    while True:  # in slices: a job whose client left stops here (job_ring.stop_requested)
        try:
            out, err = proc.communicate(data, timeout=_SLICE_SECONDS)
            break
        except subprocess.TimeoutExpired:
            data = None  # sent already; communicate goes on reading
            if time.monotonic() < end and not job_ring.stop_requested():
                continue
            proc.kill()
            proc.communicate()
            if job_ring.stop_requested():
                raise DecompositionError(f"stopped: {job_ring.stop_reason()}") from None
            raise DecompositionError(f"V-HACD took more than {WALL_SECONDS} s") from None
    if proc.returncode == _MISSING:
        raise MissingPackageError("the vhacdx package is not installed")
    if proc.returncode != 0:
        last = err.decode("utf-8", "replace").strip().splitlines()[-1:] or [f"exit code {proc.returncode}"]
        raise DecompositionError(f"V-HACD failed or went past its bounds ({MEMORY_BYTES >> 20} MiB, "
                                 f"{CPU_SECONDS} s of CPU): {last[0][:300]}")
    with np.load(io.BytesIO(out)) as data:
        count = int(data["count"])
        return [(data[f"v{i}"], data[f"f{i}"]) for i in range(count)]


def main() -> int:
    """The worker: bound itself, read the mesh from stdin, write the hulls to stdout."""
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_BYTES, MEMORY_BYTES))
    resource.setrlimit(resource.RLIMIT_CPU, (CPU_SECONDS, CPU_SECONDS))
    try:
        import vhacdx
    except ImportError:
        return _MISSING
    with np.load(io.BytesIO(sys.stdin.buffer.read())) as data:
        vertices, faces, params = data["vertices"], data["faces"], data["params"]
    resolution, per_hull, max_hulls = (int(p) for p in params)
    parts = vhacdx.compute_vhacd(vertices, faces, maxConvexHulls=max_hulls, resolution=resolution,
                                 maxNumVerticesPerCH=per_hull)
    arrays = {"count": np.array(len(parts))}
    for i, (v, f) in enumerate(parts):
        arrays[f"v{i}"], arrays[f"f{i}"] = np.asarray(v, np.float64), np.asarray(f, np.int64).reshape(-1, 3)
    out = io.BytesIO()
    np.savez(out, **arrays)
    sys.stdout.buffer.write(out.getvalue())
    sys.stdout.buffer.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
