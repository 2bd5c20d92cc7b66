"""Issue 29 item 7 and the fuzz's memory: what a server keeps after clients leave.

* Connections that come and go keep nothing: 60 Zenoh sessions, each sending 30 requests of
  a few KiB and closing, grew a server by 16 MB each before (Zenoh's shared-memory transport
  mapped every session's 16 MiB pool and never unmapped it); now the server's Zenoh config has
  the shared-memory transport off unless the operator's file sets it.
* Large requests give their memory back: three requests with 1-10 MB strings and one asking
  for 160 images (a 147 MB reply, refused) left a server 250-300 MB larger before (a reference
  cycle in ``replies.pack_large`` held every image of a reply until the cyclic collector ran;
  glibc's dynamic mmap threshold and per-thread arenas kept the rest); now a few MB.
* The pieces: ``pack_large`` makes no cyclic garbage, the allocator settings are made at start
  unless the environment sets them, and a renderer's offscreen buffer is of its own size, not
  the largest sensor's (item 8: ten 4096x4096 streams left 1.1-1.5 GB of 4096x4096 buffers).
"""

from __future__ import annotations

import gc
import os
import subprocess
import sys
import time
import uuid

import zenoh

import vrep
from conftest import ServerProcess
from simx_client import protocol as P
from simx_client.connection import client_config
from simx_server.legacy.replies import pack_large
from simx_server.legacy.zenoh_config import zenoh_config

B = P.MODE_BLOCKING
WARM_UP = 10  # connections before the first measure (the first ones allocate what is reused)
CONNECTIONS = 50  # measured connections
MB_PER_CONNECTION = 1.0  # the bound; before: 16 MB each
LARGE_REQUESTS_MB = 40  # the bound for the large requests; before: 250-300 MB


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:")) / 1024


def _connection(port: int, requests: int = 30, size: int = 5000) -> None:
    """A fresh Zenoh session: ``requests`` blocking requests under a fresh client id (a string
    signal of ``size`` bytes every third one: over Zenoh's 3 KiB shared-memory threshold), close."""
    session = zenoh.open(client_config("127.0.0.1", port))
    client = uuid.uuid4().hex
    commands = [[["GetPingTime", B, []]], [["GetObjectHandle", B, ["UR5_joint1"]]],
                [["SetStringSignal", B, ["kept", b"x" * size]]]]
    try:
        for i in range(requests):
            replies = list(session.get(P.call_key("simx", client), payload=P.request(client, commands[i % 3]),
                                       timeout=10))
            assert len(replies) == 1 and replies[0].ok is not None
            assert P.unpack_response(replies[0].ok.payload.to_bytes())[5][0][0] is True
    finally:
        session.close()


def test_connections_that_come_and_go_leave_the_server_flat():
    srv = ServerProcess("--pacing", "immediate", renderers="on-demand")
    try:
        for _ in range(WARM_UP):
            _connection(srv.port)
        time.sleep(0.3)
        before = _rss_mb(srv.proc.pid)
        for _ in range(CONNECTIONS):
            _connection(srv.port)
        time.sleep(0.3)
        after = _rss_mb(srv.proc.pid)
        per = (after - before) / CONNECTIONS
        print(f"{CONNECTIONS} connections x 30 requests: server RSS {before:.0f} -> {after:.0f} MB "
              f"({per:.2f} MB per connection)")
        assert per < MB_PER_CONNECTION, (f"the server grew {after - before:.0f} MB over {CONNECTIONS} "
                                         f"connections ({per:.1f} MB each): {before:.0f} -> {after:.0f} MB")
        assert srv.proc.poll() is None
    finally:
        srv.stop()


