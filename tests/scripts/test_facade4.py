"""The CoppeliaSim 4.x script API of the child scripts' ``sim`` facade (issue 12, part 7).

``tests/scenes/facade4/``: a scene whose ``Api`` (Lua, api.lua) and ``PyApi`` (Python, api.py)
scripts wrap each new call in a remote function; the in-process tests call them through
``Scripts.call`` on a :class:`Simulation` (deterministic steps) in both languages and check the
effect on the world; the remote test runs a real server with the issue's reproduction (a 4.x
step counter that a client waits for) and the scene edits a client then sees.
"""

from __future__ import annotations

import logging
import math
import re

import numpy as np
import pytest

from conftest import ROOT, SCENE, ServerProcess, wait_until
from simx_client.protocol import ArgumentError, ScriptError
from simx_server.sim import kinematics
from simx_server.api import SIM, script_sim
from simx_server.scene.simulation import Simulation

FACADE_FUNCTIONS = tuple(SIM)

SCENE4 = ROOT / "tests" / "scenes" / "facade4" / "facade4.xml"
CHILD = 1  # sim_scripttype_childscript
APIS = ["Api", "PyApi"]  # the same functions in Lua and in Python
G = 9.81
PAYLOAD_KG = 2.0
WALL_DISTANCE = 0.9  # m from the site "prox" to the near face of "wall"
CAMERA = (16, 12)


@pytest.fixture
def sim():
    s = Simulation(SCENE4, realtime=False, allow_python_scripts=True)
    s.start()
    yield s
    s.stop()
    s.close()


def call(sim: Simulation, api: str, function: str, ints=(), floats=(), strings=(), buffer=b""):
    return sim.scripts.call(api, CHILD, function, list(ints), [float(f) for f in floats], list(strings), buffer)


def handle(sim: Simulation, name: str) -> int:
    return sim.world.resolve(name).handle


# ------------------------------------------------------------------------- signals
@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_int32_float_and_string_signals_set_get_and_clear(sim, api):
    ints, floats, _, buf = call(sim, api, "signals", [42], [2.5], ["sig"], b"\x00bytes")
    assert ints == [42, 42, 1]  # read back, the 3.x name reads the same signal, all cleared
    assert floats == [2.5] and buf == b"\x00bytes"
    assert sim.signals.get_int("sig") is None


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("counter,signal", [("Counter", "steps"), ("PyCounter", "py_steps")])
def test_a_4x_step_counter_counts_steps(sim, counter, signal):
    for _ in range(3):
        sim.step()
    assert sim.signals.get_int(signal) == 3


# ------------------------------------------------------------------- scene edits
@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_create_dummy_then_set_object_name_keeps_handle_and_pose(sim, api):
    count = len(sim.world.objects)
    ints, pos, names, _ = call(sim, api, "dummy", [], [0.05, 1.0, 2.0, 3.0], ["ScriptDummy"])
    h = ints[0]
    assert ints == [h, h, h]  # getObjectHandle and the 4.x path lookup find the new name
    assert sim.world.resolve("ScriptDummy").handle == h and sim.world.get(h).type == 4  # a dummy
    assert len(sim.world.objects) == count + 1
    assert pos == pytest.approx([1.0, 2.0, 3.0])  # the position set before the rename stays
    assert names == ["ScriptDummy", "/ScriptDummy"]
    for _ in range(2):
        sim.step()  # the scene still runs, with the other scripts
    assert sim.world.position(h, -1) == pytest.approx([1.0, 2.0, 3.0])


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_set_object_alias_renames_a_joint_with_its_motor_settings_and_state(sim, api):
    joint = handle(sim, "Arm_joint")
    sim.world.set_joint_position(joint, 0.7)
    sim.world.set_joint_target_velocity(joint, 0.5)
    ints, _, strings, _ = call(sim, api, "alias", [joint], [], ["elbow joint!"])
    assert strings == ["elbow_joint_"]  # CoppeliaSim replaces illegal characters with '_'
    assert ints == [joint]  # found again by its full path
    obj = sim.world.resolve("elbow_joint_")
    assert obj.handle == joint and "Arm_joint" not in sim.world.by_name
    assert obj.settings.get("mode") == "velocity"  # its simx: settings followed it
    assert sim.world.joint_position(joint) == pytest.approx(0.7)
    sim.step()  # its actuator followed it too: it turns at the target velocity kept
    assert sim.world.joint_position(joint) > 0.7 + 0.5 * 0.05 * 0.5


