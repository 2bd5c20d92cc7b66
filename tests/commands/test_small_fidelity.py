"""Issue 12, part 8: the headless mouse (CoppeliaSim's simpleTest.py) and names that MJCF
elements of different kinds share (a camera and a body both named ``head``).

The shared-names scene is tests/scenes/shared_names.xml (its comment lists the layout).
"""

from __future__ import annotations

import logging
from pathlib import Path

import mujoco
import numpy as np
import pytest

import vrep
from conftest import ServerProcess, free_port, wait_until
from simx_server.sim.world import DUMMY, JOINT, LIGHT, SHAPE, VISION_SENSOR, World

SHARED = Path(__file__).resolve().parents[1] / "scenes" / "shared_names.xml"
B, STREAM, BUFFER = vrep.simx_opmode_blocking, vrep.simx_opmode_streaming, vrep.simx_opmode_buffer
MOUSE_X, MOUSE_Y, MOUSE_BUTTONS = 22, 23, 31  # vrepConst.py

#: V-REP name -> (type, MJCF kind, MJCF name) by the rule joint > body > site > camera > light.
EXPECTED = {
    "head": (SHAPE, "body", "head"),
    "head#0": (DUMMY, "site", "head"),
    "head#1": (VISION_SENSOR, "camera", "head"),
    "ball": (SHAPE, "body", "ball"),
    "ball#0": (LIGHT, "light", "ball#0"),  # the scene's own name, which the camera must skip
    "ball#1": (VISION_SENSOR, "camera", "ball"),
    "hand": (SHAPE, "body", "hand"),
    "hand#0": (VISION_SENSOR, "camera", "hand"),
    "slider": (JOINT, "joint", "slider"),
    "slider#0": (SHAPE, "body", "slider"),
    "eye": (VISION_SENSOR, "camera", "eye"),
    "neck": (JOINT, "joint", "neck"),
    "torso": (SHAPE, "body", "torso"),
}


# ----------------------------------------------------------------------- the mouse
def test_mouse_is_a_fixed_point_as_simple_test_reads_it(vrep_client):
    """simpleTest.py's loop: stream sim_intparam_mouse_x, then read the buffer until a value
    comes; a headless server's mouse sits at (0, 0) with no button pressed, and stays there."""
    cid = vrep_client
    assert vrep.sim_intparam_mouse_x == MOUSE_X
    assert vrep.sim_intparam_mouse_y == MOUSE_Y and vrep.sim_intparam_mouse_buttons == MOUSE_BUTTONS
    rc, _ = vrep.simxGetIntegerParameter(cid, MOUSE_X, STREAM)
    assert rc in (vrep.simx_return_ok, vrep.simx_return_novalue_flag)
    first = wait_until(lambda: (r := vrep.simxGetIntegerParameter(cid, MOUSE_X, BUFFER))[0] == 0 and r,
                       timeout=10, what="a streamed mouse_x value")
    assert first == (0, 0)
    # the stream is evaluated after every step: let steps pass, the mouse does not move
    assert vrep.simxStartSimulation(cid, B) == 0
    try:
        t0 = vrep.simxGetLastCmdTime(cid)
        wait_until(lambda: vrep.simxGetIntegerParameter(cid, MOUSE_X, BUFFER)[0] == 0
                   and vrep.simxGetLastCmdTime(cid) > t0 + 200, timeout=10, what="a few steps")
        for _ in range(5):
            assert vrep.simxGetIntegerParameter(cid, MOUSE_X, BUFFER) == (0, 0)
    finally:
        assert vrep.simxStopSimulation(cid, B) == 0
        vrep.simxGetIntegerParameter(cid, MOUSE_X, vrep.simx_opmode_discontinue)
    assert vrep.simxGetIntegerParameter(cid, MOUSE_X, B) == (0, 0)
    assert vrep.simxGetIntegerParameter(cid, MOUSE_Y, B) == (0, 0)
    assert vrep.simxGetIntegerParameter(cid, MOUSE_BUTTONS, B) == (0, 0)
    assert vrep.simxGetInt32Param(cid, MOUSE_Y, B) == (0, 0)
    # read-only, as in V-REP: nobody moves the mouse of a headless server
    for pid in (MOUSE_X, MOUSE_Y, MOUSE_BUTTONS):
        assert vrep.simxSetIntegerParameter(cid, pid, 5, B) == vrep.simx_return_remote_error_flag
        assert vrep.simxGetIntegerParameter(cid, pid, B) == (0, 0)


