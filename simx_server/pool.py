"""A pool of local ``simx-server`` processes, one scene and one port each.

    from simx_server.pool import ServerPool

    with ServerPool(4, "scenes/ur5_ik.xml", "--speed", "0") as pool:
        for host, port in pool.addresses:     # [("127.0.0.1", 40123), ...]
            ...                               # vrep.simxStart(host, port, True, True, 5000, 5)

Each server is its own process with its own simulation (nothing is shared between them). Ports
are found by binding port 0; if another program takes one before its server listens (the
server then exits saying it cannot listen), that server is started again on another free port.
Each server's stdout and stderr go to a log file (``pool.log_paths``), in a temporary folder
removed by :meth:`ServerPool.close` unless ``log_dir`` was given. :meth:`close` stops every
server by PID (SIGTERM, wait, SIGKILL) and is also called by ``with`` and, as a last resort,
by garbage collection. On Linux the servers also get SIGTERM when the thread that started the
pool ends (``PR_SET_PDEATHSIG``), so a pool's owner killed with SIGKILL leaves no server
behind; create the pool on a thread that lives as long as it (the main thread, usually).

``pool.claims`` (a picklable :class:`ServerClaims`) gives each process that calls ``claim()`` a
server of its own, for identical environment constructors (``gymnasium.make_vec``), and
``pool.close_with(envs)`` closes the pool when ``envs`` is closed (docs/SERVER.md, "Many servers").
"""

from __future__ import annotations

import functools
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

READY = "simx-server ready"
LISTEN_FAILED = "cannot listen"
START_TIMEOUT = 60.0  # s for every server of a pool to print its ready line
STOP_TIMEOUT = 10.0  # s after SIGTERM before SIGKILL
PORT_RETRIES = 5  # new ports tried for one server that lost its port to another program


