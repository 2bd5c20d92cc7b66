"""Linked mechanisms of a ``.ttt`` (simx_server/scene/ttt/mechanisms.py) on a parallel gripper
written with the tests' own writer, built as V-REP's RG2 is: the right finger's slide is a
dependent joint of the left one (mirrored), and each finger hangs from a passive rail and hinge,
held only by a dynamics loop closure to its slide's carriage. The loop closures sit on the
hinges' axes: a position-only link (a connect) would leave each finger free to swing about its
hinge; V-REP's overlap constraint (a weld) keeps it parallel to the palm."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import tttwriter as W
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader
from simx_server.scene.ttt.geometry import quat_to_mat

pytestmark = pytest.mark.renderers_on_demand  # no image is read here

C = math.sqrt(0.5)
Q_X, Q_NEG_X, Q_Y = (C, 0.0, C, 0.0), (C, 0.0, -C, 0.0), (C, -C, 0.0, 0.0)  # joint z along +x, -x, +y
OPEN, CLOSED = -0.02, 0.03  # the slides' limits (m): V-REP's minimum -0.02, range 0.05
FLOOR, MOUNT, LIFT, CARRIER, TILT, PALM, CUBE, LEFT, RIGHT = 1, 2, 3, 4, 5, 6, 7, 10, 20
SPEED, FORCE = 0.05, 20.0  # the RG2's script: 0.05 m/s, 20 N


def _inv(q):
    return (q[0], -q[1], -q[2], -q[3])


def _in_joint(q, offset):
    """``offset`` (in the joint's parent's axes) in the frame of a joint turned by ``q``."""
    return tuple(quat_to_mat(np.array(q, float)).T @ np.array(offset, float))


def _side(name: str, first: int, sign: float) -> bytes:
    """One side of the gripper (``sign`` -1 left, +1 right): a slide with a carriage, a passive
    rail and hinge that carry the finger, and the loop closure between carriage and finger on
    the hinge's axis. Every shape is posed in the palm's axes."""
    slide, carriage, loop_a, rail, rail_body, hinge, finger, loop_b = range(first, first + 8)
    q = Q_X if sign < 0 else Q_NEG_X  # both slides close towards the middle
    limits = (OPEN, CLOSED - OPEN)
    if name == "Left":  # the motor: velocity control, as the RG2's openCloseJoint
        out = W.joint(slide, PALM, "LeftSlide", (sign * 0.04, 0, -0.02), q, kind=11, loop=False,
                      max_force=FORCE, limits=limits)
    else:  # q_right = 0 + 1 * q_left: its axis points the other way, so it mirrors the left
        out = W.joint(slide, PALM, "RightSlide", (sign * 0.04, 0, -0.02), q, kind=11, motor=False,
                      mode=4, extra=W.dependency(LEFT, 1.0, 0.0), limits=limits)
    return (out
            + W.cuboid_shape(carriage, slide, f"{name}Carriage", (0.01, 0.01, 0.01), quat=_inv(q), mass=0.01,
                             respondable=False)
            + W.dummy(loop_a, carriage, f"{name}LoopA", (0, 0, -0.01), linked=loop_b, link_type=0)
            + W.joint(rail, PALM, f"{name}Rail", (sign * 0.04, 0, -0.03), q, kind=11, motor=False,
                      limits=(OPEN - 0.01, CLOSED - OPEN + 0.02))
            + W.cuboid_shape(rail_body, rail, f"{name}RailBody", (0.01, 0.01, 0.01), quat=_inv(q), mass=0.01,
                             respondable=False)
            + W.joint(hinge, rail_body, f"{name}Hinge", (0, 0, 0), Q_Y, motor=False)
            + W.cuboid_shape(finger, hinge, f"{name}Finger", (0.01, 0.03, 0.08), _in_joint(Q_Y, (0, 0, -0.045)),
                             quat=_inv(Q_Y), mass=0.05)
            + W.dummy(loop_b, finger, f"{name}LoopB", (0, 0, 0.045), linked=loop_a, link_type=0))


def gripper_scene(cube: bool) -> bytes:
    """A static mount, a lift (prismatic, along z), a tilt (revolute about y), the palm and its
    two fingers; a 5 cm cube of 0.4 kg between the open fingers when ``cube``."""
    body = (W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05))))
            + W.rec("DYN", W.lst(W.rec("En2", W.i32(0) + W.f32(0, 0, -9.81))))
            + W.cuboid_shape(FLOOR, -1, "Floor", (2, 2, 0.1), (0, 0, -0.05), dynamic=False)
            + W.cuboid_shape(MOUNT, -1, "Mount", (0.05, 0.05, 0.05), (0, 0, 0.31), dynamic=False, respondable=False)
            + W.joint(LIFT, MOUNT, "Lift", kind=11, max_force=500.0, limits=(-0.1, 0.5))
            + W.cuboid_shape(CARRIER, LIFT, "Carrier", (0.04, 0.04, 0.04), (0, 0, -0.12), mass=0.2, respondable=False)
            + W.joint(TILT, CARRIER, "Tilt", (0, 0, -0.03), Q_Y, max_force=100.0)
            + W.cuboid_shape(PALM, TILT, "Palm", (0.12, 0.04, 0.02), _in_joint(Q_Y, (0, 0, -0.04)), quat=_inv(Q_Y),
                             mass=0.3, respondable=False)
            + _side("Left", LEFT, -1.0) + _side("Right", RIGHT, 1.0))
    if cube:
        body += W.cuboid_shape(CUBE, -1, "Cube", (0.05, 0.05, 0.05), (0, 0, 0.025), mass=0.4)
    return W.ttt_file(body)


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """The gripper's scene converted, without and with the cube: ``{cube: (xml, report)}``."""
    out = {}
    for cube in (False, True):
        folder = tmp_path_factory.mktemp("gripper")
        f = folder / "gripper.ttt"
        f.write_bytes(gripper_scene(cube))
        out[cube] = convert.convert(reader.read(f), folder / "out", "gripper")
    return out


