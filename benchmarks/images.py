"""3. Images: ``simxGetVisionSensorImage`` on ``kinect_rgb`` (640x480 RGB) and
``simxGetVisionSensorDepthBuffer`` on ``kinect_depth`` (640x480 float32), then streamed images.

Decomposition of one blocking image call (every part timed side by side, one of each per round):

* **total**: the blocking call from the client, on a fresh world state (the server runs in
  synchronous mode and one ``simxSynchronousTrigger``, untimed, precedes each timed call, so
  the server's per-step frame cache misses and the frame is rendered inside the call);
* **render**, two ways: (a) in this process on an identical ``Simulation``:
  ``sim.world.step()`` (untimed) then ``sim.vision.image_bytes(handle, 0)`` (render, flip, copy
  to bytes), same MUJOCO_GL; (b) on the server itself, for the very call timed: the server is
  benchmarks/instrumented_server.py, whose probe times ``VisionSensors.image_bytes`` /
  ``depth_bytes`` (same work as (a)) and stamps it with CLOCK_MONOTONIC;
* **conversion**: the client's bytes -> legacy list, ``simx_client.api._image`` (numpy
  ``frombuffer(int8).tolist()``) on the same bytes, in this process;
* **transfer** = total - render (b, the same call's) - conversion (same round): everything
  else (request, msgpack on both sides, Zenoh over loopback TCP, payload copies, the server's
  thread hop). Its floor is a bare Zenoh query/reply of the same sizes to
  benchmarks/zenoh_echo.py. (With render (a) instead, the difference of two processes'
  renders adds their noise; the JSON keeps that variant as ``transfer_inprocess``.)

Also a second call in the same step (server cache hit, no render) as a cross-check of
transfer + conversion, and the legacy binding's own conversion: copying the 921,600-byte
``c_byte`` buffer (307,200 ``c_float`` for depth) into a list element by element, exactly as
``vrep.py`` did, timed in the same rounds.

The arm is first put in the tutorial's DDPG start pose (on the server and in the in-process
copy alike), where the Kinect looks at the table and the ball, as robotControl.py's user sees
it; at the zero pose it would see only the sky.

Streaming: ``simx_opmode_streaming`` on ``kinect_rgb`` with the server back in asynchronous real
time (dt 50 ms); a legacy-style loop reads ``simx_opmode_buffer`` (converting every read) and
counts new frames (``simxGetLastCmdTime`` changes): frames per second received and simulation
steps per second meanwhile.
"""

from __future__ import annotations

import ctypes
import json
import math
import time

import numpy as np

from benchmarks.common import Floor, Settings, connect, interleaved, perf, wire_sizes
from benchmarks.procs import SCENE, Echo, Server
from benchmarks.stats import Figure, Target, rate_summary, scaled, summary
from simx_client import api
from simx_client import constants as C

B, STREAM, BUFFER = C.simx_opmode_blocking, C.simx_opmode_streaming, C.simx_opmode_buffer
TUTORIAL_POSE = [90, -45, 90, 0, -100, 0]  # degrees, the DDPG start pose (tests/sim/test_tutorial_pose.py)


def tutorial_pose(cid: int, sim) -> None:
    """Teleport the UR5 to the tutorial pose on the server (and hold it) and in ``sim``."""
    for i, degrees in enumerate(TUTORIAL_POSE, start=1):
        q = math.radians(degrees)
        h = api.simxGetObjectHandle(cid, f"UR5_joint{i}", B)[1]
        _check(api.simxSetJointPosition(cid, h, q, B), "simxSetJointPosition")
        sim.world.set_joint_position(sim.world.resolve(f"UR5_joint{i}").handle, q)
    sim.world.changed()


def legacy_image_list(c_image, n: int) -> list:
    """vrep.py's simxGetVisionSensorImage conversion: element by element from c_byte*."""
    image = [None] * n
    for i in range(n):
        image[i] = c_image[i]
    return image


def gl_renderer() -> str:
    """GL_RENDERER of the context current on this thread (after a render), or why not. Run it
    on the render thread, which owns the GL contexts (``VisionSensors.after``)."""
    try:
        from OpenGL import GL

        return "; ".join(GL.glGetString(x).decode() for x in (GL.GL_RENDERER, GL.GL_VERSION))
    except Exception as exc:  # no context, no PyOpenGL, ...
        return f"unknown ({type(exc).__name__})"


def _check(rc: int, what: str) -> None:
    if rc != 0:
        raise RuntimeError(f"{what} failed with return code {rc}")