def test_renamed_sensors_camera_and_script_object_keep_working(sim):
    facade = script_sim(sim.world, handle(sim, "PyApi"), sim.signals, simulation=sim)
    for old, new in [("ft", "FT2"), ("prox", "Prox2"), ("cam", "Cam2"), ("payload", "Payload2"), ("Api", "Api2")]:
        h = handle(sim, old)
        facade.setObjectAlias(h, new)
        assert handle(sim, new) == h
    sim.step()
    assert facade.readForceSensor(handle(sim, "FT2"))[1][2] == pytest.approx(-PAYLOAD_KG * G, rel=0.01)  # its weight, along gravity
    assert facade.readProximitySensor(handle(sim, "Prox2"))[1] == pytest.approx(WALL_DISTANCE)
    assert facade.getVisionSensorImg(handle(sim, "Cam2"))[1] == list(CAMERA)
    assert call(sim, "Api2", "state")[0][0] == 0x11  # the renamed object's script runs on


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_set_object_parent_moves_the_subtree_in_place(sim, api):
    hand, holder, arm = handle(sim, "Hand"), handle(sim, "Holder"), handle(sim, "Arm")
    before = sim.world.position(hand, -1)
    ints, pos, _, _ = call(sim, api, "parent", [hand, holder, 1])
    assert ints == [holder] and sim.world.get(hand).parent == holder
    assert pos == pytest.approx(before, abs=1e-9)
    assert sim.world.get(handle(sim, "Tip")).parent == hand  # the site went with its body
    ints, _, _, _ = call(sim, api, "parent", [hand, arm, 0])  # back, keeping the local pose
    assert ints == [arm]


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_bad_names_and_sizes_answer_errors_and_change_nothing(sim, api):
    count = len(sim.world.objects)
    with pytest.raises(ScriptError, match=r"(sim\.setObjectName|ArgumentError): object name 'a/b' must be"):
        call(sim, api, "dummy", [], [0.05, 0, 0, 0], ["a/b"])
    with pytest.raises(ScriptError, match=r"name 'Holder' is taken by another object"):
        call(sim, api, "alias", [handle(sim, "Hand")], [], ["Holder"])
    with pytest.raises(ScriptError, match=r"(sim\.createDummy|ArgumentError): dummy size must be positive"):
        call(sim, api, "dummy", [], [-1, 0, 0, 0], ["Fine"])
    # the first call created its dummy before the rename failed, as in CoppeliaSim
    assert len(sim.world.objects) == count + 1
    assert sim.world.resolve("Hand").handle and sim.world.resolve("Holder").handle


# ------------------------------------------------------------------------ poses
@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_object_matrix_get_and_set_in_both_argument_orders(sim, api):
    tip = handle(sim, "Tip")
    _, m, _, _ = call(sim, api, "getMatrix", [tip, -1])
    p, r = sim.world.frame(tip)
    assert np.array(m).reshape(3, 4) == pytest.approx(np.hstack([r, p[:, None]]), abs=1e-6)
    cube = handle(sim, "Cube")
    c, s = math.cos(0.3), math.sin(0.3)
    target = [c, -s, 0, 1.0, s, c, 0, 2.0, 0, 0, 1, 3.0]  # 0.3 rad about z, at (1, 2, 3)
    for order in (0, 1):
        _, got, _, _ = call(sim, api, "setMatrix", [cube, order], target)
        assert got == pytest.approx(target, abs=1e-5)
        assert sim.world.orientation(cube, -1) == pytest.approx([0, 0, 0.3], abs=1e-6)
    with pytest.raises(ScriptError, match="not a rotation"):
        call(sim, api, "setMatrix", [cube, 0], [2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0])


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_poses_in_coppeliasim_4_5_argument_order(sim, api):
    cube = handle(sim, "Cube")
    _, got, _, _ = call(sim, api, "pose45", [cube], [1.0, 2.0, 3.0, 0.4])
    assert got == pytest.approx([1, 2, 3, 0, 0, 0.4], abs=1e-6)
    assert sim.world.position(cube, -1) == pytest.approx([1, 2, 3])