def test_large_requests_give_their_memory_back():
    srv = ServerProcess("--pacing", "immediate")
    session = zenoh.open(client_config("127.0.0.1", srv.port))
    try:
        def ask(client: str, commands: list) -> bytes:
            replies = list(session.get(P.call_key("simx", client), payload=P.request(client, commands), timeout=60))
            assert len(replies) == 1 and replies[0].ok is not None
            return replies[0].ok.payload.to_bytes()

        rgb = P.unpack_response(ask("kept", [["GetObjectHandle", B, ["kinect_rgb"]]]))[5][0][1]
        ask("kept", [["GetVisionSensorImage", B, [rgb, 0]]])  # the renderer's buffers exist
        before = _rss_mb(srv.proc.pid)
        for mb in (1, 4, 10):
            big = "N" * (mb << 20)
            results = P.unpack_response(ask("kept", [["GetObjectHandle", B, [big]],
                                                     ["GetJointPosition", vrep.simx_opmode_oneshot, [big]]]))[5]
            assert [ok for ok, _ in results] == [False, False]
        ask("kept", [["GetVisionSensorImage", B, [rgb, 0]]] * 160)  # 147 MB: over the reply bound
        time.sleep(0.5)
        after = _rss_mb(srv.proc.pid)
        print(f"large requests: server RSS {before:.0f} -> {after:.0f} MB")
        assert after - before < LARGE_REQUESTS_MB, (f"the server kept {after - before:.0f} MB "
                                                    f"({before:.0f} -> {after:.0f})")
    finally:
        session.close()
        srv.stop()


def test_pack_large_makes_no_cyclic_garbage():
    message = [1, 2, [[True, b"\x01" * (2 << 20)], [True, {"k": b"\x02" * (1 << 20)}]]]
    gc.collect()
    gc.disable()
    try:
        data = pack_large(message)
        assert gc.collect() == 0, "pack_large left a reference cycle (it holds the message's images)"
    finally:
        gc.enable()
    assert data == P.pack(message)


def test_shared_memory_is_off_unless_the_operators_file_sets_it(tmp_path):
    assert zenoh_config(["tcp/127.0.0.1:7447"]).get_json("transport/shared_memory/enabled") == "false"
    plain = tmp_path / "plain.json5"
    plain.write_text('{mode: "router"}')
    assert zenoh_config(["tcp/127.0.0.1:7447"], plain).get_json("transport/shared_memory/enabled") == "false"
    shm = tmp_path / "shm.json5"
    shm.write_text("{transport: {shared_memory: {enabled: true}}}")
    assert zenoh_config(["tcp/127.0.0.1:7447"], shm).get_json("transport/shared_memory/enabled") == "true"


def test_malloc_is_tuned_unless_the_environment_sets_it():
    code = "from simx_server.legacy.allocator import tune_malloc; print(sorted(tune_malloc()))"
    env = {k: v for k, v in os.environ.items() if k not in ("MALLOC_ARENA_MAX", "MALLOC_MMAP_THRESHOLD_",
                                                             "MALLOC_TRIM_THRESHOLD_", "GLIBC_TUNABLES")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.strip() == "['arena_max', 'mmap_threshold', 'trim_threshold']"
    out = subprocess.run([sys.executable, "-c", code], env=dict(env, MALLOC_ARENA_MAX="8"), capture_output=True,
                         text=True, check=True).stdout
    assert out.strip() == "['mmap_threshold', 'trim_threshold']"


def test_a_renderer_s_offscreen_buffer_is_of_its_own_size():
    """After one sensor was set to 4096x4096 (the model's offwidth/offheight follow the largest
    sensor), a 640x480 renderer took a 4096x4096 offscreen buffer too (about 300 MB on
    llvmpipe; ten 4096x4096 streams left 1.1-1.5 GB of them)."""
    import mujoco

    from simx_server.cli import default_scene
    from simx_server.sim.render_thread import RenderThread

    model = mujoco.MjModel.from_xml_path(str(default_scene()))
    model.vis.global_.offwidth = model.vis.global_.offheight = 4096
    thread = RenderThread("simx-test-render")
    try:
        r = thread.executor.submit(thread.renderer, model, 640, 480).result(timeout=60)
        assert (r._mjr_context.offWidth, r._mjr_context.offHeight) == (640, 480)
        assert (model.vis.global_.offwidth, model.vis.global_.offheight) == (4096, 4096)  # left as it was
        big = thread.executor.submit(thread.renderer, model, 4096, 4096).result(timeout=60)
        assert (big._mjr_context.offWidth, big._mjr_context.offHeight) == (4096, 4096)
    finally:
        thread.executor.submit(thread.free).result(timeout=60)
        thread.executor.shutdown()