def run(s: Settings) -> list[Figure]:
    from simx_server.scene.simulation import Simulation

    probe_log = s.log_dir / "images-probe.json"
    s.log_dir.mkdir(parents=True, exist_ok=True)
    sim = Simulation(SCENE, 0.05)
    try:
        with Echo(s.log_dir) as echo:
            srv = Server(s.log_dir, probe_log=probe_log, name="images")
            try:
                cid = connect(srv.port)
                floor = Floor(echo.port)
                try:
                    raw = _measure(s, cid, floor, sim)
                finally:
                    floor.close()
                    api.simxFinish(cid)
            finally:
                srv.stop()
    finally:
        sim.close()
    frames = json.loads(probe_log.read_text())["frames"]
    return _figures(raw, frames) + _first_frames(s)


def _server_frame(frames: list, kind: str, a: float, b: float) -> float:
    """Duration (s) of the server's frame of ``kind`` produced within [a, b] (the longest: the
    one that rendered)."""
    got = [d for k, t0, d in frames if k == kind and a <= t0 <= b]
    return max(got) if got else float("nan")


def _measure(s: Settings, cid: int, floor: Floor, sim) -> list[Figure]:
    rgb = api.simxGetObjectHandle(cid, "kinect_rgb", B)[1]
    dep = api.simxGetObjectHandle(cid, "kinect_depth", B)[1]
    _check(api.simxSynchronous(cid, True), "simxSynchronous")
    _check(api.simxStartSimulation(cid, B), "simxStartSimulation")
    tutorial_pose(cid, sim)
    h_rgb, h_dep = sim.world.resolve("kinect_rgb").handle, sim.world.resolve("kinect_depth").handle
    assert (h_rgb, h_dep) == (rgb, dep)

    size_rgb = wire_sizes(cid, [["GetVisionSensorImage", B, [rgb, 0]]])
    size_dep = wire_sizes(cid, [["GetVisionSensorDepthBuffer", B, [dep]]])
    res, img_bytes = sim.vision.image_bytes(rgb, 0)
    _, dep_bytes = sim.vision.depth_bytes(dep)
    renderer = sim.vision.after(gl_renderer).result()  # the GL context is the render thread's
    n_img, n_dep = res[0] * res[1] * 3, res[0] * res[1]
    c_img_buf = (ctypes.c_byte * n_img).from_buffer_copy(img_bytes)
    c_dep_buf = (ctypes.c_float * n_dep).from_buffer_copy(dep_bytes)
    c_img = ctypes.cast(c_img_buf, ctypes.POINTER(ctypes.c_byte))
    c_dep = ctypes.cast(c_dep_buf, ctypes.POINTER(ctypes.c_float))
    seen = {"rgb": 0, "dep": 0}
    spans: dict[str, list] = {"rgb": [], "dep": []}  # (monotonic start, end) of each timed call

    def server_call(kind: str, call, what: str):
        """A timed blocking call on a fresh step (the trigger untimed); records its span."""
        def timed() -> float:
            _check(api.simxSynchronousTrigger(cid), "simxSynchronousTrigger")
            m0, t0 = time.monotonic(), perf()
            rc, _, values = call()
            dt = perf() - t0
            spans[kind].append((m0, time.monotonic()))
            _check(rc, what)
            seen[kind] = len(values)
            return dt
        return timed

    def in_process(render):
        """Render time of one frame on an identical in-process Simulation, after a step."""
        def timed() -> float:
            sim.world.step()
            t0 = perf()
            render()
            return perf() - t0
        return timed

    rgb_call = server_call("rgb", lambda: api.simxGetVisionSensorImage(cid, rgb, 0, B), "simxGetVisionSensorImage")
    dep_call = server_call("dep", lambda: api.simxGetVisionSensorDepthBuffer(cid, dep, B),
                           "simxGetVisionSensorDepthBuffer")
    rgb_render = in_process(lambda: sim.vision.image_bytes(rgb, 0))
    dep_render = in_process(lambda: sim.vision.depth_bytes(dep))

    def rgb_cached() -> None:
        _check(api.simxGetVisionSensorImage(cid, rgb, 0, B)[0], "simxGetVisionSensorImage")

    # np.array on the returned lists (simx_client.images.ImageList) against plain lists of the
    # same values. NumPy 2 refuses np.array(plain, dtype=np.uint8) on negative ints
    # (OverflowError), so the plain rgb list goes through int64 first, as a NumPy 2 user must.
    img_list, dep_list = api._image([res, img_bytes])[1], api._depth([res, dep_bytes])[1]
    img_plain, dep_plain = list(img_list), list(dep_list)
    cases = {
        "rgb_np": lambda: np.array(img_list, dtype=np.uint8),
        "rgb_np_plain": lambda: np.array(img_plain).astype(np.uint8),
        "dep_np": lambda: np.array(dep_list, dtype=np.float32),
        "dep_np_plain": lambda: np.array(dep_plain, dtype=np.float32),
        "rgb_call": rgb_call,
        "rgb_cached": rgb_cached,
        "rgb_render": rgb_render,
        "rgb_convert": lambda: api._image([res, img_bytes]),
        "rgb_legacy": lambda: legacy_image_list(c_img, n_img),
        "rgb_floor": lambda: floor.call(size_rgb[1], size_rgb[0]),
        "dep_call": dep_call,
        "dep_render": dep_render,
        "dep_convert": lambda: api._depth([res, dep_bytes]),
        "dep_legacy": lambda: legacy_image_list(c_dep, n_dep),
        "dep_floor": lambda: floor.call(size_dep[1], size_dep[0]),
    }
    t = interleaved(s.n(40, 8), 1, cases, warmup=2, budget_s=s.t(60, 20))
    assert seen["rgb"] == n_img and seen["dep"] == n_dep, seen
    _check(api.simxSynchronous(cid, False), "simxSynchronous(False)")
    warm = len(spans["rgb"]) - len(t["rgb_call"])  # warm-up calls come first
    return {"t": t, "spans": {k: v[warm:] for k, v in spans.items()}, "renderer": renderer,
            "size_rgb": size_rgb, "size_dep": size_dep, "stream": _streaming(s, cid, rgb)}


