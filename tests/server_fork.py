"""``simx-server`` processes for the tests, forked from a process that has imported the server.

Each test server used to be ``python -m simx_server.cli``: a new interpreter importing MuJoCo,
numpy, Zenoh, OpenCV and the server's ~300 modules, about 0.8 s of CPU before it reads its
scene, and the suite starts well over a hundred servers. Here a pytest worker starts one
multiprocessing *forkserver* that imports all that once (``PRELOAD``); each server is a fork
of it running ``simx_server.cli.main`` with the test's arguments, environment and folder, its
stdout on a socket the test reads (the ready line) and its stderr in the test's log file. It is
the same server code, in its own process with its own PID, Zenoh session and GL context (none
is made before the fork): what differs from ``python -m simx_server.cli`` is only that the
imports happened earlier, in the parent.

:class:`ForkedServer` answers the parts of ``subprocess.Popen`` the tests use (``pid``,
``poll``, ``wait``, ``returncode``, ``stdout``, ``send_signal``, ``terminate``, ``kill``).
``SIMX_TEST_FORK_SERVERS=0`` starts real ``python -m simx_server.cli`` processes instead.
"""

from __future__ import annotations

import atexit
import multiprocessing
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

#: What the forkserver imports before its first fork: what ``simx-server`` imports to serve.
PRELOAD = [
    "numpy", "mujoco", "zenoh", "cv2", "msgpack",
    "simx_server.cli", "simx_server.scene.simulation", "simx_server.legacy.server",
    "simx_server.zmq.frontend", "simx_server.zmq.remote_api", "simx_server.loop.tasks",
    "server_fork_frozen",  # last: gc.freeze() of all the above
]

_context: Any = None


def _ctx() -> Any:
    global _context
    if _context is None:
        _context = multiprocessing.get_context("forkserver")
        _context.set_forkserver_preload(PRELOAD)
    return _context


def _serve(argv: list[str], env: dict[str, str], cwd: str | None, out: socket.socket, err_path: str) -> None:
    """The forked server: the test's environment, folder and streams, then ``simx-server``'s
    main as ``python -m simx_server.cli`` would run it, exit functions included (multiprocessing
    ends its children with ``os._exit``, which would skip them)."""
    os.environ.clear()
    os.environ.update(env)
    if cwd is not None:
        os.chdir(cwd)
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    err = os.open(err_path, os.O_WRONLY | os.O_APPEND)
    os.dup2(err, 2)
    os.dup2(out.fileno(), 1)
    out.close()
    for fd in (null, err):
        os.close(fd)
    sys.stdin = open(0, closefd=False)
    sys.stdout = open(1, "w", buffering=1, closefd=False)
    sys.stderr = open(2, "w", buffering=1, closefd=False)
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1):
        signal.signal(sig, signal.SIG_DFL)
    sys.argv = ["simx-server", *argv]
    from simx_server.cli import main

    code = 1
    try:
        code = main(argv) or 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    finally:
        atexit._run_exitfuncs()
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(code)


class ForkedServer:
    """A forked ``simx-server`` with the ``subprocess.Popen`` interface the tests use.

    Args:
        argv: ``simx-server``'s arguments.
        env: its environment.
        cwd: its working folder (None: the test's).
        log: the open file its stderr goes to (appended).
    """

    def __init__(self, argv: list[str], env: dict[str, str], cwd: str | Path | None, log: Any) -> None:
        ours, theirs = socket.socketpair()
        self._process = _ctx().Process(target=_serve, args=(list(argv), env, None if cwd is None else str(cwd),
                                                            theirs, f"/proc/{os.getpid()}/fd/{log.fileno()}"))
        self._process.start()
        theirs.close()
        self.stdout = ours.makefile("r", encoding="utf-8")
        ours.close()  # the file keeps the socket open
        self.pid: int = self._process.pid
        self.returncode: int | None = None

    def poll(self) -> int | None:
        """The exit status (negative: the signal), None while it runs."""
        if self.returncode is None and self._process.exitcode is not None:
            self.returncode = self._process.exitcode
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        """Wait for the exit; ``subprocess.TimeoutExpired`` after ``timeout`` s."""
        self._process.join(timeout)
        if self._process.exitcode is None:
            raise subprocess.TimeoutExpired(["simx-server"], timeout or 0)
        return self.poll()  # type: ignore[return-value]

    def send_signal(self, sig: int) -> None:
        if self.poll() is None:
            os.kill(self.pid, sig)

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)
