"""Processes the benchmarks start: simx servers, the bare Zenoh echo, client workers.

Every process is started here and stopped by its own PID (SIGTERM, then SIGKILL); nothing
else is ever signalled. Output goes to files in the run's log folder, never to pipes that
could fill up, except the one ready line read from stdout.
"""

from __future__ import annotations

import os
import select
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "ur5_rg2_kinect.xml"
LOOPBACK = "127.0.0.1"
#: More arguments for every simx server the suites start, before the suite's own (``--smoke``:
#: ``--renderers on-demand``, a server's GL renderers made at its first image: half the CPU of a
#: start, and most of the smoke run's servers read no image).
SERVER_ARGS: list[str] = []


def free_port() -> int:
    """A TCP port nothing listens on now (loopback)."""
    with socket.socket() as s:
        s.bind((LOOPBACK, 0))
        return s.getsockname()[1]


def port_in_use(port: int) -> bool:
    """True when something listens on 127.0.0.1:port."""
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((LOOPBACK, port))
        except OSError:
            return True
    return False


def child_env(**extra: str) -> dict[str, str]:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.setdefault("MUJOCO_GL", "egl")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
    env.update(extra)
    return env


def proc_status(pid: int) -> dict[str, float]:
    """A process's resident memory in MB (``rss_mb``) and its thread count (``threads``)."""
    out = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                out["rss_mb"] = int(line.split()[1]) / 1024
            elif line.startswith("Threads:"):
                out["threads"] = int(line.split()[1])
    return out


class Proc:
    """A child process with its stderr in a file and a ready line awaited on stdout."""

    def __init__(self, name: str, cmd: list[str], log_dir: Path, ready: str = "ready",
                 timeout: float = 90.0, env: dict[str, str] | None = None, cwd: Path | None = None,
                 stdin_pipe: bool = False):
        self.name = name
        log_dir.mkdir(parents=True, exist_ok=True)
        self.err_path = log_dir / f"{name}.stderr"
        self._err = open(self.err_path, "wb")
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=self._err, stdin=subprocess.PIPE if stdin_pipe else subprocess.DEVNULL,
                                     env=env or child_env(), cwd=cwd, text=True)
        self.ready_line = self._wait_ready(ready, timeout)

    @property
    def pid(self) -> int:
        return self.proc.pid

    def _wait_ready(self, marker: str, timeout: float) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            r, _, _ = select.select([self.proc.stdout], [], [], 0.2)
            if r:
                line = self.proc.stdout.readline()
                if marker in line:
                    return line.strip()
            if self.proc.poll() is not None:
                break
        self.stop()
        raise RuntimeError(f"{self.name} did not become ready:\n{self.stderr_tail()}")

    def stderr_tail(self, n: int = 3000) -> str:
        try:
            return self.err_path.read_text(errors="replace")[-n:]
        except OSError:
            return ""

    def stop(self, timeout: float = 10.0) -> int | None:
        """SIGTERM this process (by PID), wait, SIGKILL if needed; returns the exit status."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=timeout)
        for stream in (self.proc.stdout, self.proc.stdin):
            if stream:
                try:
                    stream.close()
                except OSError:
                    pass
        self._err.close()
        return self.proc.returncode

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


class Server(Proc):
    """A simx server on its own free loopback port (``python -m simx_server.cli``).

    ``probe_log``: run the instrumented server (benchmarks/instrumented_server.py), which writes
    the wall time (CLOCK_MONOTONIC) at the end of every simulation step and the duration of
    every vision-sensor frame to that file on exit. ``root``: run the server of that simx
    source tree instead of this one (``--baseline``).
    """

    def __init__(self, log_dir: Path, *args: str, port: int | None = None, probe_log: Path | None = None,
                 name: str = "server", root: Path | None = None):
        self.port = port or free_port()
        module = "benchmarks.instrumented_server" if probe_log else "simx_server.cli"
        zmq = [] if "--zmq-port" in args else ["--no-zmq"]  # the ZMQ remote API only where a suite asks
        cmd = [sys.executable, "-m", module, str(SCENE), "--port", str(self.port),
               "--log-level", "WARNING", *zmq, *SERVER_ARGS, *args]
        env = child_env(**({"SIMX_BENCH_PROBE_LOG": str(probe_log)} if probe_log else {}))
        if root is not None:  # another source tree's server (--baseline): its code, this scene
            env["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), os.environ.get("PYTHONPATH", "")) if p)
        super().__init__(f"{name}-{self.port}", cmd, log_dir, env=env, cwd=root or ROOT)


class Echo(Proc):
    """The bare Zenoh floor: benchmarks/zenoh_echo.py on its own free loopback port."""

    def __init__(self, log_dir: Path, port: int | None = None):
        self.port = port or free_port()
        cmd = [sys.executable, "-m", "benchmarks.zenoh_echo", "--port", str(self.port)]
        super().__init__(f"echo-{self.port}", cmd, log_dir, cwd=ROOT)
