"""CoppeliaSim's spring-damper joint mode where its target velocity binds: a velocity motor at
that speed with at most the spring-damper's force (``CJoint::handleDynJointControl``), not a free
spring (simx_server/sim/joint_springs.py). RLBench's door handles: target velocity 0, a brake."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import tttwriter as W
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader
from simx_server.sim import object_params

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

HORIZONTAL = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)  # the joint's z axis along -y


def _lever(tmp_path, k: float, target_velocity: float, target: float = 0.0, gravity: bool = True):
    """A static post and a 0.2 kg, 0.3 m lever on a spring-damper hinge (axis horizontal, so that
    gravity pulls the lever down with 0.294 N m, unless ``gravity`` is off); upper velocity 2 rad/s."""
    body = (W.cuboid_shape(1, -1, "Post", (0.1, 0.1, 0.1), (0, 0, 0.5), dynamic=False)
            + W.joint(2, 1, "Hinge", (0, 0, 0.1), quat=HORIZONTAL, target_velocity=target_velocity,
                      extra=W.rec("Dcm", W.i32(12)) + W.rec("Spp", W.f32(k, 0.0)) + W.rec("Dtp", W.f32(target)))
            + W.cuboid_shape(3, 2, "Lever", (0.3, 0.05, 0.05), (0.15, 0, 0), mass=0.2))
    settings = b"" if gravity else W.rec("DYN", W.lst(W.rec("En2", W.i32(0) + W.f32(0, 0, 0))))
    f = tmp_path / "lever.ttt"
    f.write_bytes(W.ttt_file(settings + body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "lever")
    return xml


def _texts(xml):
    return {t.name: t.data for t in mujoco.MjSpec.from_file(str(xml)).texts}


def _run(sim: Simulation, seconds: float) -> list[float]:
    q = []
    for _ in range(round(seconds / sim.world.dt)):
        sim.step()
        q.append(float(sim.world.data.joint("Hinge").qpos[0]))
    return q


def test_a_spring_with_target_velocity_zero_is_a_brake_that_stops_the_lever(tmp_path):
    xml = _lever(tmp_path, k=3.0, target_velocity=0.0)
    assert _texts(xml)["simx:Hinge"] == "mode=spring spring_k=3 spring_c=0 max_velocity=2"
    m = mujoco.MjModel.from_xml_path(str(xml))
    assert m.jnt_stiffness[m.joint("Hinge").id] == 0  # no free spring
    sim = Simulation(xml, realtime=False)
    try:
        sim.start()
        _run(sim, 2.0)
        later = np.abs(_run(sim, 1.0))
        # the brake holds where K |e| first met the load (0.294 N m / 3 = 0.098 rad), and stays:
        # a free spring of K = 3 swings between 0 and 0.196 rad without end
        assert 0.09 < later.min() and later.max() < 0.21
        assert later.max() - later.min() < 2e-3
    finally:
        sim.close()


def test_a_spring_moves_its_joint_at_most_at_its_target_velocity(tmp_path):
    xml = _lever(tmp_path, k=50.0, target_velocity=0.2, target=0.5, gravity=False)
    assert _texts(xml)["simx:Hinge"] == ("mode=spring spring_k=50 spring_c=0 max_velocity=2 "
                                        "target_position=0.5 target_velocity=0.200000003")
    sim = Simulation(xml, realtime=False)
    try:
        sim.start()
        q = _run(sim, 1.0)
        assert q[-1] == pytest.approx(0.2, abs=0.03)  # 0.2 rad/s, not a spring's snap
        q = _run(sim, 3.0)
        assert q[-1] == pytest.approx(0.5, abs=0.01)  # there it stays: the force is K e, ~0
        assert max(q) < 0.51
    finally:
        sim.close()


def test_a_spring_faster_than_its_joint_is_the_joints_own_spring(tmp_path):
    xml = _lever(tmp_path, k=5.0, target_velocity=5.0, target=0.3, gravity=False)
    assert _texts(xml)["simx:Hinge"] == "mode=passive"
    m = mujoco.MjModel.from_xml_path(str(xml))
    assert m.jnt_stiffness[m.joint("Hinge").id] == pytest.approx(5.0)


@pytest.mark.parametrize("mode, setting", [(1, "mode=force"), (16, "mode=callback")])
def test_a_4x_files_force_and_callback_modes_load_as_such(tmp_path, mode, setting):
    # CoppeliaSim 4.4+'s control mode (Dcm) 1 and 16: torque control, a script's joint callback
    # (simx_server/sim/dyn_ctrl.py); before, both loaded as velocity or position control
    f = tmp_path / "modes.ttt"
    f.write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Post", (0.1, 0.1, 0.1), (0, 0, 0.5), dynamic=False)
                             + W.joint(2, 1, "Hinge", (0, 0, 0.1), extra=W.rec("Dcm", W.i32(mode)))
                             + W.cuboid_shape(3, 2, "Lever", (0.3, 0.05, 0.05), (0.15, 0, 0), mass=0.2)))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "modes")
    assert _texts(xml)["simx:Hinge"].startswith(setting)
    sim = Simulation(xml, realtime=False)
    try:
        assert object_params.get_int_param(sim, sim.world.resolve("Hinge").handle, 2039) == mode
    finally:
        sim.close()
