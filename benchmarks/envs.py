"""Issue 13 part 5: Gymnasium env steps per second, remote against in-process.

* **remote**: ``simx/UR5BallReach-v0`` (simx_client.envs.ur5_ball_reach.UR5BallReachEnv) on
  simx-server subprocesses started ``--stopped`` (default legacy pacing; the env's reset turns
  synchronous mode on and starts it), one server per env on its own free loopback port:
  1 env stepped directly, 2 and 4 envs through ``gymnasium.vector.AsyncVectorEnv`` (one worker
  process per env), and 1 env through a 1-env AsyncVectorEnv (the vector wrapper's own cost).
  Observations 84x84 (the sensors set to 112x84 after each start, resized client-side with
  INTER_AREA) and 640x480 (the sensors' own size). Images arrive as lazy lists
  (``simx_client.images.set_lazy_image_lists``: the env only makes arrays of them).
* **floor, same run**: :class:`InProcessReach`, the same env logic on MuJoCo directly in this
  process: ``simx_server.scene.simulation.Simulation(scene)`` and its ``VisionSensors`` (same scene,
  same renderer on its render thread, the same render size (112x84 or 640x480), dt 50 ms), the same targets through
  ``sim.world.set_joint_target_position``, the same ``sim_steps`` steps per env step, the same
  renders per step (RGB + depth), the same flip/resize/metres conversion, the same joint and
  position reads; minus the transport (and minus the legacy list the remote API returns).

Every case: random actions (seeded), a reset and warm-up steps untimed, then ``steps`` timed
env steps (vector: ``steps`` vector steps of n envs). Figures: the median step time, and
throughput = env steps / wall time of the timed loop. Ratios: in-process / remote for 1 env
(the target: remote within 1.5x, i.e. ratio of step times <= 1.5), n envs / 1 env throughput
(target for 4: >= 1.6x).
"""

from __future__ import annotations

import time

import cv2
import numpy as np

from benchmarks.common import Settings, loadavg, perf
from benchmarks.procs import SCENE, Server
from benchmarks.stats import Figure, Target, summary

TUTORIAL_POSE_DEG = (90.0, -45.0, 90.0, 0.0, -100.0, 0.0)
SIZES = ((84, 84), (640, 480))


class InProcessReach:
    """UR5BallReach's reset/step/observe on an in-process Simulation (no transport)."""

    def __init__(self, width: int, height: int, joints: int = 3, max_offset_deg: float = 5.0,
                 sim_steps: int = 1, settle_steps: int = 2, seed: int = 0):
        from simx_client.envs.ur5_ball_reach import BALL_X, BALL_Y, BALL_Z, JOINT_NAMES
        from simx_server.scene.simulation import Simulation

        self.sim = Simulation(str(SCENE), realtime=False)
        self.sim.vision.wait_ready(60)
        w = self.sim.world
        self.width, self.height, self.n_joints = width, height, joints
        self.max_offset_deg, self.sim_steps, self.settle_steps = max_offset_deg, sim_steps, settle_steps
        self.joints = [w.resolve(n).handle for n in JOINT_NAMES]
        self.rgb_h, self.dep_h = w.resolve("kinect_rgb").handle, w.resolve("kinect_depth").handle
        self.ball, self.tcp = w.resolve("Sphere").handle, w.resolve("RG2_tcp").handle
        spec = self.sim.vision.spec(self.dep_h)
        self.near, self.far = spec.near, spec.far
        from simx_client.envs.ur5_ball_reach import render_size
        self.render_size = render_size((spec.width, spec.height), (width, height), None)
        self.rng = np.random.default_rng(seed)
        self.ball_box = (BALL_X, BALL_Y, BALL_Z)
        self.targets = np.radians(np.array(TUTORIAL_POSE_DEG))

    def _resize(self, img):
        if img.shape[0] == self.height and img.shape[1] == self.width:
            return img
        return cv2.resize(img, (self.width, self.height), interpolation=cv2.INTER_AREA)

    def _observe(self):
        v, w = self.sim.vision, self.sim.world
        (rw, rh), raw = v.image_bytes(self.rgb_h, 0)
        rgb = np.ascontiguousarray(self._resize(np.frombuffer(raw, np.uint8).reshape(rh, rw, 3)[::-1]))
        (dw, dh), buf = v.depth_bytes(self.dep_h)
        d = np.frombuffer(buf, np.float32).reshape(dh, dw)[::-1]
        metres = np.clip(np.float32(self.near) + d * np.float32(self.far - self.near),
                         np.float32(self.near), np.float32(self.far))
        depth = self._resize(np.ascontiguousarray(metres))
        q = np.array([w.joint_position(h) for h in self.joints], dtype=np.float32)
        ball, tcp = np.array(w.position(self.ball, -1)), np.array(w.position(self.tcp, -1))
        return {"rgb": rgb, "depth": depth, "joints": q}, -float(np.linalg.norm(ball - tcp))

    def reset(self):
        sim, w = self.sim, self.sim.world
        sim.stop()
        sim.vision.wait_ready(60)
        sim.start()
        for sensor in (self.rgb_h, self.dep_h):  # as the env: the render size after each start
            sim.vision.set_resolution(sensor, *self.render_size)
        self.targets = np.radians(np.array(TUTORIAL_POSE_DEG))
        (x0, x1), (y0, y1), z = self.ball_box
        for h, t in zip(self.joints, self.targets):
            w.set_joint_position(h, float(t))
            w.set_joint_target_position(h, float(t))
        w.set_pose(self.ball, -1, position=[float(self.rng.uniform(x0, x1)), float(self.rng.uniform(y0, y1)), z])
        for _ in range(self.settle_steps):
            sim.step()
        return self._observe()[0]

    def step(self, action):
        offsets = np.clip(np.asarray(action, dtype=np.float64).reshape(self.n_joints),
                          -self.max_offset_deg, self.max_offset_deg)
        self.targets[: self.n_joints] += np.radians(offsets)
        w = self.sim.world
        for h, t in zip(self.joints[: self.n_joints], self.targets[: self.n_joints]):
            w.set_joint_target_position(h, float(t))
        for _ in range(self.sim_steps):
            self.sim.step()
        return self._observe()

    def close(self):
        self.sim.close()


