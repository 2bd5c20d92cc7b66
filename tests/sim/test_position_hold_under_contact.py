"""A joint in position control holds its target under a contact's load, as V-REP's position loop
does: CoppeliaSim hands the engine a velocity motor of target velocity ``P e / 5 ms`` bounded by
the maximum force (``CJoint::handleDynJointControl``), a constraint, so at rest ``e`` is 0 whatever
the load below that force. simx's servo alone yielded by the load over its gain (a platform
carrying a 2 kg box sank 5 mm; RLBench's arm, its fingers closed on a door handle, gave way under
the handle's push and the handle slipped out). Engine-level, in-process."""

from __future__ import annotations

import pytest

from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read

SCENE = """<mujoco model="lift">
  <option timestep="0.005"/>
  <custom><text name="simx:lift" data="mode=position max_velocity=1 pid_p=0.1"/></custom>
  <worldbody>
    <body name="platform" pos="0 0 0.5">
      <joint name="lift" type="slide" axis="0 0 1" range="-0.4 0.4"/>
      <geom type="box" size="0.1 0.1 0.01" mass="1"/>
    </body>
    <body name="load" pos="0 0 0.56">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05" mass="{mass}"/>
    </body>
  </worldbody>
  <actuator><general name="m" joint="lift" forcelimited="true" forcerange="-{force} {force}"/></actuator>
</mujoco>
"""


def _platform(tmp_path, mass: float, force: float):
    """A slide joint in position control (target 0, ``force`` N) under a ``mass`` kg box that
    rests on it: (simulation, script API, the joint's handle), started."""
    (tmp_path / "lift.xml").write_text(SCENE.format(mass=mass, force=force))
    sim = Simulation(tmp_path / "lift.xml", dt=0.05, realtime=False)
    w = sim.world
    api = script_sim(w, w.resolve("platform").handle, sim.signals, simulation=sim)
    lift = api.getObject("/lift")
    sim.start()
    return sim, api, lift


def test_a_position_motor_holds_its_target_under_a_resting_load(tmp_path):
    sim, api, lift = _platform(tmp_path, mass=2.0, force=100.0)
    try:
        for _ in range(40):  # 2 s: the box lands and rests on the platform
            sim.step()
        positions = []
        for _ in range(10):
            sim.step()
            positions.append(api.getJointPosition(lift))
        assert max(abs(p) for p in positions) < 2e-4, positions  # at its target (0), not 5 mm below
        # the motor bears the platform's and the box's weight (N, along +z)
        assert api.getJointForce(lift) == pytest.approx(3.0 * 9.81, rel=0.05)
    finally:
        sim.close()


def test_a_load_beyond_the_maximum_force_makes_it_give_way(tmp_path):
    sim, api, lift = _platform(tmp_path, mass=5.0, force=30.0)  # 59 N of weight on a 30 N motor
    try:
        for _ in range(20):
            sim.step()
        assert api.getJointPosition(lift) < -0.1  # it sinks, with its whole force
        assert abs(api.getJointForce(lift)) == pytest.approx(30.0, rel=0.01)
    finally:
        sim.close()