@pytest.mark.renderers_on_demand  # no image read
def test_renamed_free_and_mocap_bodies_keep_their_state(sim):
    facade = script_sim(sim.world, handle(sim, "PyApi"), sim.signals, simulation=sim)
    cube, mark = handle(sim, "Cube"), handle(sim, "Mark")
    facade.setObjectPosition(mark, [1.5, -2.5, 0.5])  # a mocap pose, set at run time
    for _ in range(3):
        sim.step()
    pos, vel = sim.world.position(cube, -1), kinematics.object_velocity(sim, cube)[0]
    facade.setObjectName(cube, "Box7")
    facade.setObjectAlias(mark, "Marker")
    assert sim.world.resolve("Box7").handle == cube and sim.world.resolve("Marker").handle == mark
    assert sim.world.position(cube, -1) == pytest.approx(pos)
    assert kinematics.object_velocity(sim, cube)[0] == pytest.approx(vel)
    assert sim.world.position(mark, -1) == pytest.approx([1.5, -2.5, 0.5])
    sim.step()  # still falling, from where it was
    assert kinematics.object_velocity(sim, cube)[0][2] == pytest.approx(vel[2] - G * sim.world.dt, rel=0.01)
    dummy = facade.createDummy()  # CoppeliaSim 4's default size
    assert sim.world.model.site_size[sim.world.get(dummy).mj_id][0] == pytest.approx(0.0025)


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_object_velocity_of_a_falling_body(sim, api):
    cube = handle(sim, "Cube")
    for _ in range(4):
        sim.step()
    _, vw, _, _ = call(sim, api, "velocity", [cube])
    t = sim.world.time
    assert vw[2] == pytest.approx(-G * t, rel=0.01)
    v, w = kinematics.object_velocity(sim, cube)
    assert vw == pytest.approx(v.tolist() + w.tolist())


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_objects_in_tree(sim, api):
    joint, arm, hand, tip = (handle(sim, n) for n in ("Arm_joint", "Arm", "Hand", "Tip"))
    all_ = -2  # sim.handle_all
    assert call(sim, api, "tree", [joint, all_, 0])[0] == [joint, arm, hand, tip]
    assert call(sim, api, "tree", [joint, all_, 1])[0] == [arm, hand, tip]  # bit 0: without the base
    assert call(sim, api, "tree", [arm, all_, 2])[0] == [arm, hand]  # bit 1: first children only
    assert call(sim, api, "tree", [joint, 4, 0])[0] == [tip]  # dummies only
    scene = call(sim, api, "tree", [-12, all_, 0])[0]  # sim.handle_scene
    assert sorted(scene) == sorted(sim.world.objects)


def test_objects_in_tree_lists_the_ur5(tmp_path):
    s = Simulation(SCENE, realtime=False)
    try:
        w = s.world
        facade = script_sim(w, w.resolve("UR5").handle, s.signals, simulation=s)
        tree = facade.getObjectsInTree(w.resolve("UR5").handle)
        names = [w.get(h).name for h in tree]
        assert names[0] == "UR5"
        joints = [n for n, h in zip(names, tree) if w.get(h).type == 1]
        assert joints[:6] == [f"UR5_joint{i}" for i in range(1, 7)]  # in kinematic order
        assert "RG2_openCloseJoint" in joints and "kinect_rgb" in names  # gripper and camera hang below
        assert names.index("RG2") > names.index("UR5_link6") and "Table" not in names
        assert set(tree) == {h for h in w.objects if _below(w, h, tree[0])}
    finally:
        s.close()


def _below(world, h, base) -> bool:
    while h != -1:
        if h == base:
            return True
        h = world.get(h).parent
    return False


# ------------------------------------------------------------------------ forces
@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_add_force_and_torque_acts_for_one_step(sim, api):
    cube = handle(sim, "Cube")
    dt = sim.world.dt
    call(sim, api, "force", [cube, 0], [0, 0, 2 * G, 0, 0, 0])  # twice its weight, up
    sim.step()
    v1 = kinematics.object_velocity(sim, cube)[0][2]
    assert v1 == pytest.approx(G * dt, rel=0.02)  # it rose
    sim.step()  # the force is gone: gravity alone
    assert kinematics.object_velocity(sim, cube)[0][2] == pytest.approx(v1 - G * dt, abs=0.01)


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_add_force_off_centre_turns_the_body(sim, api):
    cube = handle(sim, "Cube")
    dt = sim.world.dt
    call(sim, api, "force", [cube, 1], [0.05, 0, 0, 0, 10, 0])  # 10 N along y, 5 cm along x
    call(sim, api, "force", [cube, 1], [0.05, 0, 0, 0, 10, 0])  # forces add up: 20 N
    sim.step()
    v, w = kinematics.object_velocity(sim, cube)
    izz = sim.world.model.body_inertia[sim.world.get(cube).mj_id][2]
    assert v[1] == pytest.approx(20 * dt, rel=0.02)
    assert w[2] == pytest.approx(20 * 0.05 * dt / izz, rel=0.05)
    with pytest.raises(ScriptError, match="'Holder' is static"):
        call(sim, api, "force", [handle(sim, "Holder"), 0], [0, 0, 1, 0, 0, 0])
    with pytest.raises(ScriptError, match=r"within \+/-1e\+08 N .*MAX_SCRIPT_FORCE"):
        call(sim, api, "force", [cube, 0], [0, 0, 0, 1e9, 0, 0])
    sim.step()  # the refused torque was not applied
    assert kinematics.object_velocity(sim, cube)[1][0] == pytest.approx(0.0, abs=1e-9)