def _timed_loop(step, sample, steps: int, warmup: int, budget_s: float) -> tuple[list[float], float]:
    for _ in range(warmup):
        step(sample())
    times = []
    deadline = time.monotonic() + budget_s
    t_start = perf()
    for _ in range(steps):
        a = sample()
        t0 = perf()
        step(a)
        times.append(perf() - t0)
        if time.monotonic() > deadline:
            break
    return times, perf() - t_start


def _in_process(width: int, height: int, steps: int, warmup: int, budget: float):
    env = InProcessReach(width, height)
    rng = np.random.default_rng(1)
    try:
        env.reset()
        return _timed_loop(env.step, lambda: rng.uniform(-5, 5, 3), steps, warmup, budget)
    finally:
        env.close()


def _remote(s: Settings, n: int, vector: bool, width: int, height: int, steps: int, warmup: int,
            budget: float):
    import gymnasium as gym

    from simx_client.envs.ur5_ball_reach import UR5BallReachEnv

    servers = []
    try:
        for i in range(n):
            servers.append(Server(s.log_dir, "--stopped", name=f"env{n}{'v' if vector else ''}-{width}-{i}"))
        ports = [srv.port for srv in servers]
        if vector:
            env = gym.vector.AsyncVectorEnv(
                [lambda p=p: UR5BallReachEnv(port=p, width=width, height=height) for p in ports],
                context="spawn")  # fork would copy this process's Zenoh and GL threads: a hang
        else:
            env = UR5BallReachEnv(port=ports[0], width=width, height=height)
        try:
            env.reset(seed=0)
            env.action_space.seed(1)
            return _timed_loop(env.step, env.action_space.sample, steps, warmup, budget)
        finally:
            env.close()
    finally:
        for srv in servers:
            srv.stop()


def run(s: Settings) -> list[Figure]:
    steps, warmup, budget = s.n(100, 20), s.n(5, 2), s.t(60.0, 20.0)
    figures: list[Figure] = []
    combos = ((1, False), (1, True), (2, True), (4, True))
    for width, height in s.pick(SIZES, SIZES, smoke=SIZES[:1]):
        size = f"{width}x{height}"
        load0 = loadavg()
        inproc, inproc_wall = _in_process(width, height, steps, warmup, budget)
        cases = {}
        for n, vector in s.pick(combos, combos, smoke=((1, False), (1, True))):
            t, wall = _remote(s, n, vector, width, height, steps, warmup, budget)
            cases[(n, vector)] = (t, wall)
        load1 = loadavg()
        ms = lambda t: {k: v * 1e3 for k, v in summary(t).items()}  # noqa: E731
        inproc_ms, rate_in = ms(inproc), len(inproc) / inproc_wall
        one_ms = ms(cases[(1, False)][0])
        floor_in = {"label": "in-process env step", "median": inproc_ms["median"],
                    "p10": inproc_ms["p10"], "p90": inproc_ms["p90"]}
        extra_load = {"loadavg_before": load0, "loadavg_after": load1}
        figures.append(Figure(f"envs.inproc.{size}", f"in-process env step (floor), {size}", "ms", inproc_ms,
                              extra={"steps_per_s": rate_in, **extra_load},
                              note=f"{size}: in-process {rate_in:.1f} steps/s"))
        rate_one = len(cases[(1, False)][0]) / cases[(1, False)][1]
        figures.append(Figure(f"envs.remote1.{size}", f"remote env step, 1 env, {size}", "ms", one_ms,
                              floor=floor_in, target=Target("ratio", "<=", 1.5, "<= 1.5x in-process"),
                              extra={"steps_per_s": rate_one, "inprocess_steps_per_s": rate_in,
                                     "throughput_ratio_remote_over_inprocess": rate_one / rate_in}))
        rates = {}
        for (n, vector), (t, wall) in cases.items():
            rates[(n, vector)] = n * len(t) / wall
        for (n, vector), rate in rates.items():
            label = f"env steps/s, {n} env{'s' if n > 1 else ''}{' (AsyncVectorEnv)' if vector else ''}, {size}"
            per = [n / x for x in cases[(n, vector)][0]]  # env steps/s of each (vector) step
            st = summary(per)
            target = None
            if n == 4:
                target = Target("ratio", ">=", 1.6, ">= 1.6x one env")
            floor = None if (n, vector) == (1, False) else {
                "label": "1 env (direct) steps/s", "median": summary([1 / x for x in cases[(1, False)][0]])["median"]}
            figures.append(Figure(f"envs.rate{n}{'v' if vector else ''}.{size}", label, "1/s", st, floor=floor,
                                  target=target,
                                  extra={"throughput_wall": rate, "throughput_wall_over_1env": rate / rate_one,
                                         "steps": len(cases[(n, vector)][0])},
                                  note=f"{size}: {n} env{'s' if n > 1 else ''}{' vec' if vector else ''}: "
                                       f"{rate:.1f} env steps/s over the loop ({rate / rate_one:.2f}x 1 env)"))
        figures.append(Figure(f"envs.inproc_rate.{size}", f"  in-process env steps/s, {size}", "1/s",
                              summary([1 / x for x in inproc])))
    return figures
