"""A gripper whose finger motors "lock when the target velocity is zero" (``simx:``
``velocity_lock=1``, what a ``.ttt`` saved; RLBench's Panda fingers have it) keeps squeezing what
it closed on once told to stop, as CoppeliaSim's Bullet 2.78 plugin holds such a joint with equal
limits where it stopped (``_handlePrismaticMotor_controllerDisabled``); without it the stopped
motor only resists motion and the grip relaxes. PyRep's ``Gripper.actuate`` closes this way:
velocity towards closed until the fingers stop moving, then target velocity 0."""

from __future__ import annotations

import contextlib

import mujoco
import pytest

from simx_server.api import client_context
from simx_server.scene.simulation import Simulation

SCENE = """<mujoco model="grip">
  <compiler angle="radian"/>
  <option timestep="0.005"/>
  <worldbody>
    <geom name="table" type="box" pos="0 0 0.1" size="0.2 0.2 0.1"/>
    <body name="box" pos="0 0 0.24">
      <freejoint/>
      <geom type="box" size="0.02 0.02 0.04" mass="0.5" friction="0.5"/>
    </body>
    <body name="hand" pos="0 0 0.25">
      <joint name="lift" type="slide" axis="0 0 1" range="-0.1 0.3"/>
      <geom type="box" size="0.08 0.02 0.005" pos="0 0 0.06" mass="0.5"/>
      <body name="left" pos="-0.05 0 0">
        <joint name="finger_left" type="slide" axis="1 0 0" range="0 0.04"/>
        <geom type="box" size="0.005 0.015 0.03" pos="0 0 0.025" mass="1" friction="0.5"/>
      </body>
      <body name="right" pos="0.05 0 0">
        <joint name="finger_right" type="slide" axis="-1 0 0" range="0 0.04"/>
        <geom type="box" size="0.005 0.015 0.03" pos="0 0 0.025" mass="1" friction="0.5"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="lift" forcerange="-200 200" forcelimited="true"/>
    <motor joint="finger_left" forcerange="-10 10" forcelimited="true"/>
    <motor joint="finger_right" forcerange="-10 10" forcelimited="true"/>
  </actuator>
  <custom>
    <text name="simx:finger_left" data="mode=velocity LOCK"/>
    <text name="simx:finger_right" data="mode=velocity LOCK"/>
  </custom>
</mujoco>
"""


@contextlib.contextmanager
def _locked_gripper(tmp_path):
    """The scene with locking fingers, started: ``(simulation, sim API, finger handles)``."""
    path = tmp_path / "grip.xml"
    path.write_text(SCENE.replace("LOCK", "velocity_lock=1"))
    simulation = Simulation(path, realtime=False)
    try:
        simulation.start()
        api = client_context(simulation, "test").sim
        yield simulation, api, [api.getObject("/finger_left"), api.getObject("/finger_right")]
    finally:
        simulation.close()


def lifted(tmp_path, lock: bool) -> float:
    """Close the fingers on the box until they press on it, stop them as PyRep's
    ``Gripper.actuate`` does (target velocity 0), lift the hand 0.1 m; the box's rise (m)."""
    path = tmp_path / "grip.xml"
    path.write_text(SCENE.replace("LOCK", "velocity_lock=1" if lock else ""))
    simulation = Simulation(path, realtime=False)
    try:
        simulation.start()
        api = client_context(simulation, "test").sim
        fingers = [api.getObject("/finger_left"), api.getObject("/finger_right")]
        assert [api.getObjectInt32Param(f, api.jointintparam_velocity_lock) for f in fingers] == [int(lock)] * 2
        lift, box = api.getObject("/lift"), api.getObject("/box")
        z0 = api.getObjectPosition(box, -1)[2]
        for f in fingers:  # closing, until they press on the box with their whole force
            api.setJointTargetVelocity(f, 0.04)
        for _ in range(20):
            simulation.step()
        for f in fingers:  # PyRep's Gripper.actuate: the fingers stopped moving, target velocity 0
            api.setJointTargetVelocity(f, 0.0)
        simulation.step()
        assert api.getJointPosition(fingers[0]) == pytest.approx(0.025, abs=0.002)  # on the box
        # a lock is a joint equality pinned where the finger stopped, on while the target is 0
        w = simulation.world
        locks = [mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_EQUALITY, f"simx_lock:finger_{s}")
                 for s in ("left", "right")]
        assert [e >= 0 and bool(w.data.eq_active[e]) for e in locks] == [lock] * 2
        api.setJointTargetPosition(lift, 0.1)
        for _ in range(30):
            simulation.step()
        return api.getObjectPosition(box, -1)[2] - z0
    finally:
        simulation.close()