# -------------------------------------------------------------------- shared names
def test_every_named_element_gets_an_object_by_the_documented_rule(caplog):
    with caplog.at_level(logging.DEBUG, logger="simx.world"):
        world = World(SHARED)
    m = world.model
    names = {o.name: o for o in world.objects.values()}
    assert set(names) == set(EXPECTED)
    total = m.njnt - 1 + m.nbody - 1 + m.nsite + m.ncam + m.nlight  # every named element (the free joint has no name)
    assert len(world.objects) == total == len(EXPECTED)
    for vname, (otype, kind, mj_name) in EXPECTED.items():
        obj = world.resolve(vname)
        assert obj.type == otype, vname
        table = getattr(mujoco.mjtObj, f"mjOBJ_{kind.upper()}")
        assert mujoco.mj_id2name(m, table, obj.mj_id) == mj_name, vname
        assert world.resolve(vname + "#") is obj  # "name#" means "name", as for every object
    # the renamed camera sits where the MJCF camera is: on torso, not on the body "head"
    assert world.objects[world.resolve("head#1").parent].name == "torso"
    assert world.objects[world.resolve("hand#0").parent].name == "hand"
    # one warning line counts the renamed elements, one DEBUG line names each; none says "used twice"
    lines = [r.getMessage() for r in caplog.records if "share a name" in r.getMessage()]
    assert len(lines) == 1 and "5 MJCF element(s)" in lines[0], lines
    details = [r.getMessage() for r in caplog.records if r.levelno == logging.DEBUG and "V-REP object" in r.getMessage()]
    assert len(details) == 5, details
    for kind, mj_name, vname in (("site", "head", "head#0"), ("camera", "head", "head#1"), ("camera", "ball", "ball#1"),
                                 ("camera", "hand", "hand#0"), ("body", "slider", "slider#0")):
        assert any(f"MJCF {kind} {mj_name!r} is the V-REP object {vname!r}" in d for d in details), (vname, details)
    assert "'eye'" not in lines[0] + "".join(details) and "used twice" not in caplog.text


def test_names_are_stable_across_a_rebuild():
    """Handles and V-REP names stay as they were when the model is swapped in again (scene
    editing rebuilds the registry)."""
    world = World(SHARED)
    before = {o.name: o.handle for o in world.objects.values()}
    world.replace_model(world.model)
    assert {o.name: o.handle for o in world.objects.values()} == before


def test_edits_keep_the_names_of_the_objects_still_there(caplog):
    """Removing the body ``head`` frees the name, but the site and the camera keep ``head#0``
    and ``head#1`` (and their handles); a copy of a body gets a name free among the V-REP names,
    so the handle it answers is the copy's."""
    from simx_server.commands import HANDLERS
    from simx_server.scene.simulation import Simulation

    sim = Simulation(SHARED, dt=0.05, realtime=False)
    try:
        world = sim.world
        before = {o.name: o.handle for o in world.objects.values()}
        caplog.clear()
        with caplog.at_level(logging.DEBUG, logger="simx.world"):
            (copy,) = HANDLERS["CopyPasteObjects"](sim, [[before["hand"]]])
        obj = world.get(copy)
        assert obj.type == SHAPE and obj.name == "hand#1" and copy not in before.values()
        assert world.resolve("hand#0").handle == before["hand#0"]  # the camera keeps its name
        # the copy of the camera shares the copied body's name in the MJCF too: renamed, told once
        assert world.resolve("hand#1#0").type == VISION_SENSOR
        (line,) = [r.getMessage() for r in caplog.records if "share a name" in r.getMessage()]
        assert "6 MJCF element(s)" in line
        assert "MJCF camera 'hand#1' is the V-REP object 'hand#1#0'" in caplog.text
        (head_copy,) = HANDLERS["CopyPasteObjects"](sim, [[before["head"]]])
        assert world.get(head_copy).name == "head#2" and world.get(head_copy).type == SHAPE
        caplog.clear()
        with caplog.at_level(logging.INFO, logger="simx.world"):
            HANDLERS["RemoveObject"](sim, [before["head"]])
        after = {o.name: o.handle for o in world.objects.values()}
        gone = {"head", "neck"}  # the body and the joint in it
        assert {n: h for n, h in before.items() if n not in gone}.items() <= after.items()
        assert not gone & set(after)
        assert not [r for r in caplog.records if "share" in r.getMessage()]  # nothing new to tell
    finally:
        sim.close()


