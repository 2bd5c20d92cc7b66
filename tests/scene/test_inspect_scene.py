"""``simx-server --list-objects``: the scene as V-REP's hierarchy shows it, as the server maps it."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

import vrep
from conftest import ROOT, SCENE
from simx_server.scene.listing import describe

SHARED_NAMES = ROOT / "tests" / "scenes" / "shared_names.xml"


def _list(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "simx_server.cli", "--list-objects", *args],
                          capture_output=True, text=True, timeout=60)


@pytest.fixture(scope="module")
def ur5():
    return {o["name"]: o for o in describe(SCENE)["objects"]}


def test_joints_carry_the_scenes_motor_settings(ur5):
    j1 = ur5["UR5_joint1"]
    assert (j1["type"], j1["joint_type"]) == (vrep.sim_object_joint_type, "revolute")
    assert j1["max_force"] == 150.0 and j1["max_velocity"] == pytest.approx(math.pi)  # forcerange, simx: text
    assert j1["motor_enabled"] and j1["control_loop"]  # mode=position
    assert ur5["UR5_joint4"]["max_force"] == 28.0
    grip = ur5["RG2_openCloseJoint"]  # mode=velocity max_velocity=0.5, forcerange 40
    assert (grip["joint_type"], grip["motor_enabled"], grip["control_loop"]) == ("prismatic", True, False)
    assert (grip["max_force"], grip["max_velocity"], grip["range"]) == (40.0, 0.5, [0.0, 0.055])
    follower = ur5["RG2_fingerJoint2"]  # no actuator in the scene: simx's added motor, off
    assert not follower["motor_enabled"] and follower["actuator"] == "simx_motor:RG2_fingerJoint2"


def test_vision_sensors_and_child_script(ur5):
    rgb, depth = ur5["kinect_rgb"], ur5["kinect_depth"]
    assert rgb["type"] == vrep.sim_object_visionsensor_type
    assert (rgb["resolution"], rgb["image"], rgb["near"], rgb["far"]) == ([640, 480], "rgb", 0.01, 3.5)
    assert depth["image"] == "depth"
    # fovy 44.32 deg vertical at 4:3: V-REP's perspective angle is the horizontal one, the larger
    assert rgb["view_angle"] == pytest.approx(2 * math.atan(math.tan(math.radians(44.32 / 2)) * 4 / 3))
    assert ur5["RG2"]["child_script"] == {"file": "rg2.lua", "language": "Lua"}
    assert ur5["Sphere"]["body"] == "free" and ur5["sun"]["light"] == "directional"


def test_the_tree_nests_the_arm_chain_as_v_rep_does(ur5):
    chain = ["UR5", "UR5_joint1", "UR5_link1", "UR5_joint2", "UR5_link2", "UR5_joint3", "UR5_link3",
             "UR5_joint4", "UR5_link4", "UR5_joint5", "UR5_link5", "UR5_joint6", "UR5_link6", "RG2", "kinect",
             "kinect_rgb"]
    for parent, child in zip(chain, chain[1:]):
        assert ur5[child]["parent"] == ur5[parent]["handle"], child
        assert ur5[child]["depth"] == ur5[parent]["depth"] + 1
    assert ur5["UR5"]["parent"] == -1 and ur5["UR5"]["depth"] == 0


def test_listing_matches_what_a_running_server_reports(vrep_client, ur5):
    """Handles, names, types and parents as simxGetObjectGroupData gives them."""
    cid, block = vrep_client, vrep.simx_opmode_blocking
    rc, handles, _, _, names = vrep.simxGetObjectGroupData(cid, vrep.sim_appobj_object_type, 0, block)
    assert rc == 0
    _, _, types, _, _ = vrep.simxGetObjectGroupData(cid, vrep.sim_appobj_object_type, 1, block)
    _, _, parents, _, _ = vrep.simxGetObjectGroupData(cid, vrep.sim_appobj_object_type, 2, block)
    served = {n: (h, t, p) for h, n, t, p in zip(handles, names, types, parents)}
    listed = {n: (o["handle"], o["type"], o["parent"]) for n, o in ur5.items()}
    assert listed == served


def test_command_prints_the_tree_and_exits_without_serving():
    out = _list(str(SCENE))
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0].startswith("scene ur5_rg2_kinect.xml: 28 objects")
    assert "ready" not in out.stdout and "listening" not in out.stdout  # no Zenoh
    joint1 = next(line for line in lines if "UR5_joint1" in line)
    link1 = next(line for line in lines if "UR5_link1" in line)
    assert joint1.split()[:3] == [str(describe(SCENE)["objects"][3]["handle"]), "joint", "UR5_joint1"]
    assert "revolute" in joint1 and "max force 150 N·m" in joint1 and "control loop on" in joint1
    # indentation by parent: the link sits two columns deeper than its joint
    assert link1.index("UR5_link1") == joint1.index("UR5_joint1") + 2
    rgb = next(line for line in lines if "kinect_rgb" in line)
    assert "vision sensor" in rgb and "640x480 rgb, near 0.01 m, far 3.5 m" in rgb
    assert "child script rg2.lua (Lua)" in next(line for line in lines if " RG2  " in line)


def test_json_and_duplicate_names():
    out = _list(str(SHARED_NAMES), "--json")
    assert out.returncode == 0, out.stderr
    objects = {o["name"]: o for o in json.loads(out.stdout)["objects"]}
    # the naming rule: joint > body > site > camera > light keeps the name, the others get NAME#N
    assert objects["head"]["type"] == vrep.sim_object_shape_type and "mjcf_name" not in objects["head"]
    assert (objects["head#0"]["type_name"], objects["head#0"]["mjcf_name"]) == ("dummy", "head")
    assert (objects["head#1"]["type_name"], objects["head#1"]["resolution"]) == ("vision sensor", [32, 24])
    assert objects["slider"]["type_name"] == "joint" and objects["slider#0"]["mjcf_name"] == "slider"
    assert objects["slider#0"]["parent"] == objects["slider"]["handle"]
    assert objects["ball#1"]["mjcf_name"] == "ball" and objects["ball#0"]["type_name"] == "light"
    assert objects["neck"]["max_force"] >= 1e8 and not objects["neck"]["motor_enabled"]  # added motor


@pytest.mark.parametrize("content, expected", [
    (None, "no scene file"),
    ("<mujoco><worldbody><geom size='x'/></worldbody></mujoco>", "bad format in attribute 'size'"),
    ("<mujoco><custom><text name='simx:a' data='b'/></custom></mujoco>", "is not key=value"),
])
def test_missing_or_invalid_scene_exits_2_with_one_line(tmp_path, content, expected):
    scene = tmp_path / "scene.xml"
    if content is not None:
        scene.write_text(content)
    out = _list(str(scene))
    assert out.returncode == 2 and out.stdout == ""
    line = out.stderr.strip().splitlines()[-1]
    assert line.startswith("simx-server: --list-objects: ") and expected in line and "scene.xml" in line


def test_json_without_list_objects_is_refused():
    out = subprocess.run([sys.executable, "-m", "simx_server.cli", "--json"], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 2 and "--json goes with --list-objects" in out.stderr
