"""Shared fixtures: real simx-server processes on free loopback ports."""

from __future__ import annotations

import os
import secrets
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering for in-process tests too

ROOT = Path(__file__).resolve().parents[1]

#: Seconds the test files of 3 s or more take (setup, calls and teardown, from pytest's junit
#: reports of two whole-suite runs on 2 cores with the suite's 4 workers, 2026-11-25, without
#: the train and ray extras: 1,070 s in all, each run about 280 s, beside other work on the
#: machine (load 2-8), which stretches them all; their order is what counts). pytest-xdist's
#: --dist loadfile hands files out in the order of its queue; by default it sorts that queue by
#: test count, so one-test files such as the Ray cluster test (32 s) came last and a worker ended
#: the run alone with them (about 20 s of the suite's 141 s).
#: scripts/test.sh passes --no-loadscope-reorder and the hook below queues files longest first
#: (these; the others, mostly unit tests, by their test count at 0.05 s each).
SLOW_FILES = {
    # The Ray cluster test runs alone after the others in scripts/test.sh's whole-suite run; its
    # weight orders it when pytest is given paths (queued mid-run: started first, with every
    # process of a fresh clone compiling its modules, its env servers timed out a trigger).
    # The DDPG smoke test's figure is from a run with the train extra (2026-11-22).
    "e2e/test_ray_cluster.py": 9, "e2e/test_train_ddpg.py": 30,
    "scripts/test_script_census.py": 135, "scene/ttt/test_gripper_drives.py": 65,
    "scripts/test_script_budget.py": 53, "e2e/test_robotcontrol_e2e.py": 42, "e2e/test_viewer.py": 28,
    "zmq/test_zmq_hardening.py": 24, "client/test_envs.py": 23, "scene/ttt/test_ttt_worker.py": 23,
    "scene/ttt/test_ttt_corpus.py": 22, "zmq/test_zmq_images.py": 22, "client/test_outbox.py": 21,
    "transport/test_pool.py": 19, "transport/test_netns.py": 18, "scripts/test_lua_c_bounds.py": 17,
    "e2e/test_zmq_programs.py": 16, "scene/ttt/test_ttt_tutorial_rg2_cube.py": 16,
    "client/test_client_robustness.py": 14, "e2e/test_pioneer.py": 14, "transport/test_memory_budgets.py": 14,
    "transport/test_memory_kept.py": 13, "client/test_dataset.py": 12, "client/test_envs_local_servers.py": 12,
    "scene/ttt/test_ttt_tutorial_rg2.py": 12, "transport/test_big_streams.py": 12,
    "transport/test_server_core.py": 12, "scene/ttt/test_ttt_filters.py": 11, "sim/test_render_threads.py": 11,
    "scene/ttt/test_ttt_reader.py": 10, "scripts/test_vpg_style.py": 10, "transport/test_budgets.py": 10,
    "transport/test_cli.py": 10, "transport/test_stream_order.py": 10, "client/test_env_determinism.py": 9,
    "client/test_pool_gym.py": 9, "scripts/test_script_hardening.py": 9, "transport/test_first_frame.py": 9,
    "transport/test_first_run.py": 9, "client/test_api_objects.py": 8, "e2e/test_integration.py": 8,
    "scene/test_confinement.py": 8, "scene/ttt/test_ttt_looks.py": 8, "scripts/test_scripts.py": 8,
    "scene/ttt/test_ttt_bounds.py": 7, "commands/test_small_fidelity.py": 6, "pyrep/test_objects.py": 6,
    "scene/ttt/test_ttt_deferred.py": 6, "scripts/test_facade_services.py": 6, "transport/test_fuzz.py": 6,
    "transport/test_pacing.py": 6, "pyrep/test_robots.py": 5, "scene/test_editing.py": 5,
    "scene/test_inspect_scene.py": 5, "scene/ttt/test_load_off_thread.py": 5, "scene/ttt/test_ttt_kinds.py": 5,
    "scripts/test_facade4.py": 5, "sim/test_table_for_pyrep.py": 5, "sim/test_tutorial_pose.py": 5,
    "transport/test_cli_messages.py": 5, "transport/test_flood_order.py": 5, "transport/test_slow_consumer.py": 5,
    "transport/test_stepped_overlap.py": 5, "zmq/test_zmq_security.py": 5, "client/test_api_sensors.py": 4,
    "commands/test_sensors.py": 4, "e2e/test_xdisplay.py": 4, "loop/test_pass_window.py": 4,
    "pyrep/test_more_objects.py": 4, "scene/ttt/test_ttt_server.py": 4, "scripts/test_api32_scripts.py": 4,
    "sim/test_depth_frames.py": 4, "transport/test_client_folders.py": 4, "transport/test_stepped.py": 4,
    "client/test_client_faults.py": 3, "scene/test_scene_budgets.py": 3, "scene/ttt/test_ttt_custom.py": 3,
    "scene/ttt/test_ttt_settings.py": 3, "scripts/test_legacy_scripts.py": 3, "scripts/test_sim_ik_chains.py": 3,
    "test_layers.py": 3, "transport/test_client_slots.py": 3, "transport/test_idle.py": 3,
    "transport/test_security.py": 3, "transport/test_zmq_api.py": 3,
}