def test_a_scene_without_shared_names_logs_nothing_about_them(caplog):
    from conftest import SCENE
    with caplog.at_level(logging.INFO, logger="simx.world"):
        World(SCENE)
    assert not [r for r in caplog.records if "share" in r.getMessage()]


def test_shared_names_over_the_remote_api():
    """A real server: the body and the camera named ``head`` are both reachable, the camera
    serves images, and the server logs the renaming once."""
    srv = ServerProcess(str(SHARED), ports=[free_port()])
    log = ""
    try:
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        try:
            rc, head = vrep.simxGetObjectHandle(cid, "head", B)
            assert rc == 0
            rc, cam = vrep.simxGetObjectHandle(cid, "head#1", B)
            assert rc == 0 and cam != head
            rc, hand_cam = vrep.simxGetObjectHandle(cid, "hand#0", B)
            assert rc == 0
            # the body is a shape: it has a position; it is not a vision sensor
            rc, pos = vrep.simxGetObjectPosition(cid, head, -1, B)
            assert rc == 0 and np.allclose(pos, [0.35, 0, 0.6], atol=1e-6)
            assert vrep.simxGetVisionSensorImage(cid, head, 0, B)[0] == vrep.simx_return_remote_error_flag
            # the camera is a vision sensor of the MJCF camera's resolution, and sees the scene
            rc, res, image = vrep.simxGetVisionSensorImage(cid, cam, 0, B)
            assert rc == 0 and res == [32, 24] and len(image) == 32 * 24 * 3
            assert len(set(image)) > 1
            rc, res, _ = vrep.simxGetVisionSensorImage(cid, hand_cam, 1, B)
            assert rc == 0 and res == [8, 6]
            # group data lists both, with their V-REP names and types
            rc, handles, ints, _, strings = vrep.simxGetObjectGroupData(cid, vrep.sim_handle_all, 0, B)
            assert rc == 0 and sorted(strings) == sorted(EXPECTED)
            rc, handles, types, _, _ = vrep.simxGetObjectGroupData(cid, vrep.sim_handle_all, 1, B)
            by_handle = dict(zip(handles, types))
            assert by_handle[head] == SHAPE and by_handle[cam] == VISION_SENSOR
        finally:
            vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    lines = [line for line in log.splitlines() if "share" in line]
    assert len(lines) == 1, log
    assert "'head' camera -> 'head#1'" in lines[0] and "used twice" not in log


@pytest.mark.parametrize("name", ["head#2", "ball#2", "hand#1", "eye#0"])
def test_suffixes_beyond_the_rule_are_unknown(name):
    world = World(SHARED)
    with pytest.raises(Exception, match="does not exist"):
        world.resolve(name)


def test_the_log_line_is_bounded():
    from simx_server.base import limits
    from simx_server.sim import naming

    many = [naming.Renamed(f"n{i}", "camera", f"n{i}#0") for i in range(3 * limits.MAX_RENAMES_LOGGED)]
    line = naming.describe("big.xml", many, limits.MAX_RENAMES_LOGGED)
    assert line.count("camera ->") == limits.MAX_RENAMES_LOGGED
    assert line.endswith(f"and {2 * limits.MAX_RENAMES_LOGGED} more (--log-level DEBUG lists each)")
    assert f"{3 * limits.MAX_RENAMES_LOGGED} MJCF element(s)" in line