# ----------------------------------------------------------------------- sensors
@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_read_force_sensor_weighs_the_payload(sim, api):
    for _ in range(2):
        sim.step()
    ints, ft, _, _ = call(sim, api, "readForce", [handle(sim, "ft")])
    assert ints == [1]  # data available
    assert np.linalg.norm(ft[:3]) == pytest.approx(PAYLOAD_KG * G, rel=0.01)
    with pytest.raises(ScriptError, match="not a force sensor"):
        call(sim, api, "readForce", [handle(sim, "Tip")])


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_read_proximity_sensor_sees_the_wall(sim, api):
    ints, f, _, _ = call(sim, api, "readProx", [handle(sim, "prox")])
    assert ints == [1, handle(sim, "wall")]
    assert f[0] == pytest.approx(WALL_DISTANCE, abs=1e-6)  # distance
    assert f[1:4] == pytest.approx([0, 0, WALL_DISTANCE], abs=1e-6)  # point, sensor frame
    assert f[4:7] == pytest.approx([0, 0, -1], abs=1e-6)  # the face looks back at the sensor


@pytest.mark.parametrize("api", APIS)
def test_vision_sensor_images(sim, api):
    cam = handle(sim, "cam")
    w, h = CAMERA
    ints, f, _, img = call(sim, api, "image", [cam, 0])
    assert ints == [w, h, w * h * 3, w * h]
    assert img == sim.vision.image(cam, False).tobytes()  # the same image as simxGetVisionSensorImage's
    assert f[0] == pytest.approx(img[0] / 255) and f[0] > 0.3 > f[1]  # the red plate, as 0..1 floats
    grey = call(sim, api, "image", [cam, 1])[3]
    assert grey == sim.vision.image(cam, True).tobytes() and len(grey) == w * h


def test_vision_sensor_image_windows(sim):
    cam = handle(sim, "cam")
    facade = script_sim(sim.world, handle(sim, "PyApi"), sim.signals, simulation=sim)
    full = sim.vision.image(cam, False)
    img, res = facade.getVisionSensorImg(cam, 0, 0, [2, 3], [4, 5])  # from the bottom left corner
    assert res == [4, 5] and img == full[3:8, 2:6].tobytes()
    values = facade.getVisionSensorImage(cam, 2, 3, 4, 5)
    assert values == pytest.approx((full[3:8, 2:6].reshape(-1) / 255).tolist())
    assert facade.getVisionSensorImage(cam, 0, 0, 0, 0, 1) == full.tobytes()  # returnType 1: bytes
    with pytest.raises(ArgumentError, match="not inside the 16x12 image"):
        facade.getVisionSensorImg(cam, 0, 0, [10, 0], [8, 1])
    with pytest.raises(ArgumentError, match="pos must be a table of 2 integers"):
        facade.getVisionSensorImg(cam, 0, 0, [1, 2, 3])


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_object_int32_and_float_params(sim, api):
    joint = handle(sim, "Arm_joint")
    ints, floats, _, _ = call(sim, api, "params", [joint, 2001, 2017])
    assert ints == [0, 1, 0, 1, 0, 0]  # velocity mode: control loop off; unknown parameter: result 0
    ints, floats, _, _ = call(sim, api, "params", [joint, 2001, 2017, 1], [2.5])
    assert ints[:3] == [1, 1, 1] and floats == [2.5, 2.5]
    assert sim.world.mode[sim.world.motor(joint)] == 0  # position control now
    assert sim.world.max_velocity[sim.world.motor(joint)] == 2.5


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api,init", [("Api", "lua_init_state"), ("PyApi", "py_init_state")])
def test_simulation_state(sim, api, init, caplog):
    assert sim.signals.get_int(init) == 0x10  # sysCall_init: advancing, first after stop
    ints = call(sim, api, "state")[0]
    assert ints == [0x11, 0x11, 0x08, 0]
    sim.pause()
    assert call(sim, api, "state")[0][0] == 0x08
    with caplog.at_level(logging.INFO, logger="simx.scripts"):
        sim.stop()
    states = [r.getMessage().split()[-1] for r in caplog.records if "cleanup state" in r.getMessage()]
    assert states == ["22", "22"]  # both scripts' sysCall_cleanup: advancing, last before stop (0x16)


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api", APIS)
def test_get_object_relative_to_the_script(sim, api):
    link, tip = f"{api}Link", f"{api}Tip"
    assert call(sim, api, "relative", [], [], [f"{link}/{tip}"])[0] == [handle(sim, tip)]
    assert call(sim, api, "relative", [], [], [tip])[0] == [handle(sim, tip)]  # anywhere below
    assert call(sim, api, "relative", [], [], [f"{tip}/{link}"])[0] == [-1]  # wrong order
    assert call(sim, api, "relative", [], [], ["Tip"])[0] == [-1]  # exists, but not below the script
    facade = script_sim(sim.world, handle(sim, api), sim.signals, simulation=sim)
    assert facade.getObject("/Holder", {"index": 0}) == handle(sim, "Holder")
    assert facade.getObject("/Holder", {"index": 1, "noError": True}) == -1  # names are unique