def pytest_collection_modifyitems(session, config, items):
    """Queue the test files longest first (see SLOW_FILES); a file's tests keep their order."""
    tests = Path(__file__).resolve().parent
    counts: dict[str, int] = {}
    names = []
    for item in items:
        try:
            name = item.path.resolve().relative_to(tests).as_posix()
        except ValueError:
            name = ""
        names.append(name)
        counts[name] = counts.get(name, 0) + 1
    weight = {n: SLOW_FILES.get(n, 0.05 * c) for n, c in counts.items()}
    order = sorted(range(len(items)), key=lambda k: -weight[names[k]])  # stable
    items[:] = [items[k] for k in order]


@pytest.fixture(autouse=True)
def _renderers_on_demand(request, monkeypatch):
    """Under the marker ``renderers_on_demand`` (tests and modules whose in-process
    ``Simulation`` is never asked for an image), a ``Simulation`` made in the test (not in a
    module-scoped fixture) makes its renderers at the first image, as the server's
    ``--renderers on-demand``, unless the test passes ``renderers_at_load`` itself: each
    Simulation has its own GL context (0.35-0.45 s of CPU to make on llvmpipe) and every edit
    made its renderers again at load (test_editing.py: 22 s of CPU, 4 s without)."""
    if request.node.get_closest_marker("renderers_on_demand") is None:
        return
    from simx_server.scene.simulation import Simulation

    made_at_load = Simulation.__init__

    def on_demand(self, *args, **kwargs):
        kwargs.setdefault("renderers_at_load", False)
        made_at_load(self, *args, **kwargs)

    monkeypatch.setattr(Simulation, "__init__", on_demand)


#: Groups of skipped tests the summary names (issue 44): a part of each skip reason -> the group.
SKIP_GROUPS = (
    ("a plain clone has no ../shared", "the tutorial's own files (../shared beside the checkout: robotControl.py, "
                                       "RG2.lua, the reference tables, the real scene files)"),
    ("needs the train extra", "training (the train extra: scripts/install-train.sh)"),
    ("needs the ray extra", "Ray RLlib (the ray extra: scripts/install-train.sh ray)"),
    ("coppeliasim_zmqremoteapi_client", "CoppeliaSim's ZMQ client (the test extra)"),
    ("gymnasium", "Gymnasium (the test extra)"),
)


@pytest.hookimpl(hookwrapper=True, tryfirst=True)
def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """Close the run with one line per group of skipped tests and why they were skipped, so a
    green run on a plain clone says what it did not run (``-ra`` lists each test above); the
    outermost wrapper, so that these lines come after pytest's own short summary."""
    yield
    skipped = terminalreporter.stats.get("skipped", [])
    if not skipped:
        return
    groups: dict[str, int] = {}
    for report in skipped:
        reason = str(report.longrepr[2] if isinstance(report.longrepr, tuple) else report.longrepr)
        group = next((name for key, name in SKIP_GROUPS if key in reason), "other reasons (listed above)")
        groups[group] = groups.get(group, 0) + 1
    terminalreporter.write_sep("-", "simx: skipped tests, by group")
    for group, count in sorted(groups.items(), key=lambda kv: -kv[1]):
        terminalreporter.write_line(f"simx: skipped {count} test(s) of {group}")


SHARED = ROOT.parent / "shared"
LEGACY = SHARED / "legacy"
REFERENCE = SHARED / "reference"
SCENE = ROOT / "scenes" / "ur5_rg2_kinect.xml"