class Rig:
    """The gripper's simulation and its motors, in-process."""

    def __init__(self, xml):
        self.sim = Simulation(xml, realtime=False)
        self.w = self.sim.world
        self.sim.start()

    def motor(self, name: str) -> int:
        return self.w.motor_index[self.w.resolve(name).handle]

    def target(self, name: str, position: float) -> None:
        self.w.motors.target_position[self.motor(name)] = position

    def drive(self, velocity: float) -> None:
        """The gripper's motor as the RG2's script drives it: a target velocity at 20 N."""
        i = self.motor("LeftSlide")
        self.w.motors.max_force[i] = FORCE
        self.w.motors.target_velocity[i] = velocity
        self.w.motors.write_force_limits(self.w.model)

    def q(self, name: str) -> float:
        return float(self.w.data.joint(name).qpos[0])

    def steps(self, n: int) -> dict[str, float]:
        """Run ``n`` steps; the largest |left - right| slide gap and |hinge| angle seen."""
        worst = {"mirror": 0.0, "hinge": 0.0, "slide": -np.inf}
        for _ in range(n):
            self.sim.step()
            worst["mirror"] = max(worst["mirror"], abs(self.q("LeftSlide") - self.q("RightSlide")))
            worst["hinge"] = max(worst["hinge"], abs(self.q("LeftHinge")), abs(self.q("RightHinge")))
            worst["slide"] = max(worst["slide"], self.q("LeftSlide"), self.q("RightSlide"))
        return worst

    def close(self) -> None:
        self.sim.close()


def test_the_report_names_no_mechanism_as_lost(scenes):
    _, report = scenes[False]
    assert not [line for line in report.lines() if "depend" in line or "loop" in line]


@pytest.mark.parametrize("tilt", [0.0, 1.2], ids=["upright", "tilted"])
def test_fingers_mirror_and_stop_at_their_limits_in_two_poses(scenes, tilt):
    rig = Rig(scenes[False][0])
    try:
        rig.target("Lift", 0.2)  # up, clear of the floor, then turned about y
        rig.target("Tilt", tilt)
        rig.steps(30)
        assert rig.q("Tilt") == pytest.approx(tilt, abs=0.02)
        rig.drive(SPEED)  # close
        closing = rig.steps(30)
        assert rig.q("LeftSlide") == pytest.approx(CLOSED, abs=1e-3)
        assert rig.q("RightSlide") == pytest.approx(CLOSED, abs=1e-3)
        rig.drive(-SPEED)  # open
        opening = rig.steps(30)
        assert rig.q("LeftSlide") == pytest.approx(OPEN, abs=1e-3)
        assert rig.q("RightSlide") == pytest.approx(OPEN, abs=1e-3)
        for seen in (closing, opening):
            assert seen["mirror"] < 2e-3, seen  # the dependent slide follows (mirror image)
            assert seen["hinge"] < 0.03, seen   # the loop closures keep the fingers parallel
            assert seen["slide"] < CLOSED + 1e-3, seen  # the limit holds under 20 N
    finally:
        rig.close()


def test_a_closed_gripper_lifts_a_cube(scenes):
    rig = Rig(scenes[True][0])
    try:
        rig.steps(10)
        z0 = float(rig.w.data.body("Cube").xpos[2])
        rig.drive(SPEED)
        rig.steps(30)
        grip = rig.q("LeftSlide")
        assert 0.005 < grip < 0.015, grip  # stopped by the cube (its faces at x = +-0.025)
        # held back by the cube, V-REP's velocity motor pushes with its whole maximum force
        effort = rig.w.data.actuator_force[rig.w.model.actuator("LeftSlide_motor").id]
        assert effort == pytest.approx(FORCE, rel=0.01)
        rig.w.motors.max_velocity[rig.motor("Lift")] = 0.1  # an arm's pace: 10 cm/s
        rig.target("Lift", 0.10)  # 10 cm up, then held there for 2 s
        seen = rig.steps(60)
        assert rig.q("Lift") == pytest.approx(0.10, abs=2e-3)
        lifted = float(rig.w.data.body("Cube").xpos[2]) - z0
        assert lifted > 0.08, lifted
        assert seen["slide"] < CLOSED, seen
        assert seen["mirror"] < 2e-3 and seen["hinge"] < 0.03, seen
    finally:
        rig.close()


def test_what_cannot_be_linked_is_reported_and_left_free(tmp_path):
    body = (W.cuboid_shape(1, -1, "Base", (0.1, 0.1, 0.1), dynamic=False)
            + W.joint(2, 1, "Orphan", kind=11, motor=False, mode=4, extra=W.dependency(5, 1.0, 0.0))
            + W.cuboid_shape(3, 2, "Link", (0.05, 0.05, 0.05), mass=0.1)
            + W.dummy(4, 3, "Lonely", linked=99, link_type=0)
            + W.dummy(5, 1, "NotAJoint"))
    f = tmp_path / "broken.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, report = convert.convert(reader.read(f), tmp_path / "out", "broken")
    lines = report.lines()
    assert "1 x dependent joints without their master (left free)" in lines
    assert "1 x loop closures to a missing dummy (left open)" in lines
    assert mujoco.MjModel.from_xml_path(str(xml)).neq == 0
