"""``sim.setJointDependency`` / ``sim.getJointDependency`` on joints whose ``ref`` is not 0 (a
converted ``.ttt`` gives every joint its position in the file as ``ref``): V-REP's relation is
on positions, ``q = offset + mult * q_master`` (simx_server/sim/mechanisms.py)."""

from __future__ import annotations

import pytest

from simx_client.protocol import ArgumentError
from simx_server.scene.simulation import Simulation
from simx_server.api import script_sim

pytestmark = pytest.mark.renderers_on_demand  # no image is read here

SCENE = """<mujoco>
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="base">
      <body name="arm"><joint name="master" type="hinge" axis="0 0 1" ref="0.3"/>
        <geom type="box" size="0.1 0.02 0.02" pos="0.1 0 0" mass="0.5"/></body>
      <body name="slider" pos="0 0.3 0"><joint name="follower" type="slide" axis="1 0 0" ref="0.1"/>
        <geom type="box" size="0.02 0.02 0.02" mass="0.2"/></body>
      <body name="third_body" pos="0 0.6 0"><joint name="third" type="slide" axis="1 0 0"/>
        <geom type="box" size="0.02 0.02 0.02" mass="0.2"/></body>
    </body>
  </worldbody>
  <actuator><position name="master_servo" joint="master" kp="50"/></actuator>
</mujoco>
"""


@pytest.fixture()
def rig(tmp_path):
    xml = tmp_path / "dep.xml"
    xml.write_text(SCENE)
    sim = Simulation(xml, realtime=False)
    sim.start()
    api = script_sim(sim.world, sim.world.resolve("base").handle, sim.signals, simulation=sim)
    yield sim, api
    sim.stop()
    sim.close()


def test_a_dependency_holds_on_positions_with_refs(rig):
    sim, api = rig
    master, follower = api.getObject("/master"), api.getObject("/follower")
    api.setJointDependency(follower, master, 0.05, 0.5)
    assert api.getJointDependency(follower) == (master, pytest.approx(0.05), pytest.approx(0.5))
    api.setJointTargetPosition(master, 0.8)
    for _ in range(40):
        sim.step()
    q_master, q_follower = api.getJointPosition(master), api.getJointPosition(follower)
    assert q_master == pytest.approx(0.8, abs=0.01)
    assert q_follower == pytest.approx(0.05 + 0.5 * q_master, abs=1e-3)  # not relative to the refs


def test_self_dependency_is_refused_and_a_loop_is_cut_as_vrep_does(rig):
    _, api = rig
    master, follower, third = (api.getObject(p) for p in ("/master", "/follower", "/third"))
    with pytest.raises(ArgumentError, match="itself"):
        api.setJointDependency(follower, follower, 0, 1)
    api.setJointDependency(follower, master, 0, 1)
    api.setJointDependency(third, follower, 0, 2)
    api.setJointDependency(master, third, 0, 1)  # master <- third <- follower <- master: cut
    assert api.getJointDependency(master) == (third, pytest.approx(0.0), pytest.approx(1.0))
    assert api.getJointDependency(third) == (follower, pytest.approx(0.0), pytest.approx(2.0))
    assert api.getJointDependency(follower)[0] == -1  # it depended on the new dependent: cut
    api.setJointDependency(master, -1, 0, 1)
    assert api.getJointDependency(master)[0] == -1
