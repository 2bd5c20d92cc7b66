"""A converted joint's rotor inertia (``armature``, simx_server/scene/ttt/parts.py and
mechanisms.py). V-REP's engines give no joint one; MuJoCo needs it where a motor or a spring drives
a light link and in closed mechanisms. Every joint had 0.01 kg m^2: a free joint then turned its
child as a flywheel would (RLBench's screw_nail: a 3 mm screw, 5e-7 kg m^2 of its own, lagged the
screwdriver turning it by a radian; the TurtleBot's 11 g casters dragged it at 0.085 of its
0.105 m/s)."""

from __future__ import annotations

import math

import mujoco
import pytest

import tttwriter as W
from simx_server.scene.ttt import convert, reader
from simx_server.scene.ttt.mechanisms import DRIVEN_ARMATURE

pytestmark = pytest.mark.renderers_on_demand  # no image is read here

ARM = 0.05  # the pendulum's arm (m)


def _scene(free_hinge_motor: bool = False) -> bytes:
    """A static post with a pendulum (a 10 g cube 5 cm out on a free horizontal hinge), a motor
    hinge, a spherical joint, and a two-link loop closed by linked dummies."""
    q_y = (math.sqrt(0.5), -math.sqrt(0.5), 0.0, 0.0)  # the hinge's z along the world's y
    return W.ttt_file(
        W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + W.rec("DYN", W.lst(W.rec("En2", W.i32(0) + W.f32(0, 0, -9.81)))) +
        W.cuboid_shape(1, -1, "Post", (0.05, 0.05, 1.0), (0, 0, 0.5), dynamic=False, respondable=False) +
        W.joint(2, 1, "Hinge", (0, 0, -0.05), q_y, motor=free_hinge_motor, loop=False) +
        W.cuboid_shape(3, 2, "Bob", (0.01, 0.01, 0.01), (ARM, 0, 0), mass=0.01, respondable=False,
                       moments=(1.7e-5, 1.7e-5, 1.7e-5)) +
        W.joint(4, 1, "Motor", (0.3, 0, -0.05), motor=True) +
        W.cuboid_shape(5, 4, "Driven", (0.02, 0.02, 0.02), (0, 0, -0.05), mass=0.1, respondable=False) +
        W.joint(6, 1, "Ball", (-0.3, 0, -0.05), kind=12, motor=False) +
        W.cuboid_shape(7, 6, "Hanging", (0.02, 0.02, 0.02), (0, 0, -0.05), mass=0.1, respondable=False) +
        W.joint(8, 1, "LoopA", (0, 0.3, -0.05), motor=False) +
        W.cuboid_shape(9, 8, "LinkA", (0.02, 0.02, 0.02), (0, 0, -0.05), mass=0.01, respondable=False) +
        W.dummy(10, 9, "ClosureA", (0, 0, 0), linked=13) +
        W.joint(11, 1, "LoopB", (0, 0.32, -0.05), motor=False) +
        W.cuboid_shape(12, 11, "LinkB", (0.02, 0.02, 0.02), (0, 0, -0.05), mass=0.01, respondable=False) +
        W.dummy(13, 12, "ClosureB", (0, -0.02, 0), linked=10))


def test_free_joints_carry_no_armature_driven_and_looped_ones_do(tmp_path):
    (tmp_path / "joints.ttt").write_bytes(_scene())
    xml, _ = convert.convert(reader.read(str(tmp_path / "joints.ttt")), tmp_path / "out")
    m = mujoco.MjModel.from_xml_path(str(xml))

    def armature(name: str) -> float:
        j = m.joint(name)
        return float(m.dof_armature[j.dofadr[0]])

    assert armature("Hinge") == 0.0  # no motor: the bob's own inertia
    assert all(m.dof_armature[m.joint("Ball").dofadr[0] + k] == 0.0 for k in range(3))
    assert armature("Motor") == DRIVEN_ARMATURE
    assert armature("LoopA") == armature("LoopB") == DRIVEN_ARMATURE  # a closed mechanism's joints


@pytest.mark.parametrize("motor", [False, True], ids=["free", "motor-on"])
def test_a_free_pendulum_swings_with_its_own_inertia(tmp_path, motor):
    """Released level, a 10 g bob on a 5 cm arm reaches the bottom in about 0.1 s (a free
    pendulum's quarter swing from 90 degrees, 1.18 sqrt(L/g)); with 0.01 kg m^2 on its hinge it
    would have turned 0.3 degrees in 0.25 s. A joint whose file keeps its motor enabled is driven
    (velocity 0, 10 N m here): it holds the bob level."""
    from simx_server.scene.simulation import Simulation

    (tmp_path / "pendulum.ttt").write_bytes(_scene(free_hinge_motor=motor))
    sim = Simulation(tmp_path / "pendulum.ttt", realtime=False)
    try:
        w = sim.world
        bob = w.by_name["Bob"].body
        hinge = w.model.jnt_qposadr[w.model.joint("Hinge").id]
        start = float(w.data.xpos[bob][2])
        sim.start()
        lowest = start
        for _ in range(5):  # 0.25 s
            sim.step()
            lowest = min(lowest, float(w.data.xpos[bob][2]))
        sim.stop()
        swung = math.degrees(abs(float(w.data.qpos[hinge])))
    finally:
        sim.close()
    if motor:
        assert start - lowest < 0.005, (start, lowest)
    else:
        assert start - lowest > 0.9 * ARM, (start, lowest, swung)
