"""A joint's frames as V-REP gives them (coppeliaSimLib ``simGetObjectPosition_internal`` & co.):
the joint as an object is its base frame (``CSceneObject::getCumulativeTransformation``: a hinge
does not turn with its angle, a slide does not move with its travel); a joint as the frame of
reference is its moved frame (``getFullCumulativeTransformation``), or its base frame for
``handle + sim.handleflag_reljointbaseframe`` and in scripts saved before CoppeliaSim 4.0.1
(``CDetachedScript::_adjustScriptText11_old`` adds the flag to their pose calls). The frame's x
and y are the file's, also where MuJoCo merges the joint into a child body turned about its
axis (``frame=``). Omni-wheels rely on all of it: their scripts put the rollers' joint back at
45 degrees from the wheel joint's base frame every pass (PyRep's youBot, V-REP 3.x's youBot).
"""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

import tttwriter as W
from simx_server.api import client_context
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

try:
    from conftest import SHARED, require_shared
except ImportError:  # tests/ imported as a package
    from tests.conftest import SHARED, require_shared

pytestmark = pytest.mark.renderers_on_demand  # no image is read

REL = 0x400000  # sim.handleflag_reljointbaseframe
WXYZ = 0x1000000  # sim.handleflag_wxyzquat
RY90 = (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0)  # z turned onto the world's x
RZ180 = (0.0, 0.0, 0.0, 1.0)


def _mat(q) -> np.ndarray:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _rz(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def _scene(extra: bytes = b"") -> bytes:
    """A static base; a hinge along the world's x whose only child is turned 180 degrees about
    the joint's axis (MuJoCo puts the joint in that child's body); a slide along z; a probe dummy."""
    return (W.cuboid_shape(1, -1, "Base", (0.1, 0.1, 0.1), (0, 0, 0.5), dynamic=False)
            + W.joint(2, 1, "J", (0.2, 0, 0), quat=RY90, limits=(-3.0, 6.0))
            + W.cuboid_shape(3, 2, "Link", (0.02, 0.02, 0.1), (0, 0, 0.05), quat=RZ180, mass=0.1)
            + W.joint(4, 1, "S", (-0.2, 0, 0), kind=11, limits=(-0.5, 1.0))
            + W.cuboid_shape(5, 4, "Carriage", (0.05, 0.05, 0.05), (0, 0, 0), mass=0.1)
            + W.dummy(6, 1, "Probe", (0.2, 0.1, 0.05)) + extra)


def _load(tmp_path, body: bytes, program: int = 40100) -> Simulation:
    f = tmp_path / "scene.ttt"
    f.write_bytes(W.ttt_file(body, serialization=25, program=program))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "scene")
    return Simulation(xml, realtime=False)


def _matrix(api, h, rel=-1) -> tuple[np.ndarray, np.ndarray]:
    m = np.array(api.getObjectMatrix(h, rel)).reshape(3, 4)
    return m[:, :3], m[:, 3]


def test_a_joint_is_its_base_frame_and_its_children_hang_from_the_moved_one(tmp_path):
    sim = _load(tmp_path, _scene())
    try:
        api = client_context(sim).sim
        j, s, link, carriage = (api.getObject(p) for p in ("/J", "/S", "/Link", "/Carriage"))
        for q in (0.0, 0.7, -1.2):
            api.setJointPosition(j, q)
            api.setJointPosition(s, 0.3 * q)
            r, p = _matrix(api, j)
            np.testing.assert_allclose(r, _mat(RY90), atol=1e-9)           # the file's frame, not turned by q
            np.testing.assert_allclose(p, [0.2, 0, 0.5], atol=1e-9)
            assert api.getObjectPosition(s, -1) == pytest.approx([-0.2, 0, 0.5], abs=1e-9)  # not moved by q
            rl, pl = _matrix(api, link, j)                                  # the child's pose in the moved frame
            np.testing.assert_allclose(rl, _mat(RZ180), atol=1e-9)
            np.testing.assert_allclose(pl, [0, 0, 0.05], atol=1e-9)
            assert api.getObjectPosition(carriage, s) == pytest.approx([0, 0, 0], abs=1e-9)
            assert api.getObjectPosition(carriage, -1)[2] == pytest.approx(0.5 + 0.3 * q, abs=1e-9)
    finally:
        sim.close()


def test_the_base_frame_flag_and_the_quaternion_order_flag(tmp_path):
    sim = _load(tmp_path, _scene())
    try:
        api = client_context(sim).sim
        j, probe = api.getObject("/J"), api.getObject("/Probe")
        in_base = _mat(RY90).T @ np.array([0.0, 0.1, 0.05])                # the probe from the joint's base frame
        for q in (0.0, 0.9):
            api.setJointPosition(j, q)
            moved = (_mat(RY90) @ _rz(q)).T @ np.array([0.0, 0.1, 0.05])
            assert api.getObjectPosition(probe, j) == pytest.approx(moved.tolist(), abs=1e-9)
            assert api.getObjectPosition(probe + REL, j) == pytest.approx(in_base.tolist(), abs=1e-9)
        api.setObjectPosition(probe + REL, j, [0.0, 0.0, 0.1])                # placed in the base frame at q = 0.9
        assert api.getObjectPosition(probe, -1) == pytest.approx([0.3, 0, 0.5], abs=1e-9)
        api.setObjectOrientation(probe, j, [0, 0, 0])                       # turned as the moved frame
        np.testing.assert_allclose(_matrix(api, probe)[0], _mat(RY90) @ _rz(0.9), atol=1e-9)
        xyzw = api.getObjectQuaternion(probe, -1)
        assert api.getObjectQuaternion(probe + WXYZ, -1) == pytest.approx([xyzw[3], *xyzw[:3]], abs=1e-12)
        pose = api.getObjectPose(probe + WXYZ, -1)
        assert pose[3:] == pytest.approx([xyzw[3], *xyzw[:3]], abs=1e-12)
        api.setObjectPose(probe + WXYZ, -1, [0.1, 0.2, 0.3, 1, 0, 0, 0])       # w first: the identity
        assert api.getObjectPose(probe, -1) == pytest.approx([0.1, 0.2, 0.3, 0, 0, 0, 1], abs=1e-12)
    finally:
        sim.close()