def _figures(raw: dict, frames: list) -> list[Figure]:
    t, spans, renderer = raw["t"], raw["spans"], raw["renderer"]
    size_rgb, size_dep = raw["size_rgb"], raw["size_dep"]
    ms = {k: scaled(summary(v), 1e3) for k, v in t.items()}
    decomposition = {}
    for kind, key, probe in (("rgb", "rgb", "image"), ("dep", "dep", "depth")):
        calls, conv, local = t[f"{key}_call"], t[f"{key}_convert"], t[f"{key}_render"]
        server = [_server_frame(frames, probe, a, b) for a, b in spans[kind]]
        k = min(len(calls), len(conv), len(server))
        decomposition[kind] = {
            "server_render_ms": scaled(summary([x for x in server if x == x]), 1e3),
            "transfer_ms": summary([(calls[i] - server[i] - conv[i]) * 1e3 for i in range(k) if server[i] == server[i]]),
            "transfer_inprocess_ms": summary([(calls[i] - local[i] - conv[i]) * 1e3
                                              for i in range(min(k, len(local)))]),
            "unmatched_calls": sum(1 for x in server if x != x),
        }
    legacy = {"label": "legacy vrep.py list copy (c_byte, element by element)", **ms["rgb_legacy"]}
    legacy_dep = {"label": "legacy vrep.py list copy (c_float, element by element)", **ms["dep_legacy"]}
    d_rgb, d_dep = decomposition["rgb"], decomposition["dep"]
    figs = [
        Figure("images.rgb_call", "GetVisionSensorImage rgb 640x480 (render incl.)", "ms", ms["rgb_call"],
               floor=legacy, target=Target("ratio", "<", 1.0, "< legacy list copy"),
               extra={"gl_renderer": renderer, "sizes": size_rgb, "decomposition": d_rgb}, note=f"GL: {renderer}"),
        Figure("images.rgb_render_server", "  render on the server (probe, same calls)", "ms",
               d_rgb["server_render_ms"], note=f"{d_rgb['unmatched_calls']} calls without a probe record"),
        Figure("images.rgb_render", "  render in-process (image_bytes, same scene)", "ms", ms["rgb_render"]),
        Figure("images.rgb_transfer", "  transfer (total - server render - conversion)", "ms", d_rgb["transfer_ms"],
               floor={"label": "bare Zenoh query/reply, same sizes", **ms["rgb_floor"]},
               note=f"request {size_rgb[0]} B, reply {size_rgb[1]} B"),
        Figure("images.rgb_convert", "  conversion to the legacy list (client)", "ms", ms["rgb_convert"],
               floor=legacy, target=Target("ratio", "<=", 0.2, "<= 0.2x copy (5x faster)")),
        Figure("images.rgb_cached", "GetVisionSensorImage, 2nd call same step (no render)", "ms",
               ms["rgb_cached"], floor=legacy),
        Figure("images.rgb_legacy_copy", "legacy binding: 921,600 c_byte -> list copy", "ms", ms["rgb_legacy"]),
        Figure("images.depth_call", "GetVisionSensorDepthBuffer 640x480 (render incl.)", "ms", ms["dep_call"],
               floor=legacy_dep, target=Target("ratio", "<", 1.0, "< legacy list copy"),
               extra={"sizes": size_dep, "decomposition": d_dep}),
        Figure("images.depth_render_server", "  render on the server (probe, same calls)", "ms",
               d_dep["server_render_ms"]),
        Figure("images.depth_render", "  render in-process (depth_bytes, same scene)", "ms", ms["dep_render"]),
        Figure("images.depth_transfer", "  transfer (total - server render - conversion)", "ms", d_dep["transfer_ms"],
               floor={"label": "bare Zenoh query/reply, same sizes", **ms["dep_floor"]},
               note=f"request {size_dep[0]} B, reply {size_dep[1]} B"),
        Figure("images.depth_convert", "  conversion to the legacy list (client)", "ms", ms["dep_convert"],
               floor=legacy_dep, target=Target("ratio", "<=", 0.2, "<= 0.2x copy (5x faster)")),
        Figure("images.depth_legacy_copy", "legacy binding: 307,200 c_float -> list copy", "ms", ms["dep_legacy"]),
        Figure("images.rgb_np_uint8", "np.array(image, dtype=np.uint8), 640x480 rgb list", "ms", ms["rgb_np"],
               floor={"label": "plain list of the same values: np.array(plain).astype(np.uint8)",
                      **ms["rgb_np_plain"]},
               target=Target("value", "<", 1.0, "< 1 ms"),
               note="NumPy 2 raises OverflowError for np.array(plain, dtype=np.uint8)"),
        Figure("images.depth_np_float32", "np.array(depth, dtype=np.float32), 640x480 depth list", "ms",
               ms["dep_np"], floor={"label": "plain list of the same values", **ms["dep_np_plain"]},
               target=Target("value", "<", 1.0, "< 1 ms")),
    ]
    return figs + raw["stream"]


