"""Issue 21: env steps/s of RLlib training on simx, one node against two, against make_vec.

    MUJOCO_GL=egl nice -n 19 python -m benchmarks.rllib [--iterations 5] [--batch 400]

Three cases, each with 2 environments (= 2 simx-servers), 84x84 renders and the tutorial state
(``tutorial_state=True``: one more colour-coded render per step), episodes of 100 steps:

* **make_vec** (the floor): ``gymnasium.make_vec(..., num_envs=2, vectorization_mode="async")``
  on a ``ServerPool(2)``, random actions: env steps / wall time of ``--steps`` vector steps.
* **rllib, 1 node**: ``examples/train_rllib.py`` on a local Ray (``ray.init()``), PPO, 2 env
  runners with 1 environment each (each starts its own server: ``servers="local"``).
* **rllib, 2 nodes**: the same on a Ray cluster of two nodes made in two network namespaces of
  this machine (a head and a worker, 1 CPU each, one env runner on each), the driver on the head.
  Needs root for the namespaces (skipped otherwise).

RLlib figures: env steps per second of training wall time (sampling and PPO's update, one
after the other, as RLlib runs them), the median over iterations 2..N (the first pays for
warm-up); and the same over the sampling time alone (RLlib's ``env_runner_sampling_timer``).
On a 2-core machine every case shares the same 2 cores: the two "nodes" are namespaces of one
machine, so the 2-node figure shows Ray's cost across a (virtual) network, not more cores, and
the ratio to make_vec is Ray's and RLlib's overhead (actors, policy inference in the runners,
the learner), not what a real cluster of separate machines would gain.
"""

from __future__ import annotations

import argparse
import json
import os
import secrets
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "train_rllib.py"
ENV = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), PYTHONUNBUFFERED="1",
           RAY_USAGE_STATS_ENABLED="0")
ADDR_A, ADDR_B, GCS_PORT = "198.51.100.1", "198.51.100.2", 6379


def make_vec_floor(steps: int) -> dict:
    import gymnasium

    import simx_client.envs  # noqa: F401
    from simx_server.pool import ServerPool

    pool = ServerPool(2, None, "--speed", "0")
    envs = pool.close_with(gymnasium.make_vec(
        simx_client.envs.ENV_ID, num_envs=2, vectorization_mode="async", vector_kwargs={"context": "spawn"},
        servers=pool.claims, width=84, height=84, tutorial_state=True, max_episode_steps=100))
    try:
        envs.reset(seed=0)
        envs.action_space.seed(0)
        for _ in range(20):
            envs.step(envs.action_space.sample())
        t0 = time.perf_counter()
        for _ in range(steps):
            envs.step(envs.action_space.sample())
        wall = time.perf_counter() - t0
    finally:
        envs.close()
    return {"case": "make_vec, 2 envs (async)", "env_steps": 2 * steps, "wall_s": round(wall, 2),
            "env_steps_per_s": round(2 * steps / wall, 1)}


def _rllib_figures(case: str, result: dict) -> dict:
    its = result["iterations"]
    rates, sample_rates = [], []
    for prev, cur in zip(its, its[1:]):
        steps = cur["env_steps"] - prev["env_steps"]
        rates.append(steps / (cur["wall_s"] - prev["wall_s"]))
        if cur.get("sample_s"):
            sample_rates.append(steps / cur["sample_s"])
    return {"case": case, "nodes": result["nodes"], "iterations": len(its), "env_steps": its[-1]["env_steps"],
            "env_steps_per_s": round(statistics.median(rates), 1) if rates else None,
            "sampling_env_steps_per_s": round(statistics.median(sample_rates), 1) if sample_rates else None,
            "per_iteration": its}


def _example(prefix: list[str], args: argparse.Namespace, out: Path, env: dict, address: str | None) -> dict:
    cmd = [*prefix, sys.executable, str(EXAMPLE), "--env-runners", "2", "--iterations", str(args.iterations),
           "--batch", str(args.batch), "--json", str(out)] + (["--address", address] if address else [])
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=env, cwd=ROOT)
    if run.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{run.stdout[-2000:]}\n{run.stderr[-4000:]}")
    return json.loads(out.read_text())


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=30)


def _pids(ns: str) -> list[int]:
    out = subprocess.run(["ip", "netns", "pids", ns], capture_output=True, text=True, timeout=30)
    return [int(p) for p in out.stdout.split()]


