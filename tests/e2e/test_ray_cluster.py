"""simx on a real two-node Ray cluster: RLlib's PPO with one env runner per node, each runner's
environment on a simx-server of its own node.

The two nodes are two network namespaces of this machine joined by a veth pair (198.51.100.1 and
198.51.100.2, TEST-NET-2): a Ray head (`ray start --head`) in A, a worker node (`ray start
--address`) in B, each with one CPU, so the two env runners (one CPU each) land one on each node.
The driver (examples/train_rllib.py) runs in A. Every environment starts its own simx-server
(``servers="local"``) where its runner runs: the test checks that the steps were taken by servers
living in both namespaces, and that no server is left once the training stopped.

Needs the ``ray`` extra (skipped without it) and root for the namespaces (skipped saying why
otherwise). About 40-60 s on 2 cores: two Ray nodes, two env runners importing torch, and two
PPO iterations of 100 steps.
"""

from __future__ import annotations

import importlib.util
import json
import os
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from conftest import ROOT, namespace_pids, network_namespaces, wait_until

# find_spec, not an import: importing Ray takes seconds, and the test runs it in subprocesses only.
for _module in ("ray", "torch", "pandas"):  # pandas: one of what ray[rllib] adds to ray
    if importlib.util.find_spec(_module) is None:
        pytest.skip(f"needs the ray extra (no {_module}): scripts/install-train.sh ray", allow_module_level=True)

pytestmark = pytest.mark.ray

ADDR_A, ADDR_B = "198.51.100.1", "198.51.100.2"
GCS_PORT = 6379  # inside namespace A only
RAY = str(Path(sys.executable).with_name("ray"))
# RAY_worker_niceness=0: Ray runs its workers at nice 15 by default, and the simx-server an env
# runner starts inherits it; beside the suite's other workers (nice 0, load about 10 on 2 cores)
# such a server got about 1/30 of their CPU share: its first render's GL context or a step took
# over 20 s, or its Zenoh session lost its lease, and the runner failed.
ENV = dict(os.environ, MUJOCO_GL="egl", PYTHONUNBUFFERED="1", RAY_USAGE_STATS_ENABLED="0", RAY_worker_niceness="0")
STARTED = "Ray runtime started"
NODE = ["--num-cpus", "1", "--num-gpus", "0", "--object-store-memory", str(100 * 2**20),
        "--disable-usage-stats", "--block"]


def _ray_start(ns: str, env: dict, temp_dir: str, log: Path, *args: str) -> subprocess.Popen:
    with open(log, "wb") as f:
        return subprocess.Popen(["ip", "netns", "exec", ns, RAY, "start", *args, *NODE, "--temp-dir", temp_dir],
                                stdin=subprocess.DEVNULL, stdout=f, stderr=subprocess.STDOUT, env=env, cwd=ROOT)


def _stop_namespace(ns: str, procs: list[subprocess.Popen]) -> None:
    """SIGTERM to our `ray start` processes, then to everything still running in the namespace
    (Ray's daemons, workers, servers: all started by this test), SIGKILL what outlives 15 s."""
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
    for sig in (signal.SIGTERM, signal.SIGKILL):
        for pid in namespace_pids(ns):
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        deadline = time.monotonic() + 15
        while namespace_pids(ns) and time.monotonic() < deadline:
            time.sleep(0.1)


def _worker_errors(tmp: str) -> str:
    """The tracebacks in the Ray workers' stderr files of both nodes (a runner that died says why)."""
    out = []
    for err in sorted(Path(tmp).glob("*/session_*/logs/worker-*.err")):
        text = err.read_text(errors="replace")
        if "Traceback" in text or "Error" in text:
            out.append(f"--- {err.relative_to(tmp)}:\n{text[-3000:]}")
    return "\n".join(out)


