"""``simx/UR5BallReach-v0``: the UR5 + RG2 + Kinect tutorial scene as a Gymnasium environment.

Pure client side: only legacy ``simx*`` calls, so it runs against simx-server or a V-REP with
the tutorial's scene. Objects used: ``UR5_joint1``..``UR5_joint6``, ``kinect_rgb``,
``kinect_depth``, the ball ``Sphere`` and the gripper's tool-centre dummy ``RG2_tcp``.

* ``reset(seed=...)``: stops the simulation (the scene goes back to its initial state; it waits
  for the server state to say stopped, as V-REP stops a few passes after the request), turns
  synchronous mode on, starts it, puts the arm at the tutorial pose [90, -45, 90, 0, -100, 0]
  deg (plus uniform noise of ``pose_noise_deg``, seeded) and the ball at a seeded random place
  on the table inside the Kinect's view at that pose (:data:`BALL_X`, :data:`BALL_Y`), then
  runs ``settle_steps`` simulation steps.
* ``step(action)``: joint offsets in degrees, clipped to ``[-max_offset_deg, max_offset_deg]``
  (the tutorial moves a joint by a fixed number of degrees per key) and added to the joints'
  target positions (as the tutorial's ``rotateCertainAngle*``); joints 1-3 by default,
  ``joints=6`` for all six. The targets go in one ``simxPauseCommunication`` batch, then
  ``sim_steps`` simulation steps (``simxSynchronousTrigger`` + ``simxGetPingTime``).
* observation: ``{"rgb": (H, W, 3) uint8, rows top-down, "depth": (H, W) float32 metres from
  the sensor plane (near + buffer x (far - near), near/far read from ``kinect_depth``'s float
  parameters 1000/1001), "joints": (6,) float32 radians}``. The sensors render at
  ``sensor_resolution``: by default (None) the smallest size of the scene sensor's own aspect
  ratio (640x480: 4:3) that covers ``width`` x ``height`` (84x84 -> 112x84), set after each
  start through the resolution parameters 1002/1003 as V-REP allowed; ``"native"`` keeps the
  scene's (640x480); or an explicit ``(w, h)``. The frame is then resized client-side to
  ``width`` x ``height`` with OpenCV's ``INTER_AREA`` (the same view, squeezed to the
  observation's shape). A server that refuses the resolution change gives its own size, resized
  the same way.
* ``tutorial_state=True`` adds ``"state"``: the tutorial's 2 numbers, (2,) float32: the
  distance in pixels from the ball's centre to the image centre, in the scene sensor's own
  pixels (640x480, as the tutorial's YOLO boxes were; the centroid found at the render size is
  scaled to them), and the depth in metres at that pixel. The tutorial took them from a YOLO
  box; here the ball's pixels come from the sensor's colour-coded-handle render (render mode 2,
  ``sim_visionintparam_render_mode`` 1017: handle = r + 256 g + 65536 b), one more render per
  step. When no ball pixel is seen: half the image diagonal and the far clipping distance, and
  ``info["ball_visible"]`` is False. With it comes ``"ball_offset"``, (2,) float32: the same
  centre's signed offset from the image centre (x to the right, y down, the same pixels; 0, 0
  when the ball is not seen), the direction the 2 numbers leave out (the tutorial's YOLO box had
  it): a policy that sees only the distance cannot tell on which side the ball is
  (examples/train_ddpg.py gives DDPG both).
* reward: ``"dense"`` (default) is minus the distance (m) between ``RG2_tcp`` and the ball's
  centre; ``"image"`` is minus the distance of the red ball's centroid from the image centre,
  in half-diagonals (0 at the centre, about -1 at a corner), and -1 when no ball pixel is seen
  (the tutorial's version divides by the pixel count, which fails then).
* ``servers=pool.claims`` (:class:`simx_server.pool.ServerPool`): the environment claims a server
  of its own instead of ``host``/``port`` (``gymnasium.make_vec`` makes every environment with
  the same arguments) and gives it back on ``close()``.
* ``servers="local"``: the environment starts a simx-server of its own on this machine
  (``ServerPool(1, None, "--speed", "0")`` on 127.0.0.1, a free port) and stops it on
  ``close()``; the server also stops when the thread that made the environment ends, the
  process killed included (the pool's ``PR_SET_PDEATHSIG``). A pool spec, ``{"scene": path,
  "args": [...]}`` (both optional; ``args`` replaces ``["--speed", "0"]``), does the same with
  that scene and those ``simx-server`` arguments. Made for frameworks whose workers build their
  environments on whatever machine they run on (Ray RLlib's env runners): the server is always
  on the environment's own machine and is never reached from another. It needs the server side
  (MuJoCo) installed there. ``env.local_servers`` is that pool (None otherwise).
* ``terminated`` when ``RG2_tcp`` is within ``success_distance`` (default 0.05 m) of the
  ball's centre; ``truncated`` after ``max_episode_steps`` steps (default 200).
"""

