"""``sim.resetDynamicObject`` (issue 19 part 5): V-REP scene scripts call it before teleporting a
robot; the object's tree stops (zero velocities) with its contacts rebuilt. Lua (4.x and the
3.x name) and Python scripts."""

from __future__ import annotations

import pytest

from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

CHILD = 1
SCENE = """<mujoco model="reset">
  <option timestep="0.002"/>
  <worldbody>
    <body name="Robot" pos="0 0 1"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="1"/>
      <body name="Arm" pos="0.2 0 0"><joint name="ArmJoint" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.1"/></body>
    </body>
    <body name="Other" pos="1 0 1"><freejoint/><geom type="sphere" size="0.05" mass="1"/></body>
    <body name="LuaBox" pos="2 0 0"><geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/></body>
    <body name="PyBox" pos="2 1 0"><geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/></body>
  </worldbody>
  <custom>
    <text name="simx:LuaBox" data="child_script=reset.lua"/>
    <text name="simx:PyBox" data="child_script=reset.py"/>
  </custom>
</mujoco>
"""
LUA = """
function reset(ints, floats, strings, buffer)
  local h = sim.getObjectHandle(strings[1])
  if ints[1] == 3 then simResetDynamicObject(h) else sim.resetDynamicObject(h) end
  return {}, {}, {}, ""
end
"""
PY = """
def reset(ints, floats, strings, buffer):
    sim.resetDynamicObject(sim.getObjectHandle(strings[0]))
    return [], [], [], b""
"""


@pytest.fixture
def sim(tmp_path):
    (tmp_path / "scene.xml").write_text(SCENE)
    (tmp_path / "reset.lua").write_text(LUA)
    (tmp_path / "reset.py").write_text(PY)
    s = Simulation(tmp_path / "scene.xml", dt=0.05, realtime=False, allow_python_scripts=True)
    s.start()
    yield s
    s.close()


def speeds(sim, name):
    w = sim.world
    body = w.resolve(name).body
    m = w.model
    tree = [b for b in range(m.nbody) if b == body or m.body_parentid[b] == body]
    dofs = [i for i in range(m.nv) if m.dof_bodyid[i] in tree]
    return abs(sim.world.data.qvel[dofs]).max()


@pytest.mark.parametrize("script,version", [("LuaBox", 4), ("LuaBox", 3), ("PyBox", 4)])
def test_reset_dynamic_object_stops_the_tree_and_leaves_the_others(sim, script, version):
    for _ in range(5):  # falling: the robot and the other ball move
        sim.step()
    assert speeds(sim, "Robot") > 0.5 and speeds(sim, "Other") > 0.5
    sim.scripts.call(script, CHILD, "reset", [version], [], ["Robot"], b"")
    assert speeds(sim, "Robot") == 0  # the robot and its arm's joint
    assert speeds(sim, "Other") > 0.5  # not in its tree
