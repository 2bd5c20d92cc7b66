"""V-REP's script styles on a real ``simx-server`` (issue 34): a client over Zenoh steps the
simulation (synchronous mode) and reads what the scene's own Lua scripts do.

* ``tests/scenes/bubblerob/``: V-REP 3.2's threaded BubbleRob script (``threaded=1``) drives the
  robot from its proximity sensor: ahead until the nose sees the wall, then back, until the
  simulation stops; started again, the thread starts afresh.
* A scene written here with one script of each other style: a pre-3.6 ``sim_call_type`` child
  script, a ``sysCall_threadmain`` thread looping on ``simWait`` / ``simSwitchThread``, and a
  customization script driving V-REP's old custom UI.
"""

from __future__ import annotations

import time

import pytest

from conftest import ROOT, ServerProcess
from test_legacy_scripts import OLD_STYLE
from test_scripts import small_scene

BUBBLEROB = ROOT / "tests" / "scenes" / "bubblerob" / "bubblerob.xml"


@pytest.fixture
def client():
    import vrep

    servers, cids = [], []

    def connect(scene) -> int:
        server = ServerProcess(str(scene), renderers="on-demand")
        servers.append(server)
        cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
        assert cid >= 0
        cids.append(cid)
        assert vrep.simxSynchronous(cid, True) == 0  # steps on our triggers: no wall-clock timing
        return cid

    yield connect
    for cid in cids:
        vrep.simxFinish(cid)
    for server in servers:
        server.stop()


def _int_signal(cid: int, name: str):
    import vrep

    rc, value = vrep.simxGetIntegerSignal(cid, name, vrep.simx_opmode_blocking)
    return value if rc == 0 else None


def test_bubblerob_threaded_script_drives_from_its_proximity_sensor_until_the_simulation_stops(client):
    import vrep

    B = vrep.simx_opmode_blocking
    cid = client(BUBBLEROB)
    rc, robot = vrep.simxGetObjectHandle(cid, "bubbleRob", B)
    assert rc == 0

    def x() -> float:
        rc, p = vrep.simxGetObjectPosition(cid, robot, -1, B)
        assert rc == 0
        return p[0]

    xs, first_detection = [], None
    for i in range(130):  # 6.5 s at the default 50 ms step
        assert vrep.simxSynchronousTrigger(cid) == 0
        xs.append(x())
        if first_detection is None and (_int_signal(cid, "detections") or 0) > 0:
            first_detection = i
    assert xs[40] > xs[0] + 0.2  # drove ahead toward the wall (x = 1) at about 0.16 m/s
    assert first_detection is not None, "the nose sensor never saw the wall"
    assert _int_signal(cid, "backing") == 1
    peak = max(xs)
    assert xs[-1] < peak - 0.02  # backed away from the wall after seeing it
    assert peak < 0.92  # never through the wall (its face at 0.98, the robot 0.06 m in radius)
    # Stopped, the thread is dropped (its loop never ends); started again, it begins afresh.
    assert vrep.simxStopSimulation(cid, B) == 0
    assert vrep.simxStartSimulation(cid, B) == 0
    for _ in range(3):
        assert vrep.simxSynchronousTrigger(cid) == 0
    assert _int_signal(cid, "detections") == 0 and x() < 0.1


THREADMAIN = """function sysCall_threadmain()
    simSetThreadAutomaticSwitch(false)
    local n=0
    while true do
        n=n+1
        simSetIntegerSignal('thread_passes', n)
        simWait(0.1)
        simSwitchThread()
    end
end
"""

CUSTOMIZATION = """if (sim_call_type==sim_customizationscriptcall_initialization) then
    ui=simGetUIHandle('BubbleRob_UI')
    simSetUIButtonLabel(ui, 1, 'speed')
end
if (sim_call_type==sim_customizationscriptcall_simulationsensing) then
    steps=(steps or 0)+1
    simSetIntegerSignal('custom_steps', steps)
    simSetIntegerSignal('ui_button', simGetUIEventButton(ui))
end
"""