def two_nodes(args: argparse.Namespace, tmp: Path) -> dict:
    """The two-namespace Ray cluster of tests/e2e/test_ray_cluster.py, and the example on it."""
    tag = secrets.token_hex(3)
    a, b = f"simx-a-{tag}", f"simx-b-{tag}"
    made, procs = [], []
    token = tmp / "auth_token"
    token.write_text(secrets.token_hex(32))
    env = dict(ENV, RAY_AUTH_MODE="token", RAY_AUTH_TOKEN_PATH=str(token))
    node = ["--num-cpus", "1", "--num-gpus", "0", "--object-store-memory", str(100 * 2**20),
            "--disable-usage-stats", "--block"]
    ray = str(Path(sys.executable).with_name("ray"))
    try:
        for ns in (a, b):
            _ip("netns", "add", ns)
            made.append(ns)
        _ip("-n", a, "link", "add", f"sxa{tag}", "type", "veth", "peer", "name", f"sxb{tag}")
        _ip("-n", a, "link", "set", f"sxb{tag}", "netns", b)
        for ns, dev, addr in ((a, f"sxa{tag}", ADDR_A), (b, f"sxb{tag}", ADDR_B)):
            _ip("-n", ns, "addr", "add", f"{addr}/24", "dev", dev)
            for link in ("lo", dev):
                _ip("-n", ns, "link", "set", link, "up")
            _ip("-n", ns, "route", "add", "default", "dev", dev)
        for ns, name, extra in ((a, "head", ["--head", "--node-ip-address", ADDR_A, "--port", str(GCS_PORT),
                                             "--include-dashboard", "false"]),
                                (b, "worker", ["--address", f"{ADDR_A}:{GCS_PORT}", "--node-ip-address", ADDR_B])):
            with open(tmp / f"{name}.log", "wb") as log:
                procs.append(subprocess.Popen(["ip", "netns", "exec", ns, ray, "start", *extra, *node,
                                               "--temp-dir", str(tmp / name)], stdout=log,
                                              stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, env=env))
        deadline = time.monotonic() + 180
        while not all("Ray runtime started" in (tmp / f"{n}.log").read_text(errors="replace")
                      for n in ("head", "worker")):
            if time.monotonic() > deadline or any(p.poll() is not None for p in procs):
                raise RuntimeError("the two Ray nodes did not start: see " + str(tmp))
            time.sleep(0.2)
        result = _example(["ip", "netns", "exec", a], args, tmp / "two.json", env, f"{ADDR_A}:{GCS_PORT}")
        return _rllib_figures("rllib PPO, 2 nodes x 1 env runner", result)
    finally:
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for p in procs:
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                p.kill()
        for ns in made:  # everything left in our namespaces was started here
            for sig in (signal.SIGTERM, signal.SIGKILL):
                for pid in _pids(ns):
                    try:
                        os.kill(pid, sig)
                    except ProcessLookupError:
                        pass
                deadline = time.monotonic() + 10
                while _pids(ns) and time.monotonic() < deadline:
                    time.sleep(0.1)
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=5, help="PPO iterations per RLlib case")
    parser.add_argument("--batch", type=int, default=400, help="env steps per PPO iteration (2 runners)")
    parser.add_argument("--steps", type=int, default=200, help="timed vector steps of the make_vec floor")
    parser.add_argument("--json", default=str(ROOT / "benchmarks" / "results" / "rllib.json"))
    args = parser.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="sxb-"))
    rows = []
    load = [os.getloadavg()[0]]
    try:
        rows.append(make_vec_floor(args.steps))
        load.append(os.getloadavg()[0])
        rows.append(_rllib_figures("rllib PPO, 1 node x 2 env runners",
                                   _example([], args, tmp / "one.json", ENV, None)))
        load.append(os.getloadavg()[0])
        if shutil.which("ip") and os.geteuid() == 0:
            rows.append(two_nodes(args, tmp))
        else:
            rows.append({"case": "rllib PPO, 2 nodes", "skipped": "needs root and iproute2 for network namespaces"})
        load.append(os.getloadavg()[0])
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    floor = rows[0]["env_steps_per_s"]
    for r in rows:
        if r.get("env_steps_per_s"):
            r["ratio_to_make_vec"] = round(r["env_steps_per_s"] / floor, 2)
    meta = {"cpus": os.cpu_count(), "loadavg_1min_before_and_after_each": [round(x, 1) for x in load],
            "iterations": args.iterations, "batch": args.batch}
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps({"meta": meta, "rows": rows}, indent=2) + "\n")
    print(f"{'case':40s} {'env steps/s':>12s} {'sampling only':>14s} {'vs make_vec':>12s}")
    for r in rows:
        print(f"{r['case']:40s} {r.get('env_steps_per_s') or '-':>12} {r.get('sampling_env_steps_per_s') or '-':>14} "
              f"{r.get('ratio_to_make_vec') or r.get('skipped', '-'):>12}")
    print(json.dumps(meta))


if __name__ == "__main__":
    main()