def _first_streamed_image(cid: int, rgb: int, poll: float) -> None:
    """Start streaming ``rgb`` and poll the inbox every ``poll`` s until its first image is
    there; RuntimeError after 10 s."""
    api.simxGetVisionSensorImage(cid, rgb, 0, STREAM)
    deadline = time.monotonic() + 10
    while api.simxGetVisionSensorImage(cid, rgb, 0, BUFFER)[0] != 0:
        if time.monotonic() > deadline:
            raise RuntimeError("no streamed image within 10 s")
        time.sleep(poll)


def _streaming(s: Settings, cid: int, rgb: int) -> list[Figure]:
    window = s.t(8.0, 3.0)
    _first_streamed_image(cid, rgb, poll=0.002)
    frames: list[tuple[int, float]] = []
    last = api.simxGetLastCmdTime(cid)
    end = time.monotonic() + window
    while time.monotonic() < end:
        rc, _, img = api.simxGetVisionSensorImage(cid, rgb, 0, BUFFER)
        t = api.simxGetLastCmdTime(cid)
        if rc == 0 and t != last:
            frames.append((t, time.monotonic()))
            last = t
        else:
            time.sleep(0.001)
    api.simxGetVisionSensorImage(cid, rgb, 0, C.simx_opmode_discontinue)
    intervals = [b[1] - a[1] for a, b in zip(frames, frames[1:])]
    wall = frames[-1][1] - frames[0][1] if len(frames) > 1 else float("nan")
    sim_s = (frames[-1][0] - frames[0][0]) / 1e3 if len(frames) > 1 else float("nan")
    steps = sim_s / 0.05
    step_rate = steps / wall
    fps = (len(frames) - 1) / wall
    return [
        Figure("images.stream_fps", "streamed rgb 640x480: new frames/s in a buffer loop", "1/s",
               rate_summary(intervals), floor={"label": "sim steps/s meanwhile", "median": step_rate},
               note=f"{len(frames)} frames in {wall:.1f} s = {fps:.1f}/s; sim ran {step_rate:.1f} steps/s "
                    f"(real time = 20); frames per step {len(frames) - 1}/{steps:.0f}",
               extra={"frames": len(frames), "wall_s": wall, "sim_steps_per_s": step_rate, "fps_count": fps}),
    ]


def _first_frames(s: Settings) -> list[Figure]:
    """A fresh server each round (simulation running, dt 50 ms): ``simx_opmode_streaming`` on
    ``kinect_rgb``, then ``buffer`` polled every ~1 ms; wall time to the first image."""
    times = []
    for _ in range(s.n(6, 2)):
        srv = Server(s.log_dir, name="first-frame")
        try:
            cid = connect(srv.port)
            try:
                rgb = api.simxGetObjectHandle(cid, "kinect_rgb", B)[1]
                t0 = perf()
                _first_streamed_image(cid, rgb, poll=0.001)
                times.append(perf() - t0)
            finally:
                api.simxFinish(cid)
        finally:
            srv.stop()
    return [Figure("images.first_frame", "fresh server: streaming call -> first rgb 640x480 in buffer", "ms",
                   scaled(summary(times), 1e3), target=Target("value", "<=", 100.0, "<= 2 steps (100 ms)"),
                   note=f"{len(times)} fresh servers; the renderers are made before the simulation starts")]
