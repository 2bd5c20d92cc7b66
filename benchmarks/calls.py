"""1. Call round trip: blocking simx calls against the bare Zenoh query/reply floor.

One simx server (default scene, running in real time, dt 50 ms) and one echo process, each on
its own free loopback port; the client process times, side by side in interleaved blocks:

* the bare floor: a Zenoh query/reply to benchmarks/zenoh_echo.py with exactly the request and
  reply sizes of the simx call it is compared with (measured on the wire first);
* the same floor with the reply sent from the echo's main thread (the thread hop simx-server
  makes to reach its simulation thread), for diagnosis;
* the floor plus msgpack: the echo decodes a real simx request and encodes a simx response
  with simx's protocol functions, the client encodes and decodes them likewise: what any
  msgpack protocol over Zenoh pays, for diagnosis;
* the design floor: msgpack as above, answered from a thread fed through a queue as
  simx-server answers: what DESIGN.md's architecture costs before any simx logic, for
  diagnosis (simx's own code is the call minus this);
* simx-server queried bare: the exact request bytes of ``simxGetJointPosition`` sent through a
  plain Zenoh querier (no simx client code), for diagnosis: it splits simx's time over the
  floor into the server's part (this row minus the floor) and the client's (the call minus this);
* ``simxGetJointPosition``, ``simxGetObjectHandle`` and ``simxSetJointTargetPosition``, blocking;
* a ``simxPauseCommunication`` batch of six oneshot ``simxSetJointTargetPosition`` followed by a
  blocking ``simxGetPingTime`` (the legacy way to know the batch arrived), against the same
  pattern bare (an unawaited query of the batch's size, then an awaited one of the ping's size).
"""

from __future__ import annotations

import zenoh

from benchmarks.common import Floor, Settings, connect, connection, floor_pipelined, interleaved, perf, wire_sizes
from benchmarks.procs import Echo, Server
from benchmarks.stats import Figure, Target, scaled, summary
from simx_client import api
from simx_client import constants as C
from simx_client import protocol as P
from simx_client.connection import client_config

B, ONESHOT = C.simx_opmode_blocking, C.simx_opmode_oneshot
RT_TARGET = Target("ratio", "<=", 1.15, "p50 <= 1.15x floor")  # issue 30 (1.25x before)


def _ok(result) -> None:
    rc = result[0] if isinstance(result, tuple) else result
    if rc != 0:
        raise RuntimeError(f"simx call failed with return code {rc}")


def run(s: Settings) -> list[Figure]:
    # Raw round trips: served at once (with legacy pacing a blocking call waits for the next step).
    with Server(s.log_dir, "--pacing", "immediate", name="calls") as srv, Echo(s.log_dir) as echo:
        cid = connect(srv.port)
        floor = Floor(echo.port)
        bare = zenoh.open(client_config("127.0.0.1", srv.port))
        try:
            return _measure(s, cid, floor, bare)
        finally:
            bare.close()
            floor.close()
            api.simxFinish(cid)


def _bare_simx(session: zenoh.Session, cid: int, commands: list[list]):
    """A function sending simx's own request bytes for ``commands`` through a plain declared
    querier and waiting for the reply, with no simx client code on the way."""
    client = connection(cid).client
    querier = session.declare_querier(P.call_key(P.DEFAULT_PREFIX, client), timeout=5.0)
    payload = P.request(client, commands)

    def call() -> None:
        for reply in querier.get(payload=payload):
            if reply.ok is not None:
                reply.ok.payload.to_bytes()
                return
        raise RuntimeError("simx-server did not answer the bare query")
    return call