def require_shared(path: Path, what: str = "from the tutorial") -> Path:
    """``path`` (a file or folder kept in ``../shared/`` beside the checkout: the tutorial's legacy
    program, the original RG2.lua, the reference tables, the corpus of real scene files) when it
    exists; ``what`` says in a few words what it is (the skip reason puts it in parentheses).

    A plain clone has no ``../shared``: then the calling test SKIPS, with a reason that names the
    missing file and the absolute path where it is expected. When the environment variable ``CI``
    is set (non-empty) it FAILS instead, so CI, which keeps ``../shared`` beside its checkout,
    never silently loses these tests. Call it at the start of the test or fixture that needs it.
    """
    path = Path(os.path.normpath(path))  # "tests/../../shared/x" names ../shared as "shared/x"
    if path.exists():
        return path
    why = (f"{path.relative_to(SHARED.parent) if path.is_relative_to(SHARED.parent) else path.name} "
           f"({what}) is missing: expected at {path}; a plain clone has no ../shared beside it")
    if os.environ.get("CI"):
        pytest.fail(f"{why} (CI is set: failing instead of skipping)", pytrace=False)
    pytest.skip(why)


def wait_until(predicate, timeout: float = 10.0, period: float = 0.02, what="condition"):
    """Poll ``predicate`` until it returns a truthy value and return that value; fail after
    ``timeout`` s, naming ``what`` (a string, or a callable giving one, called on failure)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(period)
    pytest.fail(f"{what() if callable(what) else what} not met within {timeout} s")


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    out = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30)
    if check and out.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {out.stderr.strip()}")
    return out


@contextmanager
def network_namespaces(*addresses: str, default_route: bool = False):
    """Two network namespaces made for a test, joined by a veth pair with the two IPv4
    ``addresses`` (``/24``) on its ends, ``lo`` up in each. Yields the namespaces' names and
    removes them afterwards. ``default_route``: a default route through the link in each (for
    programs that find their own address by routing toward the internet, as Ray does).

    Skips the calling test, saying why, where namespaces cannot be made (not Linux, no
    iproute2, no root or CAP_NET_ADMIN). Processes left inside are the caller's to stop
    (``namespace_pids``) before the namespaces go.
    """
    if len(addresses) != 2:
        raise ValueError("network_namespaces makes exactly two namespaces (a veth pair)")
    if not sys.platform.startswith("linux"):
        pytest.skip("network namespaces are Linux only")
    if shutil.which("ip") is None:
        pytest.skip("iproute2's `ip` is not installed (scripts/system-deps.sh installs iproute2)")
    tag = secrets.token_hex(3)
    names = [f"simx-{c}-{tag}" for c in "ab"]
    made = []
    try:
        out = _ip("netns", "add", names[0], check=False)
        if out.returncode != 0:
            pytest.skip(f"cannot create a network namespace (needs root or CAP_NET_ADMIN): "
                        f"`ip netns add` said: {out.stderr.strip()}")
        made.append(names[0])
        _ip("netns", "add", names[1])
        made.append(names[1])
        va, vb = f"sxa{tag}", f"sxb{tag}"
        # Made inside A and moved to B: nothing is ever added to the namespace the test runs in.
        _ip("-n", names[0], "link", "add", va, "type", "veth", "peer", "name", vb)
        _ip("-n", names[0], "link", "set", vb, "netns", names[1])
        for ns, dev, addr in zip(names, (va, vb), addresses):
            _ip("-n", ns, "addr", "add", f"{addr}/24", "dev", dev)
            _ip("-n", ns, "link", "set", "lo", "up")
            _ip("-n", ns, "link", "set", dev, "up")
            if default_route:
                _ip("-n", ns, "route", "add", "default", "dev", dev)
        yield tuple(names)
    finally:
        for ns in made:
            _ip("netns", "del", ns, check=False)


def namespace_pids(ns: str) -> list[int]:
    """The processes running in network namespace ``ns`` (``ip netns pids``)."""
    out = _ip("netns", "pids", ns, check=False)
    return [int(p) for p in out.stdout.split()] if out.returncode == 0 else []


@pytest.fixture
def official():
    """``official(port)``: a client of CoppeliaSim's official ZMQ client on ``port``, its socket
    and context closed when the test ends. A dropped client sits in a reference cycle with its
    socket and context; the garbage collector then finalizes the context first, and pyzmq's
    ``Context.__del__`` blocks in ``zmq_ctx_term`` on the still-open socket (a test worker hung
    so, in whatever test ran the collection)."""
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    made = []

    def make(port: int):
        made.append(RemoteAPIClient("127.0.0.1", port))
        return made[-1]

    yield make
    for client in made:
        client.socket.close(0)
        client.context.term()


#: Ports free_port() draws from: below the kernel's ephemeral range (32768-60999 by default), so
#: that no client connection's local port takes one between the check and the server's bind (a
#: server told --zmq-port had found its port taken by another worker's connection).
_TEST_PORTS = (20000, 32000)


def free_port() -> int:
    """A TCP port nothing listens on now (loopback), drawn at random from ``_TEST_PORTS``
    (``secrets``: a test's seeded ``random`` does not make two workers draw alike)."""
    lo, hi = _TEST_PORTS
    for _ in range(100):
        port = lo + secrets.randbelow(hi - lo)
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    with socket.socket() as s:  # (every draw taken: any port the kernel gives)
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def ready_line(proc: subprocess.Popen, timeout: float) -> str | None:
    """The first line of ``proc``'s stdout that says "ready" (stripped), or None when the process
    exits or ``timeout`` s pass first."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        r, _, _ = select.select([proc.stdout], [], [], 0.2)
        if r:
            line = proc.stdout.readline()
            if "ready" in line:
                return line.strip()
        if proc.poll() is not None:
            return None
    return None


def _fork_servers() -> bool:
    """Whether ServerProcess forks its servers (tests/server_fork.py): by default, where that
    module is beside this one (a copy of this file alone, as test_first_run.py makes, starts
    ``python -m simx_server.cli``); ``SIMX_TEST_FORK_SERVERS=0`` never."""
    return os.environ.get("SIMX_TEST_FORK_SERVERS", "1") != "0" and (Path(__file__).parent / "server_fork.py").is_file()


class ServerProcess:
    """A ``simx-server`` subprocess, ready when made; stopped by PID in :meth:`stop`.

    ``renderers``: the server's ``--renderers``. The default, ``"at-load"``, is what users get;
    the servers of tests that read no image say ``"on-demand"``: no GL context is made, which
    halves the CPU of a start (0.5 of 1.1 s; the suite starts more than a hundred servers).
    ``python_scripts``: the server runs the scenes' Python scripts (``--allow-python-scripts``;
    many test scenes have some); the tests of the refusal say False."""

    def __init__(self, *args: str, ports: list[int] | None = None, cwd: str | Path | None = None,
                 renderers: str = "at-load", python_scripts: bool = True):
        # The ZMQ remote API only where a test asks for it (--zmq-port): servers of parallel tests
        # must not compete for its default port.
        zmq = [] if any(a.split("=")[0] in ("--zmq-port", "--no-zmq") for a in args) else ["--no-zmq"]
        python = ["--allow-python-scripts"] if python_scripts and "--allow-python-scripts" not in args else []
        added = [*zmq, *python, "--renderers", renderers]  # after the test's own options
        env = dict(os.environ, MUJOCO_GL="egl", PYTHONUNBUFFERED="1")
        for attempt in range(3):
            # A port found free may be taken before the server binds it (another worker's client
            # or server): with ports of its own choosing, the server is started again on others.
            self.ports = ports or [free_port()]
            cmd = [sys.executable, "-m", "simx_server.cli", *args, *added]
            for p in self.ports:
                cmd += ["--port", str(p)]
            # The log goes to a file: a pipe nobody reads would fill up and block the server.
            self.log = tempfile.TemporaryFile(mode="w+")
            if _fork_servers():  # forked from a process that has imported the server (tests/server_fork.py)
                from server_fork import ForkedServer

                self.proc = ForkedServer(cmd[3:], env, cwd, self.log)
            else:
                self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=self.log, env=env, text=True,
                                             cwd=cwd)
            try:
                self.ready_line = self._wait_ready(timeout=60)
                return
            except RuntimeError as exc:
                if ports or attempt == 2 or "the port is already in use" not in str(exc):
                    raise

    @property
    def port(self) -> int:
        return self.ports[0]

    def _wait_ready(self, timeout: float) -> str:
        line = ready_line(self.proc, timeout)
        if line is not None:
            return line
        err = self.stop()
        raise RuntimeError(f"simx-server did not become ready:\n{err}")

    def log_so_far(self) -> str:
        """The server's log (stderr) while it runs, read through a file description of its own
        (reading through ``self.log`` would move the server's write offset)."""
        with open(f"/proc/{self.proc.pid}/fd/2") as f:
            return f.read()

    def thread_dump(self, timeout: float = 5.0) -> str:
        """The server's log once it has written every thread's stack (SIGUSR1: simx-server's
        faulthandler), for a test whose server stopped answering; what the log holds after
        ``timeout`` s without the dump, or a line saying the server had exited."""
        if self.proc.poll() is not None:
            return f"(the server had exited, status {self.proc.returncode})"
        self.proc.send_signal(signal.SIGUSR1)
        deadline = time.monotonic() + timeout
        text = self.log_so_far()
        while "most recent call first" not in text and time.monotonic() < deadline:
            time.sleep(0.05)
            text = self.log_so_far()
        return text

    def stop(self, timeout: float = 10.0) -> str:
        """SIGTERM, wait, SIGKILL if needed; returns the server's log (stderr)."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.seek(0)
        return self.log.read()


@pytest.fixture(scope="module")
def server():
    """One real server on the bundled scene for a test module, on two free ports. It answers
    blocking calls at once (``--pacing immediate``): the modules that use it test the API's
    semantics, and legacy pacing (the default, one step per blocking call) would make each of
    their calls wait up to 50 ms; tests/transport/test_pacing.py, the legacy programs' end-to-end tests
    and the VPG-style program run servers with the default. Its renderers are made on demand: most
    of the modules that use it read no image (the renderers made at load, 0.25 s of CPU, went
    unused), the others make them at their first image; tests/transport/test_first_frame.py
    tests the renderers made at load."""
    srv = ServerProcess(str(SCENE), "--pacing", "immediate", ports=[free_port(), free_port()], renderers="on-demand")
    yield srv
    srv.stop()


@pytest.fixture
def vrep_client(server):
    """A connected legacy client id (``import vrep``), finished after the test."""
    import vrep

    cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
    assert cid >= 0, "could not connect to the test server"
    yield cid
    vrep.simxFinish(cid)


# The ``pyrep`` tests (tests/pyrep): a small MJCF scene written per test, launched in process.
PYREP_SCENE = """<mujoco model="pyrep_small">
  <compiler angle="radian"/>
  <option timestep="0.01"/>
  <worldbody>
    <light name="light" pos="0 0 3" dir="0 0 -1"/>
    <geom name="floor" type="plane" size="2 2 0.05" rgba="0.8 0.8 0.8 1"/>
    <body name="cube" pos="0.5 0 0.3">
      <freejoint/>
      <geom name="cube_geom" type="box" size="0.05 0.05 0.05" mass="0.5" rgba="1 0 0 1"/>
    </body>
    <body name="base" pos="-0.5 0 0.1">
      <geom type="cylinder" size="0.05 0.05" rgba="0 0 1 1"/>
      <body name="link" pos="0 0 0.1">
        <joint name="hinge" type="hinge" axis="0 0 1" range="-2 2"/>
        <geom type="box" size="0.2 0.02 0.02" pos="0.2 0 0" mass="0.2"/>
        <site name="tip" pos="0.4 0 0"/>
      </body>
    </body>
    <site name="prox" pos="0.5 0 1.0" quat="0 1 0 0"/>
    <camera name="cam" pos="0 -1.5 0.8" xyaxes="1 0 0 0 0.5 1" resolution="32 24"/>
  </worldbody>
  <sensor>
    <rangefinder site="prox" cutoff="2"/>
  </sensor>
  <actuator>
    <velocity name="hinge_motor" joint="hinge" kv="2"/>
  </actuator>
</mujoco>
"""


@pytest.fixture
def pyrep_scene(tmp_path: Path) -> Path:
    """The small MJCF scene of the ``pyrep`` tests (tests/pyrep), written per test."""
    path = tmp_path / "small.xml"
    path.write_text(PYREP_SCENE)
    return path


@pytest.fixture
def pr(pyrep_scene: Path):
    """A launched and started PyRep on the small scene; shut down after the test."""
    from pyrep import PyRep

    instance = PyRep()
    instance.launch(str(pyrep_scene), headless=True)
    instance.start()
    yield instance
    instance.shutdown()