@pytest.mark.renderers_on_demand  # no image read
@pytest.mark.parametrize("api,language", [("Api", "lua"), ("PyApi", "py")])
def test_unknown_calls_fail_naming_the_function(sim, api, language):
    pattern = rf"api\.{language}:\d+: .*sim\.launchExecutable is not available in simx"
    with pytest.raises(ScriptError, match=pattern):
        call(sim, api, "unknown")


def test_every_facade_function_is_listed_in_docs():
    text = (ROOT / "docs" / "SCRIPTS.md").read_text() + (ROOT / "docs" / "COVERAGE.md").read_text()
    missing = [n for n in FACADE_FUNCTIONS if not re.search(rf"\b{n}\b", text)]
    assert not missing, f"docs/SCRIPTS.md and docs/COVERAGE.md do not list {missing}"


# ------------------------------------------------------------------------ remote
def test_remote_4x_counter_signal_and_scene_edits_seen_by_a_client():
    """The issue's reproduction: a client waits for a 4.x step counter's signal (streaming, then
    buffer reads); then a script's createDummy + setObjectName and setObjectParent, seen through
    simxGetObjectHandle / simxGetObjectParent; an unknown call answers remote error 8."""
    import vrep

    server = ServerProcess(str(SCENE4), renderers="on-demand")
    log = ""
    try:
        cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
        assert cid >= 0
        try:
            vrep.simxGetIntegerSignal(cid, "steps", vrep.simx_opmode_streaming)

            def counted():
                rc, n = vrep.simxGetIntegerSignal(cid, "steps", vrep.simx_opmode_buffer)
                return rc == vrep.simx_return_ok and n >= 3

            wait_until(counted, timeout=10, what="the 4.x step counter's signal 'steps'")
            blocking = vrep.simx_opmode_blocking
            rc, ints, _, _, _ = vrep.simxCallScriptFunction(cid, "Api", CHILD, "dummy", [], [0.05, 1, 2, 3],
                                                            ["ScriptDummy"], bytearray(), blocking)
            assert rc == 0
            rc, h = vrep.simxGetObjectHandle(cid, "ScriptDummy", blocking)
            assert rc == 0 and h == ints[0]
            rc, pos = vrep.simxGetObjectPosition(cid, h, -1, blocking)
            assert rc == 0 and pos == pytest.approx([1, 2, 3], abs=1e-5)
            hand = vrep.simxGetObjectHandle(cid, "Hand", blocking)[1]
            holder = vrep.simxGetObjectHandle(cid, "Holder", blocking)[1]
            arm = vrep.simxGetObjectHandle(cid, "Arm", blocking)[1]
            assert vrep.simxGetObjectParent(cid, hand, blocking) == (0, arm)
            rc, ints, _, _, _ = vrep.simxCallScriptFunction(cid, "PyApi", CHILD, "parent", [hand, holder, 1], [],
                                                            [], bytearray(), blocking)
            assert rc == 0 and ints == [holder]
            assert vrep.simxGetObjectParent(cid, hand, blocking) == (0, holder)
            rc = vrep.simxCallScriptFunction(cid, "Api", CHILD, "unknown", [], [], [], bytearray(), blocking)[0]
            assert rc == vrep.simx_return_remote_error_flag
        finally:
            vrep.simxFinish(cid)
    finally:
        log = server.stop()
    assert "not available in simx" not in log.split("sim.launchExecutable")[0]  # no error before it
    assert re.search(r"simxCallScriptFunction failed: .*api\.lua:\d+: sim\.launchExecutable is not available", log)