def _measure(s: Settings, cid: int, floor: Floor, bare: zenoh.Session) -> list[Figure]:
    joints = []
    for i in range(1, 7):
        rc, h = api.simxGetObjectHandle(cid, f"UR5_joint{i}", B)
        _ok(rc)
        joints.append(h)
    j1 = joints[0]
    size = {
        "jp": wire_sizes(cid, [["GetJointPosition", B, [j1]]]),
        "gh": wire_sizes(cid, [["GetObjectHandle", B, ["UR5_joint1"]]]),
        "st": wire_sizes(cid, [["SetJointTargetPosition", B, [j1, 0.0]]]),
        "batch": wire_sizes(cid, [["SetJointTargetPosition", ONESHOT, [h, 0.0]] for h in joints]),
        "ping": wire_sizes(cid, [["GetPingTime", B, []]]),
    }

    def batch() -> None:
        api.simxPauseCommunication(cid, True)
        for h in joints:
            api.simxSetJointTargetPosition(cid, h, 0.0, ONESHOT)
        api.simxPauseCommunication(cid, False)
        _ok(api.simxGetPingTime(cid))

    send_only: list[float] = []

    def batch_send_only() -> None:
        t0 = perf()
        api.simxPauseCommunication(cid, True)
        for h in joints:
            api.simxSetJointTargetPosition(cid, h, 0.0, ONESHOT)
        api.simxPauseCommunication(cid, False)
        send_only.append(perf() - t0)
        _ok(api.simxGetPingTime(cid))  # let it land before the next case is timed

    cases = {
        "floor_jp": lambda: floor.call(size["jp"][1], size["jp"][0]),
        "hop_jp": lambda: floor.call(size["jp"][1], size["jp"][0], hop=True),
        "codec_jp": lambda: _ok((0, floor.codec_call([["GetJointPosition", B, [j1]]]))),
        "design_jp": lambda: _ok((0, floor.codec_call([["GetJointPosition", B, [j1]]], hop=True))),
        "jp": lambda: _ok(api.simxGetJointPosition(cid, j1, B)),
        "bare_jp": _bare_simx(bare, cid, [["GetJointPosition", B, [j1]]]),
        "floor_gh": lambda: floor.call(size["gh"][1], size["gh"][0]),
        "gh": lambda: _ok(api.simxGetObjectHandle(cid, "UR5_joint1", B)),
        "floor_st": lambda: floor.call(size["st"][1], size["st"][0]),
        "st": lambda: _ok(api.simxSetJointTargetPosition(cid, j1, 0.0, B)),
        "floor_batch": lambda: floor_pipelined(floor, size["batch"], size["ping"]),
        "batch": batch,
        "batch_send": batch_send_only,
    }
    t = interleaved(s.n(40, 8), 25, cases, budget_s=s.t(60, 20))
    ms = {k: scaled(summary(v), 1e3) for k, v in t.items()}

    def fl(key: str, label: str) -> dict:
        return {"label": label, **ms[key]}

    sizes_note = lambda k: f"request {size[k][0]} B, reply {size[k][1]} B"  # noqa: E731
    return [
        Figure("calls.floor", "bare Zenoh query/reply (GetJointPosition sizes)", "ms", ms["floor_jp"],
               note=sizes_note("jp"), extra={"sizes": size}),
        Figure("calls.floor_hop", "bare Zenoh + thread hop (reply from main thread)", "ms", ms["hop_jp"],
               floor=fl("floor_jp", "bare Zenoh query/reply"), note="what simx's queue hand-off costs, no simx code"),
        Figure("calls.floor_codec", "bare Zenoh + msgpack request/response codec", "ms", ms["codec_jp"],
               floor=fl("floor_jp", "bare Zenoh query/reply"),
               note="simx's request/response encoded and decoded on both ends, no simx logic"),
        Figure("calls.floor_design", "bare Zenoh + thread hop + msgpack codec (design floor)", "ms", ms["design_jp"],
               floor=fl("floor_jp", "bare Zenoh query/reply"),
               note="the codec row answered through a queue from a thread of its own, as simx-server answers"),
        Figure("calls.get_joint_position", "simxGetJointPosition (blocking)", "ms", ms["jp"],
               floor=fl("floor_jp", "bare Zenoh query/reply, same sizes"), target=RT_TARGET, note=sizes_note("jp")),
        Figure("calls.get_joint_position_bare", "  simx-server queried bare (simx request bytes, no client code)", "ms",
               ms["bare_jp"], floor=fl("floor_jp", "bare Zenoh query/reply, same sizes"),
               note="server part = this - floor; client part = simxGetJointPosition - this"),
        Figure("calls.get_object_handle", "simxGetObjectHandle (blocking)", "ms", ms["gh"],
               floor=fl("floor_gh", "bare Zenoh query/reply, same sizes"), target=RT_TARGET, note=sizes_note("gh")),
        Figure("calls.set_joint_target_position", "simxSetJointTargetPosition (blocking)", "ms", ms["st"],
               floor=fl("floor_st", "bare Zenoh query/reply, same sizes"), target=RT_TARGET, note=sizes_note("st")),
        Figure("calls.pause_batch6", "PauseCommunication batch of 6 targets + GetPingTime", "ms", ms["batch"],
               floor=fl("floor_batch", "bare: unawaited batch-size query + awaited ping-size query"),
               note=f"batch {sizes_note('batch')}; ping {sizes_note('ping')}"),
        Figure("calls.pause_batch6_send", "  of which: queueing + sending the batch (client side)", "ms",
               scaled(summary(send_only), 1e3), note="pause(True), 6 oneshot sets, pause(False); no wait"),
    ]
