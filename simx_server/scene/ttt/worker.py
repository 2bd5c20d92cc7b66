"""Read and convert one ``.ttt``/``.ttm`` file in a worker process with memory and CPU bounds.

A V-REP file is the largest input simx parses, and a client can send one. Its reader
(:mod:`~simx_server.scene.ttt.reader`) checks every count against its bound before the work it
bounds; this module adds the bounds of the process around it, as browsers parse untrusted media:
the file's bytes go to a fresh interpreter (``python -m simx_server.scene.ttt.worker``, started
with ``subprocess``, no fork of the server's threads) on its standard input; that process sets
an address-space limit (``RLIMIT_AS``, :data:`MEMORY_BYTES`) and a CPU-time limit
(``RLIMIT_CPU``, :data:`CPU_SECONDS`) on itself before it reads anything, converts the file into
the folder it was given (MJCF, meshes, textures, scripts, ``report.json``) and exits. The server
waits at most :data:`WALL_FACTOR` x the CPU bound (at least :data:`WALL_MIN_SECONDS`) of wall
time, then kills it. Whatever the worker allocated
goes with it: the server's memory stays where it was.

The operator sets the bounds with ``SIMX_TTT_WORKER_MB`` and ``SIMX_TTT_WORKER_CPU_S``
(read when a conversion starts; the tests lower them).
"""

from __future__ import annotations

import atexit
import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

from simx_server.scene.ttt.errors import SceneFileError

#: Default address-space bound of a worker (``RLIMIT_AS``), bytes; ``SIMX_TTT_WORKER_MB``.
MEMORY_BYTES = 3 * 1024 * 1024 * 1024
#: Default CPU-time bound of a worker (``RLIMIT_CPU``), s; ``SIMX_TTT_WORKER_CPU_S``.
CPU_SECONDS = 60
#: Wall time a worker may take, as a multiple of its CPU bound (it may be descheduled), and at least.
WALL_FACTOR, WALL_MIN_SECONDS = 3, 60
_SCENE, _COMPILE, _MEMORY = 3, 4, 5  # worker exit codes with a JSON line on stdout
_MAX_OUTPUT = 64 * 1024  # bytes of the worker's stdout/stderr kept
_running: set[subprocess.Popen] = set()  # workers under way (killed at the server's exit)
# what a library that could not allocate within RLIMIT_AS writes before it ends the process
_OUT_OF_MEMORY = (b"MemoryError", b"std::bad_alloc", b"Memory allocation", b"Cannot allocate memory")


def limits() -> tuple[int, int]:
    """``(memory bytes, cpu seconds)`` from the environment, else the defaults.

    Raises:
        ValueError: a set variable is not a positive integer.
    """
    mb = os.environ.get("SIMX_TTT_WORKER_MB")
    cpu = os.environ.get("SIMX_TTT_WORKER_CPU_S")
    memory = int(mb) * 1024 * 1024 if mb else MEMORY_BYTES
    seconds = int(cpu) if cpu else CPU_SECONDS
    if memory <= 0 or seconds <= 0:
        raise ValueError("SIMX_TTT_WORKER_MB and SIMX_TTT_WORKER_CPU_S must be positive integers")
    return memory, seconds


def convert(file: str, data: bytes, out: Path, stem: str, client: bool = False) -> None:
    """Convert a file's bytes into ``out/<stem>.xml`` (and its meshes, scripts, report) in a
    bounded worker process; blocks the calling thread until the worker is done (call it off the
    simulation thread where clients are served).

    Args:
        file: the file's name (for errors; ``.ttm`` makes it a model).
        data: its bytes (at most ``MAX_FILE_BYTES``, checked by the caller).
        out: an existing empty folder that receives the conversion.
        stem: the MJCF's file name without ``.xml`` (``scene`` or ``model``).
        client: a client's file: more objects than a client's scene may have elements
            (``limits.MAX_SCENE_ELEMENTS``) are refused as they are read, not after converting.

    Raises:
        SceneFileError: the file cannot be read or is beyond a reader bound (as the reader
            raises it), or the worker went past its memory (``RLIMIT_AS``), CPU (``RLIMIT_CPU``)
            or wall-time bound (record ``"worker"``), or failed otherwise.
        ValueError: MuJoCo cannot compile the conversion (its message).
    """
    memory, cpu = limits()
    wall = max(WALL_MIN_SECONDS, cpu * WALL_FACTOR)
    # No GL in the worker: MUJOCO_GL=disable keeps ``import mujoco`` from loading a GL backend
    # (without it, GLFW: 0.035 s of the worker's 0.22 s of CPU for a small file).
    env = {k: v for k, v in os.environ.items() if not k.startswith(("MUJOCO_GL", "PYOPENGL"))}
    env["MUJOCO_GL"] = "disable"
    package_root = str(Path(__file__).resolve().parents[3])
    env["PYTHONPATH"] = os.pathsep.join([package_root, *filter(None, [env.get("PYTHONPATH")])])
    env.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1",
               SIMX_TTT_WORKER_LIMITS=f"{memory} {cpu}")
    argv = [sys.executable, "-m", "simx_server.scene.ttt.worker", file, str(out), stem, "client" if client else "operator"]
    proc = subprocess.Popen(argv,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                            close_fds=True, start_new_session=True)
    _running.add(proc)
    try:
        stdout, stderr = proc.communicate(data, timeout=wall)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise SceneFileError(file, "worker", f"conversion took more than its {wall} s of wall time "
                             f"({WALL_FACTOR} x SIMX_TTT_WORKER_CPU_S, at least {WALL_MIN_SECONDS} s)") from None
    finally:
        _running.discard(proc)
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    _outcome(file, proc.returncode, stdout[-_MAX_OUTPUT:], stderr[-_MAX_OUTPUT:], memory, cpu)


