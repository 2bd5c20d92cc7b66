"""CoppeliaSim's ZMQ remote API (issue 22): its calls against a bare pyzmq REQ/REP echo of the same
sizes, and against the same calls over the legacy API, on one server.

One simx server (default scene, running in real time, ``--pacing immediate``, the ZMQ remote API
on a port of its own) and one ``benchmarks/zmq_echo.py`` process. Timed side by side in
interleaved blocks:

* ``sim.getJointPosition`` through the official client (``coppeliasim-zmqremoteapi-client``),
  the same request bytes through a raw REQ socket (no client library: the server's part),
  ``simxGetJointPosition`` (blocking, the legacy client), and the bare REQ/REP echo with the
  ZMQ call's exact request and reply sizes (measured on the wire first);
* a 640x480 RGB image with its render: the ZMQ client is in stepping mode and an untimed
  ``sim.step()`` comes before each timed call, so every timed call renders a new frame;
  ``sim.getVisionSensorImg`` (bytes, made a NumPy array) against ``simxGetVisionSensorImage``
  (blocking; the legacy list, made a NumPy array as programs do) and against the echo with the
  ZMQ call's sizes (921,600 bytes of pixels and the reply's framing).
"""

from __future__ import annotations

import numpy as np
import zmq

from benchmarks.common import Settings, connect, interleaved, perf
from benchmarks.procs import Proc, Server, free_port
from benchmarks.stats import Figure, Target, scaled, summary
from benchmarks.zmq_echo import request
from simx_client import api
from simx_client import constants as C
from simx_server.zmq import codec

B = C.simx_opmode_blocking


class ZmqEcho(Proc):
    """The bare ZMQ floor: benchmarks/zmq_echo.py on a free loopback port."""

    def __init__(self, log_dir, port: int | None = None):
        import sys

        from benchmarks.procs import ROOT

        self.port = port or free_port()
        super().__init__(f"zmq-echo-{self.port}", [sys.executable, "-m", "benchmarks.zmq_echo", "--port",
                                                   str(self.port)], log_dir, cwd=ROOT)


def _req(ctx: zmq.Context, port: int) -> zmq.Socket:
    sock = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVTIMEO, 30000)
    sock.connect(f"tcp://127.0.0.1:{port}")
    return sock


def run(s: Settings) -> list[Figure]:
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    zport = free_port()
    with Server(s.log_dir, "--pacing", "immediate", "--zmq-port", str(zport), name="zmq") as srv, \
            ZmqEcho(s.log_dir) as echo:
        cid = connect(srv.port)
        ctx = zmq.Context()
        client = RemoteAPIClient("127.0.0.1", zport)
        try:
            return _measure(s, cid, client, ctx, zport, echo.port)
        finally:
            api.simxFinish(cid)
            ctx.destroy(0)