from __future__ import annotations

import math
import os
import signal
import time
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
from gymnasium import spaces

import simx_client as vrep
from simx_client.images import decode_handles
from simx_client.servers import local_pool

TUTORIAL_POSE_DEG = (90.0, -45.0, 90.0, 0.0, -100.0, 0.0)
JOINT_NAMES = tuple(f"UR5_joint{i}" for i in range(1, 7))
#: where reset puts the ball (world x and y, m): on the table (top at z = 0.75 m) and, with the
#: arm at the tutorial pose, fully inside kinect_rgb's 640x480 view with a margin (measured).
BALL_X = (-0.15, 0.30)
BALL_Y = (0.60, 0.95)
BALL_Z = 0.78  # table top + the ball's radius (0.03 m)
SUCCESS_DISTANCE = 0.05  # m, RG2_tcp to the ball's centre

_B = vrep.simx_opmode_blocking
_ONESHOT = vrep.simx_opmode_oneshot
_STREAMING = vrep.simx_opmode_streaming
_BUFFER = vrep.simx_opmode_buffer
_SHARED: dict[tuple[str, int], list[int]] = {}  # (host, port) -> [client id, environments using it]


class UR5BallReachEnv(gym.Env):
    """Reach the ball with the gripper; see the module docstring."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(self, host: str = "127.0.0.1", port: int = 19999, client_id: int | None = None,
                 width: int = 84, height: int = 84, joints: int = 3, max_offset_deg: float = 5.0,
                 sim_steps: int = 1, settle_steps: int = 2, pose_noise_deg: float = 0.0,
                 reward: str = "dense", success_distance: float = SUCCESS_DISTANCE,
                 max_episode_steps: int = 200, render_mode: str | None = None,
                 timeout_ms: int = 5000, tutorial_state: bool = False, servers: Any = None,
                 sensor_resolution: str | tuple[int, int] | None = None) -> None:
        if joints not in (3, 6):
            raise ValueError(f"joints must be 3 (joints 1-3) or 6, not {joints!r}")
        if reward not in ("dense", "image"):
            raise ValueError(f"reward must be 'dense' or 'image', not {reward!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', not {render_mode!r}")
        if width < 1 or height < 1 or sim_steps < 1 or settle_steps < 0 or max_episode_steps < 1:
            raise ValueError("width, height, sim_steps and max_episode_steps must be >= 1, settle_steps >= 0")
        self.width, self.height = int(width), int(height)
        self.n_joints = joints
        self.max_offset_deg = float(max_offset_deg)
        self.sim_steps, self.settle_steps = int(sim_steps), int(settle_steps)
        self.pose_noise_deg = float(pose_noise_deg)
        self.reward_type = reward
        self.success_distance = float(success_distance)
        self.max_episode_steps = int(max_episode_steps)
        self.render_mode = render_mode
        self.tutorial_state = bool(tutorial_state)

        # servers: a claims object (simx_server.pool.ServerPool.claims, or anything with
        # claim() -> (host, port) and release(address)): each environment of a vector env, all
        # made with the same arguments, takes a server of its own and gives it back in close().
        self._servers, self._claimed, self.local_servers = servers, None, None
        if isinstance(servers, (str, dict)):
            if client_id is not None:
                raise ValueError("servers='local' (or a pool spec) starts a server: give no client_id")
            self.local_servers = _local_server(servers)
            host, port = self.local_servers.addresses[0]
        elif servers is not None and client_id is None:
            self._claimed = host, port = servers.claim()
        # client_id: a connection the caller made and keeps (close() leaves it open).
        self._key: tuple[str, int] | None = None
        if client_id is None:
            # The legacy API allows one connection per address and port in a process: a second
            # environment on the same server (gymnasium's check_env makes one) shares it.
            self._key = (host, int(port))
            shared = _SHARED.get(self._key)
            if shared is None:
                client_id = vrep.simxStart(host, int(port), True, True, int(timeout_ms), 5)
                if client_id < 0:
                    raise ConnectionError(f"no simx/V-REP remote API server at {host}:{port}")
                shared = _SHARED[self._key] = [client_id, 0]
                # The environment only turns images into arrays: skip making the legacy lists
                # (simx only; a real vrep.py has no such switch).
                lazy = getattr(getattr(vrep, "images", None), "set_lazy_image_lists", None)
                if lazy is not None:
                    lazy(client_id)
            shared[1] += 1
            client_id = shared[0]
        self.client_id = client_id
        self._closed = False
        self._streaming = False  # reads come from the inbox (streams started in reset())
        self._timeout = timeout_ms / 1000.0

        self._joints = [self._handle(n) for n in JOINT_NAMES]
        self._rgb_sensor = self._handle("kinect_rgb")
        self._depth_sensor = self._handle("kinect_depth")
        self._ball = self._handle("Sphere")
        self._tcp = self._handle("RG2_tcp")
        self._sensor_resolution = _sensor_resolution(sensor_resolution)
        self._native = self._render_size = (0, 0)  # read in reset(), once a stop restored the scene's
        self._near = self._float_param(self._depth_sensor, vrep.sim_visionfloatparam_near_clipping)
        self._far = self._float_param(self._depth_sensor, vrep.sim_visionfloatparam_far_clipping)

        self.action_space = spaces.Box(-self.max_offset_deg, self.max_offset_deg, (joints,), np.float32)
        near32, far32 = np.float32(self._near), np.float32(self._far)
        observations = {
            "rgb": spaces.Box(0, 255, (self.height, self.width, 3), np.uint8),
            "depth": spaces.Box(near32, far32, (self.height, self.width), np.float32),
            "joints": spaces.Box(-np.inf, np.inf, (6,), np.float32),
        }
        if self.tutorial_state:
            observations["state"] = spaces.Box(np.float32(0), np.float32(1e4), (2,), np.float32)
            observations["ball_offset"] = spaces.Box(np.float32(-1e4), np.float32(1e4), (2,), np.float32)
        self.observation_space = spaces.Dict(observations)
        self._targets = np.radians(np.array(TUTORIAL_POSE_DEG))
        self._steps = 0
        self.steps_total = 0  # step() calls over the environment's life (all episodes)
        self._last_rgb: np.ndarray | None = None
        self._ball_start = np.zeros(3)

    # ------------------------------------------------------------------ simx helpers
    def _handle(self, name: str) -> int:
        rc, h = vrep.simxGetObjectHandle(self.client_id, name, _B)
        if rc != vrep.simx_return_ok:
            raise RuntimeError(f"simxGetObjectHandle({name!r}) failed (return code {rc}): not the tutorial's scene?")
        return h

    def _blocking(self, function: Any, *args: Any) -> tuple:
        """``function(client, *args, simx_opmode_blocking)``'s results after the return code;
        RuntimeError naming the function when it fails."""
        rc, *values = function(self.client_id, *args, _B)
        self._check(rc, function.__name__)
        return tuple(values)

    def _float_param(self, handle: int, param: int) -> float:
        return float(self._blocking(vrep.simxGetObjectFloatParameter, handle, param)[0])

    def _int_param(self, handle: int, param: int) -> int:
        return int(self._blocking(vrep.simxGetObjectIntParameter, handle, param)[0])

    def _check(self, rc: int, what: str) -> None:
        """Raise RuntimeError naming the call and its return code; with servers of its own
        (``servers="local"``), whether each still runs (else its exit status) and its log tail."""
        if rc != vrep.simx_return_ok:
            raise RuntimeError(f"{what} failed (return code {rc})"
                               f"{self._servers_state(stacks=bool(rc & vrep.simx_return_timeout_flag))}")

    def _servers_state(self, stacks: bool = False) -> str:
        """What the environment's own servers say ("" without servers of its own); ``stacks``
        (a call timed out): a server still running first writes its threads' stacks to its log
        (SIGUSR1, simx-server's faulthandler)."""
        pool = self.local_servers
        if pool is None:
            return ""
        try:
            if stacks:  # ask the running ones, and wait (at most 2 s) for their whole dumps
                before = [len(log) for log in pool.logs()]
                asked = [k for k, (pid, status) in enumerate(zip(pool.pids, pool.poll())) if status is None]
                for k in asked:
                    os.kill(pool.pids[k], signal.SIGUSR1)
                deadline, sizes = time.monotonic() + 2.0, None
                while time.monotonic() < deadline:
                    logs = pool.logs()
                    # begun everywhere, and no longer growing (a dump is written thread by thread)
                    if all("Thread 0x" in logs[k][before[k]:] for k in asked):
                        if sizes == [len(log) for log in logs]:
                            break
                        sizes = [len(log) for log in logs]
                    time.sleep(0.1)
            out = [f"\n--- its simx-server pid {pid} "
                   f"{'still runs' if status is None else f'(exit status {status})'}, log tail:\n{log[-(8000 if stacks else 2000):]}"
                   for pid, status, log in zip(pool.pids, pool.poll(), pool.logs())]
        except Exception as exc:  # the message must not hide the error it explains
            return f" (its servers' state unreadable: {exc})"
        return "".join(out)

    def _read(self, function: Any, *args: Any) -> tuple:
        """``function(client, *args, mode)``'s results after the return code: from the inbox
        (``simx_opmode_buffer``) once reset() started the streams, else blocking. A streamed
        value not there yet (just after the streaming call) is waited for, as legacy programs
        do (a ping, then the inbox again), for at most ``timeout_ms``."""
        if not self._streaming:
            return self._blocking(function, *args)
        deadline = time.monotonic() + self._timeout
        while True:
            rc, *values = function(self.client_id, *args, _BUFFER)
            if rc == vrep.simx_return_ok:
                return tuple(values)
            if rc != vrep.simx_return_novalue_flag or time.monotonic() > deadline:
                self._check(rc, f"{function.__name__} (buffer)")
            vrep.simxGetPingTime(self.client_id)

    def _start_streams(self) -> None:
        """Stream everything an observation reads (queued: call inside a simxPauseCommunication
        batch). With synchronous mode, the values in the inbox after simxSynchronousTrigger +
        simxGetPingTime are the step's, as V-REP guaranteed: no round trip per read."""
        cid = self.client_id
        vrep.simxGetVisionSensorImage(cid, self._rgb_sensor, 0, _STREAMING)
        vrep.simxGetVisionSensorDepthBuffer(cid, self._depth_sensor, _STREAMING)
        vrep.simxGetObjectGroupData(cid, vrep.sim_object_joint_type, 15, _STREAMING)
        for handle in (self._ball, self._tcp):
            vrep.simxGetObjectPosition(cid, handle, -1, _STREAMING)
        self._streaming = True

    def _position(self, handle: int) -> np.ndarray:
        (p,) = self._read(vrep.simxGetObjectPosition, handle, -1)
        return np.array(p, dtype=np.float64)

    def _simulate(self, n: int) -> None:
        for _ in range(n):
            self._check(vrep.simxSynchronousTrigger(self.client_id), "simxSynchronousTrigger")
        if n:
            vrep.simxGetPingTime(self.client_id)  # returns after the last triggered step

    def _wait_stopped(self, timeout: float = 5.0) -> None:
        """V-REP stops a few passes after the request (simx at once): wait for the server state's
        bit 0 (running) to clear, as legacy programs do, so that the start that follows counts."""
        deadline = time.monotonic() + timeout
        while True:
            vrep.simxGetPingTime(self.client_id)  # a fresh reply carries the server state
            rc, state = vrep.simxGetInMessageInfo(self.client_id, vrep.simx_headeroffset_server_state)
            if rc == -1 or not state & 1 or time.monotonic() > deadline:
                return
            time.sleep(0.01)

    def _resize(self, img: np.ndarray) -> np.ndarray:
        if img.shape[0] == self.height and img.shape[1] == self.width:
            return img
        return cv2.resize(img, (self.width, self.height), interpolation=cv2.INTER_AREA)

    def _rgb_frame(self) -> np.ndarray:
        """``kinect_rgb``'s image as rendered, (h, w, 3) uint8, rows top-down."""
        res, raw = self._read(vrep.simxGetVisionSensorImage, self._rgb_sensor, 0)
        return np.asarray(raw, dtype=np.uint8).reshape(res[1], res[0], 3)[::-1]

    def _rgb(self) -> np.ndarray:
        return np.ascontiguousarray(self._resize(self._rgb_frame()))

    def _depth_frame(self) -> np.ndarray:
        """``kinect_depth``'s depth as rendered, (h, w) float32 metres, rows top-down."""
        res, buf = self._read(vrep.simxGetVisionSensorDepthBuffer, self._depth_sensor)
        d = np.asarray(buf, dtype=np.float32).reshape(res[1], res[0])[::-1]
        metres = np.float32(self._near) + d * np.float32(self._far - self._near)
        return np.clip(metres, np.float32(self._near), np.float32(self._far))

    def _set_render_size(self) -> None:
        """Both sensors to the render size (queued: call inside a simxPauseCommunication batch)."""
        if self._render_size == self._native:
            return
        w, h = self._render_size
        for sensor in (self._rgb_sensor, self._depth_sensor):
            vrep.simxSetObjectIntParameter(self.client_id, sensor, vrep.sim_visionintparam_resolution_x, w, _ONESHOT)
            vrep.simxSetObjectIntParameter(self.client_id, sensor, vrep.sim_visionintparam_resolution_y, h, _ONESHOT)

    def _ball_pixels(self) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
        """Rows and columns (top-down, the sensor's resolution) where the colour-coded render of
        ``kinect_rgb`` shows the ball, and that resolution ``(height, width)``."""
        cid, mode = self.client_id, vrep.sim_visionintparam_render_mode
        self._check(vrep.simxSetObjectIntParameter(cid, self._rgb_sensor, mode, vrep.sim_rendermode_colorcoded, _B),
                    "simxSetObjectIntParameter(render mode)")
        try:
            res, raw = self._blocking(vrep.simxGetVisionSensorImage, self._rgb_sensor, 0)
        finally:
            vrep.simxSetObjectIntParameter(cid, self._rgb_sensor, mode, vrep.sim_rendermode_opengl, _B)
            if self._streaming:  # the blocking read above replaced the image's stream: again
                vrep.simxGetVisionSensorImage(cid, self._rgb_sensor, 0, _STREAMING)
        handles = decode_handles(np.asarray(raw, dtype=np.uint8).reshape(res[1], res[0], 3)[::-1])
        rows, cols = np.nonzero(handles == self._ball)
        return rows, cols, (res[1], res[0])

    def _tutorial_state(self, depth: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
        """The tutorial's state from the colour-coded render and ``depth`` (the depth frame,
        metres): the ball's centroid scaled to the scene sensor's own pixels; its signed offset
        (x right, y down) from the image centre; whether the ball was seen."""
        rows, cols, (h, w) = self._ball_pixels()
        nw, nh = self._native
        if len(rows) == 0:
            return (np.array([math.hypot(nw, nh) / 2, self._far], dtype=np.float32),
                    np.zeros(2, dtype=np.float32), False)
        r, c = rows.mean(), cols.mean()
        dh, dw = depth.shape
        at = depth[min(dh - 1, int((r + 0.5) * dh / h)), min(dw - 1, int((c + 0.5) * dw / w))]
        cn, rn = (c + 0.5) * nw / w - 0.5, (r + 0.5) * nh / h - 0.5  # pixel centres, native size
        dx, dy = cn - (nw - 1) / 2, rn - (nh - 1) / 2
        return (np.array([math.hypot(dx, dy), at], dtype=np.float32), np.array([dx, dy], dtype=np.float32), True)

    def _group(self, object_type: int, data_type: int, per_object: int) -> dict[int, np.ndarray]:
        """One ``simxGetObjectGroupData`` call: ``{handle: its floats}`` (one round trip for
        what would be one call per object)."""
        handles, _, floats, _ = self._read(vrep.simxGetObjectGroupData, object_type, data_type)
        values = np.asarray(floats, dtype=np.float64).reshape(len(handles), per_object)
        return dict(zip(handles, values))

    def _joint_positions(self) -> np.ndarray:
        """The six joint angles (rad): joint states (data type 15: position, force per joint)."""
        states = self._group(vrep.sim_object_joint_type, 15, 2)
        return np.array([states[h][0] for h in self._joints], dtype=np.float32)

    def _observe(self) -> tuple[dict[str, np.ndarray], dict[str, Any], float, bool]:
        rgb, depth = self._rgb(), self._depth_frame()
        obs = {"rgb": rgb, "depth": self._resize(np.ascontiguousarray(depth)), "joints": self._joint_positions()}
        self._last_rgb = rgb
        ball, tcp = self._position(self._ball), self._position(self._tcp)
        distance = float(np.linalg.norm(ball - tcp))
        reward = -distance if self.reward_type == "dense" else image_reward(rgb)
        info = {"distance": distance, "ball_position": ball, "gripper_position": tcp}
        if self.tutorial_state:
            obs["state"], obs["ball_offset"], info["ball_visible"] = self._tutorial_state(depth)
        return obs, info, reward, distance <= self.success_distance

    # ------------------------------------------------------------------ Gymnasium API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        cid = self.client_id
        self._streaming = False  # blocking reads until the streams are started again below
        self._check(vrep.simxStopSimulation(cid, _B), "simxStopSimulation")
        self._wait_stopped()
        self._native = (self._int_param(self._rgb_sensor, vrep.sim_visionintparam_resolution_x),
                        self._int_param(self._rgb_sensor, vrep.sim_visionintparam_resolution_y))
        self._render_size = render_size(self._native, (self.width, self.height), self._sensor_resolution)
        self._check(vrep.simxSynchronous(cid, True), "simxSynchronous")
        self._check(vrep.simxStartSimulation(cid, _B), "simxStartSimulation")
        noise = self.np_random.uniform(-self.pose_noise_deg, self.pose_noise_deg, 6) if self.pose_noise_deg else 0.0
        self._targets = np.radians(np.array(TUTORIAL_POSE_DEG) + noise)
        x, y = self.np_random.uniform(BALL_X[0], BALL_X[1]), self.np_random.uniform(BALL_Y[0], BALL_Y[1])
        self._ball_start = np.array([x, y, BALL_Z])
        vrep.simxPauseCommunication(cid, True)
        for h, t in zip(self._joints, self._targets):
            vrep.simxSetJointPosition(cid, h, float(t), _ONESHOT)
            vrep.simxSetJointTargetPosition(cid, h, float(t), _ONESHOT)
        vrep.simxSetObjectPosition(cid, self._ball, -1, [float(x), float(y), BALL_Z], _ONESHOT)
        self._set_render_size()  # a stop gave the sensors back the scene's resolution
        self._start_streams()
        vrep.simxPauseCommunication(cid, False)
        self._simulate(self.settle_steps)
        self._steps = 0
        obs, info, _, _ = self._observe()
        return obs, info

    def step(self, action):
        if self._closed:
            raise RuntimeError("step() on a closed environment")
        offsets = np.nan_to_num(np.asarray(action, dtype=np.float64).reshape(self.n_joints))  # NaN: no move
        offsets = np.clip(offsets, -self.max_offset_deg, self.max_offset_deg)
        self._targets[: self.n_joints] += np.radians(offsets)
        cid = self.client_id
        vrep.simxPauseCommunication(cid, True)
        for h, t in zip(self._joints[: self.n_joints], self._targets[: self.n_joints]):
            vrep.simxSetJointTargetPosition(cid, h, float(t), _ONESHOT)
        vrep.simxPauseCommunication(cid, False)
        self._simulate(self.sim_steps)
        self._steps += 1
        self.steps_total += 1
        obs, info, reward, terminated = self._observe()
        truncated = self._steps >= self.max_episode_steps and not terminated
        info["is_success"] = terminated  # the key Stable-Baselines3's logger counts
        return obs, reward, terminated, truncated, info

    def server_info(self) -> dict[str, Any]:
        """Where this environment's steps go: ``{"host", "port", "server_pid" (None unless
        ``servers`` started a local server), "env_pid" (this process), "steps" (step() calls so
        far)}``; plain values, so a vector environment's ``call("server_info")`` can return it."""
        pool = self.local_servers
        host, port = (pool.addresses[0] if pool is not None else self._claimed or self._key or (None, None))
        return {"host": host, "port": port, "server_pid": pool.pids[0] if pool is not None else None,
                "env_pid": os.getpid(), "steps": self.steps_total}

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        return self._rgb() if self._last_rgb is None else self._last_rgb.copy()

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self._key is not None:
            shared = _SHARED[self._key]
            shared[1] -= 1
            if shared[1] == 0:
                del _SHARED[self._key]
                vrep.simxSynchronous(self.client_id, False)
                vrep.simxFinish(self.client_id)
        if self._claimed is not None:
            self._servers.release(self._claimed)
        if self.local_servers is not None:
            self.local_servers.close()


def _local_server(spec: str | dict) -> Any:
    """A started :class:`simx_server.pool.ServerPool` of one server for ``servers="local"`` or a
    pool spec ``{"scene": ..., "args": [...]}``; ValueError for anything else."""
    if isinstance(spec, str):
        if spec != "local":
            raise ValueError(f"servers must be 'local', a pool spec dict or a claims object, not {spec!r}")
        spec = {}
    unknown = set(spec) - {"scene", "args"}
    if unknown:
        raise ValueError(f"a pool spec takes 'scene' and 'args', not {sorted(unknown)}")
    return local_pool(1, spec.get("scene"), *[str(a) for a in spec.get("args", ("--speed", "0"))])


def _sensor_resolution(value: Any) -> str | tuple[int, int] | None:
    """``sensor_resolution`` as given, checked: None, ``"native"`` or a ``(w, h)`` of ints >= 1."""
    if value is None or (isinstance(value, str) and value == "native"):
        return value
    try:
        w, h = (int(v) for v in value)
    except (TypeError, ValueError):
        w = h = 0
    if w < 1 or h < 1:
        raise ValueError(f"sensor_resolution must be None, 'native' or (width, height) >= 1, not {value!r}")
    return w, h


def render_size(native: tuple[int, int], observation: tuple[int, int],
                sensor_resolution: str | tuple[int, int] | None) -> tuple[int, int]:
    """The ``(w, h)`` the sensors render at: see ``sensor_resolution`` in the module docstring.

    >>> render_size((640, 480), (84, 84), None)
    (112, 84)
    """
    if sensor_resolution == "native":
        return native
    if sensor_resolution is not None:
        return sensor_resolution  # type: ignore[return-value]  # (w, h), checked by _sensor_resolution
    (nw, nh), (ow, oh) = native, observation
    scale = max(ow / nw, oh / nh)
    if scale >= 1:
        return native
    return max(1, math.ceil(nw * scale - 1e-9)), max(1, math.ceil(nh * scale - 1e-9))


def image_reward(rgb: np.ndarray) -> float:
    """Minus the distance of the red ball's centroid from the image centre in half-diagonals;
    -1 when no ball pixel is seen (no division by a zero pixel count)."""
    r, g, b = (rgb[:, :, i].astype(np.int16) for i in range(3))
    rows, cols = np.nonzero((r > 150) & (g < 80) & (b < 80))
    if len(rows) == 0:
        return -1.0
    h, w = rgb.shape[:2]
    return -min(1.0, math.hypot(cols.mean() - (w - 1) / 2, rows.mean() - (h - 1) / 2) / math.hypot(w / 2, h / 2))
