"""Issue 12 part 4: the first streamed image is in the inbox within two simulation steps of the
``simx_opmode_streaming`` call, on a fresh server, after ``simxLoadScene`` (a new resolution)
and after a scene edit, as V-REP (which rendered its sensors every step) gave it.

Time is measured in simulation steps, not wall time: a second client, on the server's second
port, reads the simulation time with blocking calls (``simxGetLastCmdTime``) while the first
one polls ``simx_opmode_buffer``. A clock reading taken before a poll that still finds no
image proves that the image was not there at that simulation time.
"""

from __future__ import annotations

import time

import pytest

from conftest import ROOT, SCENE, ServerProcess, free_port, wait_until

vrep = pytest.importorskip("vrep")

DT_MS = 50  # the server's default dt
STREAMING, BUFFER, BLOCKING = vrep.simx_opmode_streaming, vrep.simx_opmode_buffer, vrep.simx_opmode_blocking


@pytest.fixture
def fresh():
    """A fresh server for each test (simulation running, dt 50 ms, at a quarter of real time)
    and two clients: the reader and the clock. The first test's claim is about a server no one
    has used yet, so the server is not shared between tests. The claim is in steps; a quarter
    of real time gives each step 200 ms of wall time, so that what is measured is when the image
    is rendered (the step after the call), not how slow the shared cores of a loaded test
    machine make llvmpipe."""
    srv = ServerProcess(str(SCENE), "--speed", "0.25", ports=[free_port(), free_port()])
    reader = vrep.simxStart("127.0.0.1", srv.ports[0], True, True, 5000, 5)
    clock = vrep.simxStart("127.0.0.1", srv.ports[1], True, True, 5000, 5)
    try:
        assert reader >= 0 and clock >= 0
        yield srv, reader, clock
    finally:
        for cid in (reader, clock):
            if cid >= 0:
                vrep.simxFinish(cid)
        srv.stop()


def sim_time(clock: int) -> int:
    """The server's simulation time now (ms), read with a blocking call."""
    rc, _ = vrep.simxGetBooleanParameter(clock, vrep.sim_boolparam_realtime_simulation, BLOCKING)
    assert rc == vrep.simx_return_ok
    return vrep.simxGetLastCmdTime(clock)


def first_frame_steps(reader: int, clock: int, handle: int, depth: bool = False) -> tuple[float, float, list]:
    """Start streaming ``handle``'s image (or depth buffer) and poll for it: ``(steps, wall s,
    resolution)``
    from the streaming call to the first clock reading that found it. Fails as soon as a poll
    finds nothing after more than two steps."""
    def read(mode):
        if depth:
            return vrep.simxGetVisionSensorDepthBuffer(reader, handle, mode)
        return vrep.simxGetVisionSensorImage(reader, handle, 0, mode)

    t0, w0 = sim_time(clock), time.monotonic()
    assert read(STREAMING)[0] == vrep.simx_return_novalue_flag
    while True:
        t = sim_time(clock)  # before the poll: a miss below proves the image was not there at t
        rc, res, img = read(BUFFER)
        if rc == vrep.simx_return_ok:
            break
        assert rc == vrep.simx_return_novalue_flag, rc
        assert t - t0 <= 2 * DT_MS, (
            f"no image yet {(t - t0) / DT_MS:.0f} steps ({time.monotonic() - w0:.3f} s) after the streaming call")
    assert len(img) == res[0] * res[1] * (1 if depth else 3)
    steps = (sim_time(clock) - t0) / DT_MS
    read(vrep.simx_opmode_discontinue)
    # Updates published before the server saw the discontinue may still be on their way: let
    # two steps pass, then a buffer read drops them, so that a later streaming call of the same
    # command starts from an empty inbox.
    t1 = sim_time(clock)
    wait_until(lambda: sim_time(clock) >= t1 + 2 * DT_MS, 5, what="two steps after the discontinue")
    assert read(BUFFER)[0] == vrep.simx_return_novalue_flag
    return steps, time.monotonic() - w0, res


def handle_of(cid: int, name: str) -> int:
    rc, h = vrep.simxGetObjectHandle(cid, name, BLOCKING)
    assert rc == vrep.simx_return_ok, name
    return h


def test_fresh_server_streams_each_camera_within_two_steps(fresh):
    srv, reader, clock = fresh
    # The simulation runs: the clock advances (a frozen clock would make the bound vacuous).
    start = sim_time(clock)
    assert wait_for_step(clock, start)
    rgb, depth = handle_of(reader, "kinect_rgb"), handle_of(reader, "kinect_depth")
    steps = [first_frame_steps(reader, clock, rgb), first_frame_steps(reader, clock, depth),
             first_frame_steps(reader, clock, rgb, depth=True)]
    print("first frames (steps, wall s):", steps)


def wait_for_step(clock: int, start: int) -> bool:
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        if sim_time(clock) > start:
            return True
    return False


def test_after_load_scene_and_edit_within_two_steps(fresh):
    """A new scene with another resolution (320x240), then an edit (the model recompiled),
    each while the simulation is stopped, as simxLoadScene requires."""
    srv, reader, clock = fresh
    assert vrep.simxStopSimulation(reader, BLOCKING) == vrep.simx_return_ok
    assert vrep.simxLoadScene(reader, str(ROOT / "scenes" / "cartpole.xml"), 0, BLOCKING) == vrep.simx_return_ok
    assert vrep.simxStartSimulation(reader, BLOCKING) == vrep.simx_return_ok
    camera = handle_of(reader, "camera")
    after_load = first_frame_steps(reader, clock, camera)
    assert after_load[2] == [320, 240]
    assert vrep.simxStopSimulation(reader, BLOCKING) == vrep.simx_return_ok
    rc, _ = vrep.simxCopyPasteObjects(reader, [handle_of(reader, "pole")], BLOCKING)
    assert rc == vrep.simx_return_ok
    assert vrep.simxStartSimulation(reader, BLOCKING) == vrep.simx_return_ok
    after_edit = first_frame_steps(reader, clock, camera)
    print("after load, after edit (steps, wall s):", after_load, after_edit)


def test_without_a_gl_platform_images_fail_cleanly(tmp_path):
    """Renderers made at load fail where there is no GL (GLFW without a display): logged once,
    and every image request then fails with the reason, without trying again (a second
    attempt aborted the process)."""
    import os
    import subprocess
    import sys

    script = tmp_path / "nogl.py"
    script.write_text(f"""
import logging
logging.basicConfig(level=logging.WARNING)
from simx_server.scene.simulation import Simulation
from simx_server.sim.render_thread import RenderError
sim = Simulation({str(SCENE)!r})
assert sim.vision.wait_ready(30)
handle = sorted(sim.vision.specs)[0]
for _ in range(2):
    try:
        sim.vision.image_bytes(handle, 0)
    except RenderError as exc:
        print("refused:", exc)
sim.close()
""")
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "glfw"
    done = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=60,
                          cwd=str(ROOT))
    if "cannot prepare the renderers" not in done.stderr:
        pytest.skip("GLFW renders here (a display or a GLFW that needs none)")
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.count("refused: vision sensors cannot render here") == 2, done.stdout
    assert done.stderr.count("cannot prepare the renderers") == 1