@atexit.register
def _end_running() -> None:
    """The server exits: its workers end with it (a conversion nobody waits for)."""
    for proc in list(_running):
        if proc.poll() is None:
            proc.kill()


def _outcome(file: str, code: int, stdout: bytes, stderr: bytes, memory: int, cpu: int) -> None:
    """Raise the error a worker's exit code and output tell (nothing for success)."""
    if code == 0:
        return
    memory_text = (f"ran out of its memory bound (RLIMIT_AS = {memory // (1024 * 1024):,} MiB, "
                   "SIMX_TTT_WORKER_MB)")
    if code in (_SCENE, _COMPILE, _MEMORY):
        try:
            told = json.loads(stdout.decode("utf-8", "replace").strip().splitlines()[-1])
        except (ValueError, IndexError):
            told = {}
        if code == _SCENE and "record" in told:
            raise SceneFileError(file, told["record"], told["message"])
        if code == _COMPILE and "message" in told:
            raise ValueError(told["message"])
        if code == _MEMORY:
            raise SceneFileError(file, "worker", f"conversion {memory_text}")
    if code in (-signal.SIGXCPU, -signal.SIGKILL):
        raise SceneFileError(file, "worker", f"conversion took more than its CPU-time bound "
                             f"(RLIMIT_CPU = {cpu} s, SIMX_TTT_WORKER_CPU_S)")
    if any(sign in stderr for sign in _OUT_OF_MEMORY) or code == -signal.SIGSEGV:
        raise SceneFileError(file, "worker", f"conversion {memory_text}")
    last = stderr.decode("utf-8", "replace").strip().splitlines()[-1:] or [f"exit code {code}"]
    raise SceneFileError(file, "worker", f"conversion failed: {last[0][:300]}")


def _bound_self(memory: int, cpu: int) -> None:
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))  # SIGXCPU at cpu s, SIGKILL one s later


def main(argv: list[str]) -> int:
    """The worker's entry point: ``FILE OUT STEM client|operator`` (the file's bytes on stdin);
    returns the exit code (0 done; 3 a reader error, 4 MuJoCo refused the result, 5 out of
    memory, each with one JSON line on stdout)."""
    file, out, stem, whose = argv
    memory, cpu = (int(v) for v in os.environ["SIMX_TTT_WORKER_LIMITS"].split())
    _bound_self(memory, cpu)
    if whose == "client":  # each object becomes at least one MuJoCo element
        from simx_server.base import limits as L
        from simx_server.scene.ttt import errors as E

        E.MAX_OBJECTS = min(E.MAX_OBJECTS, L.MAX_SCENE_ELEMENTS)
    try:
        data = sys.stdin.buffer.read()
        from simx_server.scene.ttt import convert as conversion
        from simx_server.scene.ttt import reader

        scene = reader.read(file, data)
        del data
        conversion.convert(scene, Path(out), stem)
    except SceneFileError as exc:
        print(json.dumps({"record": exc.record, "message": exc.message}), flush=True)
        return _SCENE
    except MemoryError:
        print(json.dumps({"memory": True}), flush=True)
        return _MEMORY
    except ImportError as exc:  # a library that could not map itself within RLIMIT_AS
        if "memory" not in str(exc).lower():
            raise
        print(json.dumps({"memory": True}), flush=True)
        return _MEMORY
    except ValueError as exc:
        print(json.dumps({"message": str(exc)}), flush=True)
        return _COMPILE
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