@pytest.fixture
def ray_cluster():
    """A Ray head in namespace A and a worker node in B, with token authentication (a token of
    the test's own, as a cluster's nodes share one); yields (A, B, temp folder, environment)."""
    with network_namespaces(ADDR_A, ADDR_B, default_route=True) as (a, b):
        tmp = tempfile.mkdtemp(prefix="sxr-")  # short: Ray's socket paths live under it
        token = Path(tmp, "auth_token")
        token.write_text(secrets.token_hex(32))
        env = dict(ENV, RAY_AUTH_MODE="token", RAY_AUTH_TOKEN_PATH=str(token))
        head = worker = None
        try:
            head = _ray_start(a, env, f"{tmp}/a", Path(tmp, "head.log"), "--head", "--node-ip-address", ADDR_A,
                              "--port", str(GCS_PORT), "--include-dashboard", "false")
            worker = _ray_start(b, env, f"{tmp}/b", Path(tmp, "worker.log"), "--address", f"{ADDR_A}:{GCS_PORT}",
                                "--node-ip-address", ADDR_B)

            def logs() -> str:
                return "\n".join(f"--- {n}:\n{Path(tmp, n).read_text(errors='replace')[-3000:]}"
                                  for n in ("head.log", "worker.log") if Path(tmp, n).exists())

            # `ray start` says so once its node runs (a worker node: once it joined the head).
            wait_until(lambda: head.poll() is not None or worker.poll() is not None or all(
                STARTED in Path(tmp, n).read_text(errors="replace") for n in ("head.log", "worker.log")),
                timeout=120, period=0.2, what=lambda: "both Ray nodes started\n" + logs())
            assert head.poll() is None and worker.poll() is None, logs()
            yield a, b, tmp, env
        finally:
            _stop_namespace(b, [worker] if worker else [])
            _stop_namespace(a, [head] if head else [])
            shutil.rmtree(tmp, ignore_errors=True)


def test_ppo_env_runners_step_servers_on_their_own_nodes(ray_cluster):
    a, b, tmp, env = ray_cluster
    out = Path(tmp, "result.json")
    run = subprocess.run(
        ["ip", "netns", "exec", a, sys.executable, str(ROOT / "examples" / "train_rllib.py"),
         "--address", f"{ADDR_A}:{GCS_PORT}", "--env-runners", "2", "--iterations", "2", "--batch", "100",
         "--episode-steps", "25", "--json", str(out)],
        capture_output=True, text=True, timeout=300, env=env, cwd=ROOT)
    print(run.stdout)  # per iteration: env steps, wall time; per runner: node and server
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-6000:] + _worker_errors(tmp)
    result = json.loads(out.read_text())

    assert [it["iteration"] for it in result["iterations"]] == [1, 2]
    assert result["iterations"][-1]["env_steps"] >= 200  # two iterations of 100 env steps
    assert result["nodes"] == [ADDR_A, ADDR_B], _worker_errors(tmp)  # one runner per node
    netns = {ns: f"net:[{os.stat(f'/run/netns/{ns}').st_ino}]" for ns in (a, b)}
    steps_by_namespace = {}
    for runner in result["env_runners"]:
        assert len(runner) == 1  # one environment per runner
        (env,) = runner
        assert env["host"] == "127.0.0.1" and env["server_pid"] is not None
        # the runner and its server compete for the CPUs as the other processes do (ENV)
        assert env["env_nice"] <= os.getpriority(os.PRIO_PROCESS, 0) and env["server_nice"] == env["env_nice"], env
        # the server is a process of the runner's own node (namespace), reached on its loopback
        expected = netns[a] if env["node_ip"] == ADDR_A else netns[b]
        assert env["server_netns"] == expected, env
        steps_by_namespace[env["server_netns"]] = env["steps"]
    assert set(steps_by_namespace) == set(netns.values())
    assert all(steps > 0 for steps in steps_by_namespace.values()), steps_by_namespace
    # algo.stop() closed the environments: their servers are gone, the Ray nodes still run.
    server_pids = {env["server_pid"] for runner in result["env_runners"] for env in runner}
    wait_until(lambda: not server_pids & set(namespace_pids(a) + namespace_pids(b)), timeout=30,
               what="the env runners' simx-servers to stop")