def test_old_style_threaded_and_customization_scripts_on_a_server(client, tmp_path):
    scene = small_scene(tmp_path, {"Old": ("old.lua", OLD_STYLE), "Thread": ("thread.lua", THREADMAIN),
                                   "Custom": ("custom.lua", CUSTOMIZATION)})
    text = scene.read_text()
    scene.write_text(text.replace('data="child_script=custom.lua', 'data="customization_script=custom.lua'))
    cid = client(scene)
    for _ in range(10):  # 0.5 s
        import vrep

        assert vrep.simxSynchronousTrigger(cid) == 0
    steps = _int_signal(cid, "actuation")  # the old style's actuation passes: one per step
    assert steps >= 10 and _int_signal(cid, "or16") == 5
    # A pass every 3 steps (0.1 s of simWait, resumed every 0.05 s, then a simSwitchThread), the
    # first at the start; the server may have stepped before synchronous mode was enabled.
    assert abs(_int_signal(cid, "thread_passes") - (steps // 3 + 1)) <= 1
    assert _int_signal(cid, "custom_steps") >= 10 and _int_signal(cid, "ui_button") == -1


REMOTE_API_START = """function sysCall_threadmain()
    simRemoteApi.start({extra})  -- as the tutorial's UR5 script opens 19999 for its program
    simExtRemoteApiStart({same})  -- a port the server listens on already: a no-op
    while true do simSwitchThread() end
end
"""


def test_simExtRemoteApiStart_in_a_script_serves_the_legacy_api_on_that_port(tmp_path):
    import vrep

    from conftest import free_port

    own, extra = free_port(), free_port()
    scene = small_scene(tmp_path, {"UR5": ("ur5.lua", REMOTE_API_START.format(extra=extra, same=own))})
    server = ServerProcess(str(scene), ports=[own], renderers="on-demand")
    cid = -1
    try:
        # The request is acted on in the server's housekeeping (a few times a second), after the
        # script's first pass: until then nobody listens there and simxStart answers -1 at once,
        # so the program retries, as the tutorial's robotControl.py does.
        deadline = time.monotonic() + 30
        while cid < 0 and time.monotonic() < deadline:
            cid = vrep.simxStart("127.0.0.1", extra, True, True, 5000, 5)
            if cid < 0:
                time.sleep(0.2)
        assert cid >= 0, f"no server on the script's port {extra}"
        rc, h = vrep.simxGetObjectHandle(cid, "UR5", vrep.simx_opmode_blocking)
        assert rc == 0 and h > 0
        assert vrep.simxCallScriptFunction(cid, "UR5", vrep.sim_scripttype_childscript, "nothing", [], [], [],
                                           bytearray(), vrep.simx_opmode_blocking)[0] == 8  # same server
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        log = server.stop()
    assert f"simExtRemoteApiStart({own}): served already" in log
    assert f"simExtRemoteApiStart({extra}): the legacy remote API is served on tcp/127.0.0.1:{extra}" in log


NON_SIMULATION = """function sysCall_init() passes=0 end
function sysCall_nonSimulation()
    passes=passes+1
    sim.setIntegerSignal('idle_passes', passes)
end
"""


def test_customization_script_runs_its_non_simulation_passes_while_stopped(tmp_path):
    import vrep

    from conftest import wait_until

    scene = small_scene(tmp_path, {"Custom": ("idle.lua", NON_SIMULATION)})
    scene.write_text(scene.read_text().replace('data="child_script=idle.lua', 'data="customization_script=idle.lua'))
    server = ServerProcess(str(scene), "--stopped", renderers="on-demand")
    cid = -1
    try:
        cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
        assert cid >= 0
        first = wait_until(lambda: _int_signal(cid, "idle_passes"), what="a first sysCall_nonSimulation")
        wait_until(lambda: (_int_signal(cid, "idle_passes") or 0) > first, what="more sysCall_nonSimulation passes")
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        server.stop()
