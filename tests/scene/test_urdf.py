"""URDF scenes: served like MJCF (links as shapes, joints with V-REP motors), meshes confined.

The arm is tests/scenes/urdf/two_link.urdf; its mesh, a box, is written here as a binary STL with
numpy, in a ROS package layout: ``two_link/urdf/two_link.urdf`` + ``two_link/meshes/link.stl``.
"""

from __future__ import annotations

import math
import shutil
import subprocess
import sys

import numpy as np
import pytest

import vrep
from conftest import ROOT, ServerProcess, free_port, wait_until
from simx_server.scene.listing import describe

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here
SOURCE = ROOT / "tests" / "scenes" / "urdf"
WAIT = vrep.simx_opmode_blocking
OK, REMOTE = vrep.simx_return_ok, vrep.simx_return_remote_error_flag


def box_stl(path, sx: float, sy: float, height: float) -> None:
    """A binary STL box: x, y in [-sx, sx] x [-sy, sy], z in [0, height] (m), 12 triangles."""
    v = np.array([[x, y, z] for x in (-sx, sx) for y in (-sy, sy) for z in (0.0, height)], dtype="<f4")
    faces = np.array([(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
                      (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)])
    tri = v[faces]  # (12, 3, 3)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    record = np.zeros(len(faces), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    record["n"], record["v"] = normal, tri
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\0" * 80 + np.uint32(len(faces)).tobytes() + record.tobytes())


def in_link(urdf: str, link: str, old: str, new: str) -> str:
    """``urdf`` with ``old`` replaced by ``new`` inside ``<link name=link>`` only."""
    i = urdf.index(f'<link name="{link}">')
    j = urdf.index("</link>", i)
    return urdf[:i] + urdf[i:j].replace(old, new) + urdf[j:]


@pytest.fixture
def package(tmp_path):
    """``tmp_path/two_link``: the URDF, the wrapper scene and the generated mesh, as a ROS package."""
    root = tmp_path / "two_link"
    (root / "urdf").mkdir(parents=True)
    for name in ("two_link.urdf", "two_link_scene.xml"):
        shutil.copy(SOURCE / name, root / "urdf" / name)
    box_stl(root / "meshes" / "link.stl", 0.02, 0.02, 0.3)
    return root


def test_urdf_maps_links_and_joints_like_mjcf(package):
    """Links are shapes named as in the URDF (the root link too: no fusestatic), joints are
    joints between them with motors on in position control, effort and velocity from <limit>."""
    urdf = package / "urdf" / "two_link.urdf"
    # link1's mesh through a ROS package URI (MuJoCo's URDF parser names meshes by file stem: link2's
    # is the same mesh), and so it would not load unless simx maps the URI
    urdf.write_text(in_link(urdf.read_text(), "link1", "../meshes/link.stl", "package://two_link/meshes/link.stl"))
    objects = {o["name"]: o for o in describe(urdf)["objects"]}
    assert list(objects) == ["base", "joint1", "link1", "joint2", "link2"]
    assert [objects[n]["parent"] for n in ("base", "joint1", "link1", "joint2", "link2")] == \
        [-1, objects["base"]["handle"], objects["joint1"]["handle"], objects["link1"]["handle"],
         objects["joint2"]["handle"]]
    j1, j2 = objects["joint1"], objects["joint2"]
    assert (j1["type_name"], j1["joint_type"], j1["motor_enabled"], j1["control_loop"]) == \
        ("joint", "revolute", True, True)
    assert (j1["max_force"], j1["max_velocity"], j1["range"]) == (20.0, 2.0, [-2.5, 2.5])
    assert (j2["max_force"], j2["max_velocity"]) == (10.0, 1.5)
    assert objects["link1"]["type_name"] == "shape"
    # a <mimic> joint is coupled by MuJoCo's joint equality: its motor stays off
    urdf.write_text(urdf.read_text().replace('velocity="1.5"/>', 'velocity="1.5"/><mimic joint="joint1"/>'))
    mimic = {o["name"]: o for o in describe(urdf)["objects"]}
    assert mimic["joint1"]["motor_enabled"] and not mimic["joint2"]["motor_enabled"]
    assert mimic["joint2"]["max_velocity"] == 1.5


def test_legacy_client_moves_a_urdf_joint(package):
    srv = ServerProcess(str(package / "urdf" / "two_link.urdf"), "--pacing", "immediate", renderers="on-demand")
    cid = -1
    try:
        assert "two_link.urdf, 5 objects" in srv.ready_line
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        rc, joint1 = vrep.simxGetObjectHandle(cid, "joint1", WAIT)
        assert rc == OK
        _, link2 = vrep.simxGetObjectHandle(cid, "link2", WAIT)
        rc, start = vrep.simxGetObjectPosition(cid, link2, -1, WAIT)
        assert rc == OK and start == pytest.approx([0, 0, 0.35], abs=2e-3)  # upright, held by its motors
        assert vrep.simxSetJointTargetPosition(cid, joint1, 0.6, WAIT) == OK
        wait_until(lambda: abs(vrep.simxGetJointPosition(cid, joint1, WAIT)[1] - 0.6) < 0.01, 10,
                   what="joint1 at its target 0.6 rad")
        _, moved = vrep.simxGetObjectPosition(cid, link2, -1, WAIT)
        # link2's origin sits 0.3 m along link1, which now leans 0.6 rad about y
        assert moved == pytest.approx([0.3 * math.sin(0.6), 0, 0.05 + 0.3 * math.cos(0.6)], abs=0.01)
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        srv.stop()


def test_missing_mesh_exits_2_naming_link_and_file(package):
    (package / "meshes" / "link.stl").unlink()
    out = subprocess.run([sys.executable, "-m", "simx_server.cli", str(package / "urdf" / "two_link.urdf"),
                          "--port", str(free_port())], capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "ready" not in out.stdout
    assert "link 'link1': mesh '../meshes/link.stl' not found" in out.stderr
    assert str(package / "meshes" / "link.stl") in out.stderr  # where it was looked for


def test_client_sent_urdf_loads_and_its_meshes_stay_in_the_transfer_folder(package, tmp_path):
    """simxLoadScene of a transferred URDF: the mesh sent with it loads; a mesh path climbing out
    of the transfer folder, or a package:// URI whose package folder lies outside it, is refused."""
    sent = tmp_path / "sent"
    sent.mkdir()
    box_stl(sent / "link.stl", 0.02, 0.02, 0.3)
    plain = (SOURCE / "two_link.urdf").read_text().replace("../meshes/link.stl", "link.stl")
    (sent / "arm.urdf").write_text(plain)
    (sent / "climbs.urdf").write_text(in_link(plain, "link1", '"link.stl"', '"../link.stl"'))
    # the transfer folder is <tmp>/simx-...: "package://tmp" would be the system's temporary folder
    (sent / "package.urdf").write_text(in_link(plain, "link1", '"link.stl"', '"package://tmp/link.stl"'))
    srv = ServerProcess(str(package / "urdf" / "two_link_scene.xml"), "--pacing", "immediate", "--stopped",
                        renderers="on-demand")
    cid = -1
    try:
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        for name in ("link.stl",):  # the scenes themselves travel with simxLoadScene (options 1)
            assert vrep.simxTransferFile(cid, str(sent / name), name, 5, WAIT) == OK
        assert vrep.simxLoadScene(cid, str(sent / "climbs.urdf"), 1, WAIT) == REMOTE
        assert vrep.simxLoadScene(cid, str(sent / "package.urdf"), 1, WAIT) == REMOTE
        assert vrep.simxGetObjectHandle(cid, "overview", WAIT)[0] == OK  # the scene stayed
        assert vrep.simxLoadScene(cid, str(sent / "arm.urdf"), 1, WAIT) == OK
        assert vrep.simxGetObjectHandle(cid, "overview", WAIT)[0] == REMOTE
        rc, joint2 = vrep.simxGetObjectHandle(cid, "joint2", WAIT)
        assert rc == OK and vrep.simxGetObjectFloatParameter(cid, joint2, 2017, WAIT) == (OK, 1.5)
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        log = srv.stop()
    refusals = [line for line in log.splitlines() if "refused" in line]
    assert any("'../link.stl'" in line and "climbs.urdf" in line for line in refusals), log
    # refused before any lookup: the same words whether the system's /tmp/link.stl exists or not
    assert any("package.urdf refused: it names the file 'package://tmp/link.stl'" in line for line in refusals), log
    assert "looked for" not in log and "not found" not in log


@pytest.mark.filterwarnings("ignore:Attaching a spec with an empty prefix")  # as urdf.py does for the server
def test_scene_around_a_urdf_adds_what_urdf_cannot_say(package):
    """tests/scenes/urdf/two_link_scene.xml: a camera with simx: settings, an actuator and modes."""
    objects = {o["name"]: o for o in describe(package / "urdf" / "two_link_scene.xml")["objects"]}
    assert objects["base"]["parent"] == objects["table"]["handle"]  # attached where the scene says
    assert objects["link2"]["parent"] == objects["joint2"]["handle"]
    cam = objects["overview"]
    assert (cam["type_name"], cam["resolution"], cam["near"], cam["far"]) == ("vision sensor", [320, 240], 0.05, 5.0)
    assert objects["joint1"]["actuator"] == "joint1_servo" and objects["joint1"]["motor_enabled"]
    assert objects["joint2"]["actuator"] == "simx_motor:joint2" and not objects["joint2"]["motor_enabled"]


def test_urdf_to_mjcf_writes_the_same_scene(package, tmp_path):
    out_file = tmp_path / "elsewhere" / "arm.xml"
    out_file.parent.mkdir()
    out = subprocess.run([sys.executable, "-m", "simx_server.cli", str(package / "urdf" / "two_link.urdf"),
                          "--urdf-to-mjcf", str(out_file)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert 'file="../two_link/meshes/link.stl"' in out_file.read_text()  # relative to the MJCF's folder
    as_urdf = describe(package / "urdf" / "two_link.urdf")["objects"]
    as_mjcf = describe(out_file)["objects"]
    assert as_mjcf == as_urdf


def test_mujoco_extension_element_is_honoured(package):
    """<mujoco><compiler meshdir=.../></mujoco> is where meshes are looked up; an explicit
    fusestatic="true" is the URDF author's choice (the root link merges into the world)."""
    urdf = package / "urdf" / "two_link.urdf"
    text = urdf.read_text().replace("../meshes/link.stl", "link.stl")
    urdf.write_text(text.replace('<robot name="two_link">',
                                 '<robot name="two_link"><mujoco><compiler meshdir="../meshes"/></mujoco>'))
    assert [o["name"] for o in describe(urdf)["objects"]][:3] == ["base", "joint1", "link1"]
    urdf.write_text(text.replace('<robot name="two_link">', '<robot name="two_link"><mujoco><compiler '
                                 'meshdir="../meshes" fusestatic="true"/></mujoco>'))
    objects = {o["name"]: o for o in describe(urdf)["objects"]}
    assert "base" not in objects and objects["joint1"]["parent"] == -1


SHOULDER_URDF = """<?xml version="1.0"?>
<robot name="shoulder">
  <link name="base">
    <inertial><mass value="5"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <link name="upper">
    <inertial><origin xyz="0 0 0.2"/><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><box size="0.08 0.08 0.4"/></geometry></collision>
  </link>
  <link name="fore">
    <inertial><origin xyz="0 0 0.1"/><mass value="0.5"/>
      <inertia ixx="0.004" iyy="0.004" izz="0.0005" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><box size="0.06 0.06 0.3"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.05"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="2.5" effort="50" velocity="2"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="20" velocity="2"/>
  </joint>
</robot>
"""


def test_adjacent_links_do_not_collide_so_a_shoulder_inside_its_base_follows_its_targets(tmp_path, caplog):
    """Issue 19 part 5: the upper arm's collision box starts inside the base's (welded to the
    world, so MuJoCo does not filter the pair): it stalled at 0.06 rad at its 50 N·m limit."""
    import logging

    from simx_server.scene.simulation import Simulation

    urdf = tmp_path / "shoulder.urdf"
    urdf.write_text(SHOULDER_URDF)
    with caplog.at_level(logging.WARNING, logger="simx.world"):
        sim = Simulation(urdf, dt=0.05, realtime=False)
    try:
        assert "links in contact" not in caplog.text  # the only overlap is an adjacent pair
        w = sim.world
        shoulder = w.resolve("shoulder").handle
        sim.start()
        w.set_joint_target_position(shoulder, 1.0)
        for _ in range(40):  # 2 s: at 2 rad/s it is there after 0.5 s
            sim.step()
        assert w.joint_position(shoulder) == pytest.approx(1.0, abs=0.02)
    finally:
        sim.close()