class PoolError(RuntimeError):
    """A server of the pool did not start; the message has the end of its log."""


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port nothing listens on now at ``host`` (bind port 0 and let the kernel choose)."""
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def _die_with_parent(parent: int) -> None:  # pragma: no cover - runs in the child between fork and exec
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except Exception:
        return
    if os.getppid() != parent:  # the parent died before prctl: no signal would ever come
        os._exit(1)


class ServerClaims:
    """Hands each process that asks a different server of a list; picklable, so that identical
    environment constructors (``gymnasium.make_vec(..., vectorization_mode="async")`` makes every
    worker's environment with the same arguments) still connect each to its own server.

    ``claim()`` takes the first server no process has claimed yet, atomically across the
    processes of this machine (one file per server in ``folder``, made with ``O_EXCL``).
    """

    def __init__(self, addresses: list[tuple[str, int]], folder: str | os.PathLike):
        self.addresses = [(str(h), int(p)) for h, p in addresses]
        self.folder = str(folder)

    def claim(self) -> tuple[str, int]:
        """A server's ``(host, port)`` nobody claimed before. Raises RuntimeError when all are taken."""
        for i, address in enumerate(self.addresses):
            try:
                fd = os.open(os.path.join(self.folder, f"claim-{i}"), os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
            except FileExistsError:
                continue
            os.write(fd, str(os.getpid()).encode())
            os.close(fd)
            return address
        raise RuntimeError(f"all {len(self.addresses)} servers are claimed (more environments than servers)")

    def release(self, address: tuple[str, int]) -> None:
        """Give a claimed server back (an environment's ``close()``): the next ``claim()`` may take it.
        AsyncVectorEnv makes and closes one environment in the parent before its workers start, so
        an environment that claims in its constructor must release in ``close()``."""
        try:
            i = self.addresses.index((str(address[0]), int(address[1])))
        except ValueError:
            return
        try:
            os.unlink(os.path.join(self.folder, f"claim-{i}"))
        except FileNotFoundError:
            pass

    def __repr__(self) -> str:
        return f"ServerClaims({self.addresses})"


class _Instance:
    def __init__(self, index: int, port: int, log_path: Path):
        self.index = index
        self.port = port
        self.log_path = log_path
        self.proc: subprocess.Popen | None = None
        self.tries = 0

    def log_text(self) -> str:
        try:
            return self.log_path.read_text(errors="replace")
        except OSError:
            return ""


class ServerPool:
    """``n`` ``simx-server`` processes on ``host``, each on a port of its own.

    Args:
        n: number of servers (>= 1).
        scene: MJCF file for every server (default: the bundled scene).
        *args: further ``simx-server`` arguments for every server (``"--speed", "0"``, ...);
            not ``--host`` or ``--port``, which the pool chooses. The servers get ``--no-zmq``
            (one ZMQ port cannot serve several servers) unless ``args`` say otherwise.
        host: address every server listens on (``--host``).
        ports: the servers' ports, one per server; default: free ports found by the pool.
            Given ports are not replaced if they are taken: the pool fails instead.
        log_dir: folder for the log files ``server-<i>.log`` (kept); default a temporary folder
            removed by :meth:`close`.
        timeout: seconds for all servers to be ready.
        env: environment of the servers (default: this process's, with ``MUJOCO_GL=egl`` unless set).
        progress: called with a line of text as each server becomes ready (``"simx-server 2 of 3
            ready on port 40123 after 4.1 s"``), for programs that show what a long start is doing;
            default: nothing.

    Attributes:
        addresses: ``[(host, port), ...]``, in server order.
        pids: the servers' process ids.
        log_paths: the servers' log files.

    Raises:
        PoolError: a server exited or was not ready in time; every started server is stopped.
    """

    def __init__(self, n: int, scene: str | os.PathLike | None = None, *args: str, host: str = "127.0.0.1",
                 ports: list[int] | None = None, log_dir: str | os.PathLike | None = None,
                 timeout: float = START_TIMEOUT, env: dict | None = None,
                 progress: Callable[[str], None] | None = None):
        self._progress = progress
        self._instances: list[_Instance] = []
        if n < 1:
            raise ValueError(f"a pool needs at least 1 server, got {n}")
        if ports is not None and len(ports) != n:
            raise ValueError(f"{n} servers need {n} ports, got {len(ports)}")
        for a in args:
            if a.split("=")[0] in ("--host", "--port"):
                raise ValueError(f"{a}: the pool chooses each server's host and port (use host= and ports=)")
        self._own_log_dir = log_dir is None
        self._log_dir = Path(tempfile.mkdtemp(prefix="simx-pool-")) if log_dir is None else Path(log_dir)
        self.host = host
        self._fixed_ports = ports is not None
        zmq = [] if any(a.split("=")[0] in ("--zmq-port", "--no-zmq") for a in args) else ["--no-zmq"]
        self._cmd = [sys.executable, "-m", "simx_server.cli", *([str(scene)] if scene is not None else []),
                     *args, *zmq, "--host", host]
        self._env = dict(os.environ if env is None else env)
        self._env.setdefault("MUJOCO_GL", "egl")
        self._env["PYTHONUNBUFFERED"] = "1"
        self._log_dir.mkdir(parents=True, exist_ok=True)
        self._closed = False
        self._claims: ServerClaims | None = None
        try:
            for i in range(n):
                port = ports[i] if ports is not None else self._new_port()
                inst = _Instance(i, port, self._log_dir / f"server-{i}.log")
                self._instances.append(inst)
                self._start(inst)
            self._wait_ready(timeout)
        except BaseException:
            self.close()
            raise

    # -- starting ------------------------------------------------------------------------

    def _new_port(self) -> int:
        taken = {inst.port for inst in self._instances}
        while True:
            port = free_port(self.host)
            if port not in taken:
                return port

    def _start(self, inst: _Instance) -> None:
        inst.tries += 1
        with open(inst.log_path, "ab") as log:
            inst.proc = subprocess.Popen(
                [*self._cmd, "--port", str(inst.port)], stdin=subprocess.DEVNULL, stdout=log,
                stderr=subprocess.STDOUT, env=self._env,
                preexec_fn=(functools.partial(_die_with_parent, os.getpid()) if sys.platform.startswith("linux")
                            else None))

    def _wait_ready(self, timeout: float) -> None:
        start = time.monotonic()
        deadline = start + timeout
        waiting = list(self._instances)
        while waiting:
            for inst in list(waiting):
                text = inst.log_text()
                if READY in text:
                    waiting.remove(inst)
                    if self._progress is not None:
                        self._progress(f"simx-server {len(self._instances) - len(waiting)} of {len(self._instances)} "
                                       f"ready on port {inst.port} after {time.monotonic() - start:.1f} s")
                    continue
                if inst.proc.poll() is None:
                    continue
                if (LISTEN_FAILED in text and not self._fixed_ports and inst.tries < PORT_RETRIES):
                    # Lost the race for the port to another program: another free port.
                    inst.port = self._new_port()
                    self._start(inst)
                    continue
                raise PoolError(f"simx-server {inst.index} (port {inst.port}) exited with status "
                                f"{inst.proc.returncode} before it was ready; its log ({inst.log_path}):\n"
                                f"{text[-4000:]}")
            if waiting and time.monotonic() > deadline:
                inst = waiting[0]
                raise PoolError(f"simx-server {inst.index} (port {inst.port}) not ready within {timeout:g} s; "
                                f"its log ({inst.log_path}):\n{inst.log_text()[-4000:]}")
            if waiting:
                time.sleep(0.05)

    # -- what the pool offers ------------------------------------------------------------

    @property
    def addresses(self) -> list[tuple[str, int]]:
        return [(self.host, inst.port) for inst in self._instances]

    @property
    def ports(self) -> list[int]:
        return [inst.port for inst in self._instances]

    @property
    def pids(self) -> list[int]:
        return [inst.proc.pid for inst in self._instances if inst.proc is not None]

    @property
    def log_paths(self) -> list[Path]:
        return [inst.log_path for inst in self._instances]

    @property
    def claims(self) -> ServerClaims:
        """A picklable :class:`ServerClaims` over this pool's servers (each server claimed once)."""
        if self._claims is None:
            self._claims = ServerClaims(self.addresses, tempfile.mkdtemp(prefix="simx-claims-"))
        return self._claims

    def close_with(self, owner):
        """Make ``owner.close()`` (a vector environment, say) also close this pool; returns ``owner``."""
        close = owner.close

        def close_both(*args, **kwargs):
            try:
                return close(*args, **kwargs)
            finally:
                self.close()

        owner.close = close_both
        return owner

    def __len__(self) -> int:
        return len(self._instances)

    def poll(self) -> list[int | None]:
        """Each server's exit status, None while it runs."""
        return [inst.proc.poll() if inst.proc is not None else None for inst in self._instances]

    def logs(self) -> list[str]:
        """Each server's log so far."""
        return [inst.log_text() for inst in self._instances]

    # -- stopping ------------------------------------------------------------------------

    def close(self, timeout: float = STOP_TIMEOUT) -> None:
        """Stop every server: SIGTERM by PID, wait up to ``timeout`` s, SIGKILL what still runs.
        Idempotent; removes the temporary log folder (not a ``log_dir`` given)."""
        if getattr(self, "_closed", True):
            return
        self._closed = True
        procs = [inst.proc for inst in self._instances if inst.proc is not None]
        for p in procs:
            if p.poll() is None:
                try:
                    p.send_signal(signal.SIGTERM)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + timeout
        for p in procs:
            try:
                p.wait(timeout=max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        if self._own_log_dir:
            shutil.rmtree(self._log_dir, ignore_errors=True)
        if self._claims is not None:
            shutil.rmtree(self._claims.folder, ignore_errors=True)

    def __enter__(self) -> ServerPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close(timeout=2.0)
        except Exception:
            pass

    def __repr__(self) -> str:
        return f"ServerPool({len(self._instances)} servers at {self.addresses})"
