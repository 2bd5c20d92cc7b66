"""A velocity motor told to stop holds its joint still (issue 50, item B): V-REP's velocity motor
is a velocity constraint bounded by the maximum force, so a joint at target velocity 0 does not
move under a load below that force (a gripper's linkage pressing on its active joints; PyRep's
``Gripper.actuate`` calls a joint still when it moves less than 0.01 mm in a step). simx's servo
alone is a damper: it crept under a steady load. Engine-level, in-process."""

from __future__ import annotations

import pytest

from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read

SCENE = """<mujoco model="hold">
  <option timestep="{timestep}"/>
  <custom><text name="simx:slide" data="mode=velocity max_velocity=1"/></custom>
  <worldbody>
    <body name="carriage">
      <joint name="slide" type="slide" axis="1 0 0" range="-1 1"/>
      <geom type="box" size="{half} {half} {half}" mass="{mass}"/>
    </body>
  </worldbody>
  <actuator><general name="m" joint="slide" forcelimited="true" forcerange="-{force} {force}"/></actuator>
</mujoco>
"""


def _carriage(tmp_path, timestep: float = 0.005, half: float = 0.05, mass: float = 1.0, force: float = 10.0):
    """A slide joint with a velocity motor of ``force`` N on a ``mass`` kg box: (simulation,
    world, script API, the joint's handle), the simulation started."""
    (tmp_path / "hold.xml").write_text(SCENE.format(timestep=timestep, half=half, mass=mass, force=force))
    sim = Simulation(tmp_path / "hold.xml", dt=0.05, realtime=False)
    w = sim.world
    api = script_sim(w, w.resolve("carriage").handle, sim.signals, simulation=sim)
    slide = api.getObject("/slide")
    sim.start()
    return sim, w, api, slide


@pytest.mark.parametrize("load", [2.0, 8.0])  # N along the slide, below the motor's 10 N
def test_a_stopped_velocity_motor_holds_against_a_load(tmp_path, load):
    sim, w, api, slide = _carriage(tmp_path)
    try:
        api.setJointTargetVelocity(slide, 0.1)
        for _ in range(5):
            sim.step()
        api.setJointTargetVelocity(slide, 0.0)
        w.data.xfrc_applied[w.model.body("carriage").id, 0] = load  # a steady push along +x
        sim.step()
        moves = []
        for _ in range(10):
            before = api.getJointPosition(slide)
            sim.step()
            moves.append(abs(api.getJointPosition(slide) - before))
        assert max(moves) < 1e-5, moves  # still, as PyRep's Gripper.actuate judges it (0.01 mm)
        assert api.getJointForce(slide) == pytest.approx(-load, rel=0.01)  # the motor bears the load
        w.data.xfrc_applied[w.model.body("carriage").id, 0] = 15.0  # more than the motor's force
        before = api.getJointPosition(slide)
        for _ in range(5):
            sim.step()
        assert api.getJointPosition(slide) - before > 0.01  # it gives way
        assert api.getJointForce(slide) == pytest.approx(-10.0, rel=0.01)  # with its whole force
    finally:
        sim.close()


def test_a_light_joint_told_to_stop_brakes_without_reversing(tmp_path):
    """A 0.05 kg finger with a 50 N motor, moving at 0.5 m/s, told to stop: V-REP's velocity
    motor is a constraint bounded by the maximum force, so it brakes the joint to rest (at most
    50 N, here within a millisecond) and never drives it the other way. A servo whose force is
    clipped to the maximum is explicit in MuJoCo: 50 N over a 2 ms substep changes the finger's
    velocity by 2 m/s, four times what it had, and the joint ran backwards at 0.5 m/s for ever."""
    sim, w, api, slide = _carriage(tmp_path, timestep=0.002, half=0.01, mass=0.05, force=50.0)
    try:
        api.setJointTargetVelocity(slide, 0.5)
        for _ in range(3):
            sim.step()
        assert w.data.qvel[0] == pytest.approx(0.5, abs=1e-3)
        api.setJointTargetVelocity(slide, 0.0)
        stopped_at = api.getJointPosition(slide)
        for _ in range(6):
            sim.step()
            assert abs(float(w.data.qvel[0])) < 1e-3, float(w.data.qvel[0])
            assert abs(api.getJointForce(slide)) <= 50.0 + 1e-6
        # 0.5 m/s braked at 1000 m/s^2 covers 0.125 mm; no step backwards
        assert 0.0 <= api.getJointPosition(slide) - stopped_at < 1e-3
    finally:
        sim.close()