def _measure(s: Settings, cid: int, client, ctx: zmq.Context, zport: int, echo_port: int) -> list[Figure]:
    sim = client.require("sim")
    joint = sim.getObject("/UR5/UR5_joint3")
    cam = sim.getObject("/UR5/kinect_rgb")
    _, ljoint = api.simxGetObjectHandle(cid, "UR5_joint3", B)
    _, lcam = api.simxGetObjectHandle(cid, "kinect_rgb", B)
    raw, floor = _req(ctx, zport), _req(ctx, echo_port)
    get_joint = codec.encode_request("sim.getJointPosition", [joint], client.uuid)
    raw.send(get_joint)
    joint_reply = len(raw.recv())
    joint_floor = request(joint_reply, len(get_joint))

    def floor_call(payload: bytes) -> None:
        floor.send(payload)
        floor.recv()

    def raw_call() -> None:
        raw.send(get_joint)
        raw.recv()

    rounds, block = s.n(40, 10), 25
    t = interleaved(rounds, block, {
        "floor": lambda: floor_call(joint_floor),
        "raw": raw_call,
        # (a case that returns a float is taken as having timed itself: these return None)
        "zmq": lambda: [sim.getJointPosition(joint)] and None,
        "legacy": lambda: api.simxGetJointPosition(cid, ljoint, B) and None,
    })
    fj = summary(t["floor"])
    rows = [
        Figure("zmq.floor", "bare pyzmq REQ/REP (getJointPosition sizes)", "ms", scaled(fj, 1e3),
               extra={"request_bytes": len(get_joint), "reply_bytes": joint_reply}),
        Figure("zmq.joint", "sim.getJointPosition over ZMQ (official client)", "ms", scaled(summary(t["zmq"]), 1e3),
               floor={"label": "bare REQ/REP", **scaled(fj, 1e3)},
               target=Target("ratio", "<=", 2.0, "p50 <= 2x floor (issue 30)")),
        Figure("zmq.joint_raw", "  the same request, raw REQ socket (server part)", "ms",
               scaled(summary(t["raw"]), 1e3), floor={"label": "bare REQ/REP", **scaled(fj, 1e3)}),
        Figure("zmq.joint_legacy", "simxGetJointPosition over the legacy API (Zenoh)", "ms",
               scaled(summary(t["legacy"]), 1e3), floor={"label": "bare REQ/REP", **scaled(fj, 1e3)}),
        Figure("zmq.joint_vs_legacy", "  ZMQ call / legacy call", "ms", scaled(summary(t["zmq"]), 1e3),
               floor={"label": "simxGetJointPosition", **scaled(summary(t["legacy"]), 1e3)},
               target=Target("ratio", "<=", 1.0, "<= 1x the legacy call")),
    ]
    rows += _images(s, sim, cid, lcam, cam, floor_call, raw, client)
    return rows


def _images(s: Settings, sim, cid: int, lcam: int, cam: int, floor_call, raw: zmq.Socket, client) -> list[Figure]:
    """640x480 RGB with its render: a fresh step before each timed call."""
    sim.setStepping(True)
    sim.startSimulation()
    try:
        image_req = codec.encode_request("sim.getVisionSensorImg", [cam], client.uuid)
        raw.send(image_req)
        image_reply = len(raw.recv())
        image_floor = request(image_reply, len(image_req))

        def zmq_image() -> float:
            sim.step()
            t0 = perf()
            img, res = sim.getVisionSensorImg(cam)
            np.frombuffer(img, dtype=np.uint8).reshape(res[1], res[0], 3)
            return perf() - t0

        def legacy_image() -> float:
            sim.step()
            t0 = perf()
            rc, res, img = api.simxGetVisionSensorImage(cid, lcam, 0, B)
            np.array(img, dtype=np.uint8).reshape(res[1], res[0], 3)
            if rc != 0:
                raise RuntimeError(f"simxGetVisionSensorImage: {rc}")
            return perf() - t0

        t = interleaved(s.n(30, 8), 2, {
            "floor": lambda: floor_call(image_floor),
            "zmq": zmq_image,
            "legacy": legacy_image,
        }, warmup=2)
    finally:
        sim.stopSimulation()
        sim.setStepping(False)
    fi = summary(t["floor"])
    return [
        Figure("zmq.image_floor", "bare pyzmq REQ/REP (640x480 image sizes)", "ms", scaled(fi, 1e3),
               extra={"request_bytes": len(image_req), "reply_bytes": image_reply}),
        Figure("zmq.image", "sim.getVisionSensorImg 640x480 over ZMQ (render incl.)", "ms",
               scaled(summary(t["zmq"]), 1e3), floor={"label": "bare REQ/REP", **scaled(fi, 1e3)}),
        Figure("zmq.image_legacy", "simxGetVisionSensorImage 640x480, legacy (render incl.)", "ms",
               scaled(summary(t["legacy"]), 1e3), floor={"label": "bare REQ/REP", **scaled(fi, 1e3)}),
        Figure("zmq.image_vs_legacy", "  ZMQ image / legacy image", "ms", scaled(summary(t["zmq"]), 1e3),
               floor={"label": "simxGetVisionSensorImage", **scaled(summary(t["legacy"]), 1e3)},
               target=Target("ratio", "<=", 1.0, "<= 1x the legacy call")),
    ]