def test_a_locked_stopped_gripper_keeps_its_grip(tmp_path):
    assert lifted(tmp_path, lock=True) > 0.06  # the hand rose 0.1 m; the box slips a little


def test_without_the_lock_the_stopped_grip_relaxes(tmp_path):
    assert lifted(tmp_path, lock=False) < 0.02  # the box slid out


def test_a_locked_finger_told_to_move_moves_from_its_first_step(tmp_path):
    """Unlocked by a new target velocity, a finger moves at it from the first step: the lock's
    equality pins the joint, but it is no part of the mechanism the motor drives, so the motor's
    gain is the free finger's. With the lock counted as a linkage the gain was a million times too
    high for that step and the motor's force chattered between its limits: on RLBench's Panda one
    finger moved less than PyRep's ``Gripper.actuate`` takes for moving, which then stopped it and
    left that finger open."""
    with _locked_gripper(tmp_path) as (simulation, api, fingers):
        for _ in range(3):  # target velocity 0 from the start: locked where they are
            simulation.step()
        w = simulation.world
        locks = [mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_EQUALITY, f"simx_lock:finger_{s}")
                 for s in ("left", "right")]
        assert all(w.data.eq_active[e] for e in locks)
        before = [api.getJointPosition(f) for f in fingers]
        for f in fingers:
            api.setJointTargetVelocity(f, 0.04)
        simulation.step()
        moved = [api.getJointPosition(f) - b for f, b in zip(fingers, before)]
        speeds = [api.getJointVelocity(f) for f in fingers]
        forces = [abs(api.getJointForce(f)) for f in fingers]
        assert not any(w.data.eq_active[e] for e in locks)
        assert all(x > 0.5 * 0.04 * w.dt for x in moved), moved
        # at the target velocity by the step's end, the motor's force well inside its 10 N
        assert speeds == pytest.approx([0.04, 0.04], rel=0.1) and max(forces) < 5, (speeds, forces)


@pytest.mark.parametrize("how", ["setJointPosition", "setConfigurationTree"])
def test_a_locked_finger_put_elsewhere_stays_there(tmp_path, how):
    """A stopped, locked finger placed somewhere else (PyRep's ``set_joint_positions``, RLBench's
    reset through a configuration tree) is held where it was put, as CoppeliaSim's engine
    re-creates the joint there: the lock was kept at the old place, so RLBench's Panda reopened
    after a demo closed back on the next step and every later demo attempt found no path to the
    first grasp (its closed fingers hit what they were to grasp)."""
    with _locked_gripper(tmp_path) as (simulation, api, fingers):
        tree = api.getConfigurationTree(api.getObject("/hand"))  # the fingers open, at 0
        for f in fingers:  # closed a little, then stopped: locked there
            api.setJointTargetVelocity(f, 0.04)
        for _ in range(5):
            simulation.step()
        for f in fingers:
            api.setJointTargetVelocity(f, 0.0)
        for _ in range(3):
            simulation.step()
        closed = [api.getJointPosition(f) for f in fingers]
        assert min(closed) > 0.005
        if how == "setJointPosition":
            for f in fingers:
                api.setJointPosition(f, 0.002)
        else:
            api.setConfigurationTree(tree)
        for _ in range(10):
            simulation.step()
        expected = 0.002 if how == "setJointPosition" else 0.0
        assert [api.getJointPosition(f) for f in fingers] == pytest.approx([expected] * 2, abs=2e-4)