READ = """
function sysCall_init()
    local j, probe = sim.getObjectHandle('J'), sim.getObjectHandle('Probe')
    sim.setJointPosition(j, 0.9)
    sim.setStringSignal('rel', sim.packFloatTable(sim.getObjectPosition(probe, j)))
end
"""


@pytest.mark.parametrize("program", [30600, 40100])
def test_scripts_saved_before_4_0_1_count_a_joint_by_its_base_frame(tmp_path, program):
    sim = _load(tmp_path, _scene(W.script(7, 1, READ)), program=program)
    try:
        sim.start()
        got = struct.unpack("<3f", sim.signals.get_string("rel"))
        frame = _mat(RY90) if program < 40001 else _mat(RY90) @ _rz(0.9)
        assert got == pytest.approx((frame.T @ np.array([0.0, 0.1, 0.05])).tolist(), abs=1e-6)
    finally:
        sim.close()


OMNI = """
function sysCall_init()
    roll, slip = sim.getObject('/Roll'), sim.getObject('/Slip')
end
function sysCall_actuation()
    sim.setObjectPosition(slip + sim.handleflag_reljointbaseframe, roll, {0, 0, 0})
    sim.setObjectOrientation(slip + sim.handleflag_reljointbaseframe, roll, {-math.pi / 4, 0, 0})
end
"""


def test_an_omni_wheels_roller_joint_stays_at_45_degrees_while_the_wheel_turns(tmp_path):
    """PyRep's youBot scripts: every pass the roller joint is put back at 45 degrees from the
    wheel joint's base frame; the wheel joint turns under its motor, the roller's axis stays."""
    body = (W.cuboid_shape(1, -1, "Chassis", (0.2, 0.2, 0.05), (0, 0, 0.5), dynamic=False)
            + W.joint(2, 1, "Roll", (0.15, 0, 0), quat=RY90, loop=False, target_velocity=2.0, limits=(0, 0),
                      cyclic=True)
            + W.joint(3, 2, "Slip", (0, 0, 0), motor=False, limits=(0, 0), cyclic=True)
            + W.cuboid_shape(4, 3, "Wheel", (0.04, 0.04, 0.04), (0, 0, 0), quat=RZ180, mass=0.1)
            + W.script(5, 1, OMNI))
    sim = _load(tmp_path, body)
    try:
        api = client_context(sim).sim
        roll, slip = api.getObject("/Roll"), api.getObject("/Slip")
        want = _mat(RY90) @ np.array([0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)])  # Rx(-45 deg)'s z
        sim.start()
        for _ in range(30):
            sim.step()
            axis = np.array(api.getObjectMatrix(slip, -1)).reshape(3, 4)[:, 2]
            turned = api.getJointPosition(roll) * 1.0
            # after the pass the physics step has turned it with the wheel joint by one step's angle
            step = 2.0 * sim.world.dt
            assert axis @ want == pytest.approx(math.cos(step), abs=0.02), (turned, axis)
        assert abs(api.getJointPosition(roll)) > 2.0  # the wheel joint did turn
    finally:
        sim.close()


YOUBOT = SHARED / "pyrep" / "robot_ttms" / "mobiles" / "youBot.ttm"


@pytest.mark.parametrize("command", ["forward", "sideways", "turn"])
def test_pyreps_youbot_drives_forward_sideways_and_turns(tmp_path, command):
    """PyRep's youBot (``HolonomicBase.set_base_angular_velocites``): its mecanum wheels, made
    by the scripts above, carry it sideways and turn it on the spot, not only forward."""
    xml, _ = convert.convert(reader.read(require_shared(YOUBOT)), tmp_path, "youbot")
    xml.write_text(xml.read_text().replace("<worldbody>", '<worldbody>\n<geom name="floor" type="plane" size="9 9 0.1"/>', 1))
    fw, sw, rot = {"forward": (5, 0, 0), "sideways": (0, 5, 0), "turn": (0, 0, 2)}[command]
    sim = Simulation(xml, realtime=False)
    try:
        api = client_context(sim).sim
        sim.start()
        base = api.getObject("/youBot")
        for _ in range(10):
            sim.step()
        r0, p0 = _matrix(api, base)
        yaw0 = api.getObjectOrientation(base, -1)[2]
        for i, v in enumerate((-fw - sw - rot, -fw + sw - rot, -fw - sw + rot, -fw + sw + rot)):
            api.setJointTargetVelocity(api.getObject(f"/youBot_m_joint{i + 1}"), v)
        for _ in range(round(2.0 / sim.world.dt)):
            sim.step()
        moved = r0.T @ (_matrix(api, base)[1] - p0)  # in the base's frame: x to its side, y ahead
        yaw = api.getObjectOrientation(base, -1)[2] - yaw0
        if command == "forward":
            assert moved[1] > 0.4 and abs(moved[0]) < 0.05 and abs(yaw) < 0.05, (moved, yaw)
        elif command == "sideways":
            assert moved[0] > 0.2 and abs(moved[1]) < 0.1 and abs(yaw) < 0.2, (moved, yaw)
        else:
            assert abs(yaw) > 0.3 and np.linalg.norm(moved[:2]) < 0.05, (moved, yaw)
    finally:
        sim.close()
