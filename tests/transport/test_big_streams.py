"""Stream updates of huge images reach their client (issue 23): a 4096x4096 RGB image is a 50 MB
update, and Zenoh's "drop" congestion control, which stream updates are put with, dropped every
one of them (0 updates in 10 s; a 2048x2048 image's 12.5 MB arrived). Updates of
limits.BULK_SEND_BYTES or more are put with blocking congestion control, giving way to other
clients' sends and within limits.BULK_SHARE of the sending thread's time."""

from __future__ import annotations

import os
import threading

import zenoh
from conftest import SCENE, ServerProcess, wait_until

import vrep
from simx_client import protocol as P
from simx_client.connection import client_config
from simx_server.base import limits

B = vrep.simx_opmode_blocking


def test_a_streamed_4096x4096_image_keeps_arriving():
    srv = ServerProcess(str(SCENE), "--pacing", "immediate")
    # A negative timeout: blocking calls wait up to 60 s for their reply (a bound on the wait
    # only; whether a call is answered while the updates flow is stated by order below).
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, -60_000, 5)
    session = None
    try:
        assert cid >= 0
        rc, rgb = vrep.simxGetObjectHandle(cid, "kinect_rgb", B)
        assert rc == 0
        assert vrep.simxSetObjectIntParameter(cid, rgb, 1002, 4096, B) == 0
        assert vrep.simxSetObjectIntParameter(cid, rgb, 1003, 4096, B) == 0
        session = zenoh.open(client_config("127.0.0.1", srv.port))
        client, updates, lock = f"big{os.getpid()}", [], threading.Lock()

        def received(sample: zenoh.Sample) -> None:
            t, entries = P.unpack_stream_update(sample.payload.to_bytes())
            with lock:
                updates.append((t, entries[0][2], len(entries[0][3][1])))

        session.declare_subscriber(P.stream_key(P.DEFAULT_PREFIX, client), received)
        request = P.request(client, [["GetVisionSensorImage", P.MODE_STREAMING, [rgb, 0]]])
        first = list(session.get(P.call_key(P.DEFAULT_PREFIX, client), timeout=30, payload=request))
        assert len(first) == 1 and first[0].ok is not None
        assert 4096 * 4096 * 3 >= limits.BULK_SEND_BYTES
        wait_until(lambda: len(updates) >= 2, timeout=60, what="two stream updates of the 4096x4096 image")
        with lock:
            times = [t for t, _, _ in updates]
            assert all(ok and size == 4096 * 4096 * 3 for _, ok, size in updates), updates
        assert times == sorted(times) and len(set(times)) == len(times)  # new frames, in order
        # Another client's blocking call is answered meanwhile: between updates, which keep
        # coming after it (stated by order; a send thread stuck in a blocked push would hold
        # the call up until its 60 s).
        assert vrep.simxGetPingTime(cid)[0] == 0
        with lock:
            before = len(updates)
        wait_until(lambda: len(updates) > before, timeout=60, what="an update after the blocking call")
    finally:
        if session is not None:
            session.close()
        if cid >= 0:
            vrep.simxFinish(cid)
        srv.stop()
