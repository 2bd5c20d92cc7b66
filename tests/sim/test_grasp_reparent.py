"""Grasping by re-parenting a dynamic shape (issue 50, item A): ``sim.setObjectParent(part,
attachPoint, true)`` holds a free body to what carries the attach point (a weld switched on at
run time), the logical tree shows the new parent, ``setObjectParent(part, -1, true)`` lets it
fall again; stopping the simulation lets every part go. In-process, through the sim API table
(``SIM["setObjectParent"]``, what Lua/Python scripts and the ZMQ door call), on an MJCF scene and
on a .ttt one, and through a real server's ZMQ door."""

from __future__ import annotations

import sys

import pytest

from conftest import ROOT, ServerProcess, free_port
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation

sys.path.insert(0, str(ROOT / "tests" / "scene" / "ttt"))
import tttwriter as W  # noqa: E402
from simx_server.scene.ttt import convert, reader  # noqa: E402

pytestmark = pytest.mark.renderers_on_demand  # no image is read

# A gripper on a vertical slide (position-controlled: the slide's motor), its attach point a
# site 6 cm below its palm; a 5 cm cube resting on the floor under it, touching nothing else.
SCENE = """<mujoco model="grasp">
  <option timestep="0.005"/>
  <custom><text name="simx:lift" data="mode=position max_velocity=0.5"/></custom>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="gripper" pos="0 0 0.25">
      <joint name="lift" type="slide" axis="0 0 1" range="-0.2 0.5"/>
      <geom name="palm" type="box" size="0.05 0.05 0.01" mass="0.5"/>
      <site name="attach" pos="0 0 -0.06"/>
    </body>
    <body name="cube" pos="0 0 0.025">
      <freejoint/>
      <geom type="box" size="0.025 0.025 0.025" mass="0.1"/>
    </body>
    <body name="other" pos="0.5 0 0.025">
      <freejoint/>
      <geom type="box" size="0.025 0.025 0.025" mass="0.1"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture
def scene(tmp_path):
    f = tmp_path / "grasp.xml"
    f.write_text(SCENE)
    sim = Simulation(f, dt=0.05, realtime=False)
    sim.start()
    api = script_sim(sim.world, sim.world.resolve("gripper").handle, sim.signals, simulation=sim)
    yield sim, api
    sim.close()


def _run(sim, seconds):
    for _ in range(round(seconds / sim.world.dt)):
        sim.step()


def test_a_grasped_cube_is_lifted_and_falls_when_released(scene):
    sim, api = scene
    cube, attach, lift = api.getObject("/cube"), api.getObject("/attach"), api.getObject("/lift")
    _run(sim, 0.5)
    z0 = api.getObjectPosition(cube, -1)[2]
    assert z0 == pytest.approx(0.025, abs=2e-3)                            # resting on the floor
    api.setObjectParent(cube, attach, True)
    assert api.getObjectParent(cube) == attach
    assert cube in api.getObjectsInTree(attach)
    rel = api.getObjectPosition(cube, attach)
    api.setJointTargetPosition(lift, 0.3)                                  # lift by 0.3 m
    _run(sim, 2.0)
    assert api.getJointPosition(lift) == pytest.approx(0.3, abs=1e-3)
    assert api.getObjectPosition(cube, -1)[2] == pytest.approx(z0 + 0.3, abs=2e-3)
    assert api.getObjectPosition(cube, attach) == pytest.approx(rel, abs=1e-4)  # held by the weld
    api.setObjectParent(cube, -1, True)                                    # release
    assert api.getObjectParent(cube) == -1
    assert cube not in api.getObjectsInTree(attach)
    _run(sim, 0.1)
    assert api.getObjectPosition(cube, -1)[2] < z0 + 0.3 - 0.02            # falling
    _run(sim, 1.5)
    assert api.getObjectPosition(cube, -1)[2] == pytest.approx(0.025, abs=2e-3)  # back on the floor


def test_regrasp_is_not_a_recompile_and_stop_lets_go(scene):
    sim, api = scene
    w = sim.world
    cube, attach, lift = api.getObject("/cube"), api.getObject("/attach"), api.getObject("/lift")
    api.setObjectParent(cube, attach, True)
    model = w.model
    api.setObjectParent(cube, -1, True)
    api.setObjectParent(cube, attach, True)                                # the weld is there already
    assert w.model is model
    api.setObjectParent(cube, api.getObject("/other"), True)               # another holder: same weld
    assert w.model is model and api.getObjectParent(cube) == api.getObject("/other")
    api.setObjectParent(cube, attach, True)
    api.setJointTargetPosition(lift, 0.2)
    _run(sim, 1.0)
    assert api.getObjectPosition(cube, -1)[2] > 0.15
    sim.stop()                                                             # initial state: parent and pose
    assert api.getObjectParent(cube) == -1 and not w.grasps
    assert api.getObjectPosition(cube, -1) == pytest.approx([0, 0, 0.025], abs=1e-9)
    sim.start()
    _run(sim, 0.5)
    assert api.getObjectPosition(cube, -1)[2] == pytest.approx(0.025, abs=2e-3)  # not held


def test_an_edit_keeps_the_grasp_and_a_teleport_carries_the_part(scene):
    sim, api = scene
    cube, attach, lift = api.getObject("/cube"), api.getObject("/attach"), api.getObject("/lift")
    api.setObjectParent(cube, attach, True)
    rel = api.getObjectPosition(cube, attach)
    api.createDummy(0.01)                                                  # an edit: a new model
    assert api.getObjectParent(cube) == attach
    api.setJointPosition(lift, 0.4)                                        # the holder jumps
    assert api.getObjectPosition(cube, attach) == pytest.approx(rel, abs=1e-9)
    api.setObjectPosition(cube, attach, [0.01, 0, -0.02])                  # placed in its parent's frame
    assert api.getObjectPosition(cube, attach) == pytest.approx([0.01, 0, -0.02], abs=1e-9)
    _run(sim, 0.5)
    assert api.getObjectPosition(cube, attach) == pytest.approx([0.01, 0, -0.02], abs=1e-4)  # the weld holds it there


def test_without_keep_in_place_the_pose_relative_to_the_parent_is_kept(scene):
    sim, api = scene
    cube, attach = api.getObject("/cube"), api.getObject("/attach")
    before = api.getObjectPosition(cube, -1)                               # relative to its parent, the world
    api.setObjectParent(cube, attach, False)
    assert api.getObjectPosition(cube, attach) == pytest.approx(before, abs=1e-9)
    api.setObjectParent(cube, -1, False)
    assert api.getObjectPosition(cube, -1) == pytest.approx(before, abs=1e-9)


def test_a_ttt_dynamic_cube_grasped_by_a_gripper_dummy(tmp_path):
    body = (W.joint(1, -1, "Lift", (0, 0, 0.3), kind=11)                  # a prismatic joint along z
            + W.cuboid_shape(2, 1, "Palm", (0.1, 0.1, 0.02), (0, 0, 0), mass=0.5)
            + W.dummy(3, 2, "Attach", (0, 0, -0.1))
            + W.cuboid_shape(4, -1, "Part", (0.05, 0.05, 0.05), (0, 0, 0.2), mass=0.1))
    f = tmp_path / "grasp.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "grasp")
    sim = Simulation(xml, dt=0.05, realtime=False)
    try:
        sim.start()
        w = sim.world
        api = script_sim(w, w.resolve("Palm").handle, sim.signals, simulation=sim)
        part, attach, lift = w.resolve("Part").handle, w.resolve("Attach").handle, w.resolve("Lift").handle
        api.setObjectParent(part, attach, True)
        assert api.getObjectParent(part) == attach
        z = api.getObjectPosition(part, -1)[2]
        api.setJointTargetPosition(lift, 0.2)
        _run(sim, 2.0)
        assert api.getObjectPosition(part, -1)[2] == pytest.approx(z + 0.2, abs=5e-3)  # held, not fallen
        api.setObjectParent(part, -1, True)
        _run(sim, 0.3)
        assert api.getObjectPosition(part, -1)[2] < z                       # falls once released
    finally:
        sim.close()


def test_grasp_through_the_zmq_door(tmp_path, official):
    (tmp_path / "grasp.xml").write_text(SCENE)
    port = free_port()
    srv = ServerProcess(str(tmp_path / "grasp.xml"), "--zmq-port", str(port), "--stopped", renderers="on-demand")
    try:
        sim = official(port).require("sim")
        sim.setStepping(True)
        sim.startSimulation()
        cube, attach, lift = sim.getObject("/cube"), sim.getObject("/attach"), sim.getObject("/lift")
        z0 = sim.getObjectPosition(cube, -1)[2]
        sim.setObjectParent(cube, attach, True)
        assert sim.getObjectParent(cube) == attach
        sim.setJointTargetPosition(lift, 0.2)
        for _ in range(40):
            sim.step()
        assert sim.getObjectPosition(cube, -1)[2] == pytest.approx(z0 + 0.2, abs=5e-3)
        sim.setObjectParent(cube, -1, True)
        for _ in range(4):
            sim.step()
        assert sim.getObjectPosition(cube, -1)[2] < z0 + 0.2 - 0.01
        sim.stopSimulation()
    finally:
        log = srv.stop()
    assert "Traceback" not in log, log[-3000:]


def test_released_to_a_static_parent_the_part_falls_under_it(tmp_path):
    # PyRep's Gripper.release gives the part back to its old parent, often a task's static dummy
    f = tmp_path / "grasp.xml"
    f.write_text(SCENE.replace('<geom name="floor"', '<site name="task_base" pos="1 1 0"/>\n    <geom name="floor"'))
    sim = Simulation(f, dt=0.05, realtime=False)
    try:
        sim.start()
        api = script_sim(sim.world, sim.world.resolve("gripper").handle, sim.signals, simulation=sim)
        cube, attach, lift = api.getObject("/cube"), api.getObject("/attach"), api.getObject("/lift")
        base = api.getObject("/task_base")
        api.setObjectParent(cube, base, True)  # a static parent: the cube stays free
        assert api.getObjectParent(cube) == base
        api.setObjectParent(cube, attach, True)
        api.setJointTargetPosition(lift, 0.2)
        _run(sim, 1.0)
        z = api.getObjectPosition(cube, -1)[2]
        assert z == pytest.approx(0.225, abs=5e-3)
        api.setObjectParent(cube, base, True)  # release
        assert api.getObjectParent(cube) == base and cube in api.getObjectsInTree(base)
        api.createDummy(0.01)  # an edit keeps that parent
        assert api.getObjectParent(cube) == base
        _run(sim, 1.5)
        assert api.getObjectPosition(cube, -1)[2] == pytest.approx(0.025, abs=2e-3)  # fell to the floor
        sim.stop()
        assert api.getObjectParent(cube) == -1  # the parent at the start
    finally:
        sim.close()


def test_the_first_grasp_makes_every_part_graspable_without_recompile(scene):
    sim, api = scene
    w = sim.world
    api.setObjectParent(api.getObject("/cube"), api.getObject("/attach"), True)  # the one recompile
    model = w.model
    api.setObjectParent(api.getObject("/other"), api.getObject("/attach"), True)  # another part
    assert w.model is model and api.getObjectParent(api.getObject("/other")) == api.getObject("/attach")


def test_a_dynamic_shape_under_a_free_one_stays_free_unless_that_one_is_held(scene):
    """CoppeliaSim's engines simulate a dynamic shape hung from another dynamic shape by itself
    (RLBench's pour_from_cup_to_cup hangs 20 drops from its cup); a free body that is itself
    held (grasped) carries what is hung from it."""
    sim, api = scene
    cube, other, attach, lift = (api.getObject(p) for p in ("/cube", "/other", "/attach", "/lift"))
    _run(sim, 0.2)
    api.setObjectPosition(other, -1, [0.5, 0, 0.3])
    api.setObjectParent(other, cube, True)                 # the cube is free and not held
    assert api.getObjectParent(other) == cube
    _run(sim, 0.5)
    assert api.getObjectPosition(other, -1)[2] == pytest.approx(0.025, abs=2e-3)  # it fell by itself
    api.setObjectParent(cube, attach, True)                # now the cube is held
    api.setObjectParent(other, cube, True)
    api.setJointTargetPosition(lift, 0.3)
    _run(sim, 2.0)
    assert api.getObjectPosition(other, -1)[2] > 0.25  # carried up with it (0.5 m out on two welds: it sags)


# A gripper on a horizontal slide (position-controlled, 30 N at most), a cube held 8 cm below
# its palm, and a 2 mm wall in the cube's way that the gripper itself passes above.
WALL_SCENE = """<mujoco model="wall">
  <option timestep="0.005"/>
  <custom><text name="simx:slide" data="mode=position max_velocity=0.2"/></custom>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <geom name="wall" type="box" pos="0.1 0 0.05" size="0.001 0.2 0.05"/>
    <body name="gripper" pos="0 0 0.2">
      <joint name="slide" type="slide" axis="1 0 0" range="-0.5 0.5"/>
      <geom name="palm" type="box" size="0.05 0.05 0.01" mass="0.5"/>
      <site name="attach" pos="0 0 -0.06"/>
    </body>
    <body name="cube" pos="0 0 0.06">
      <freejoint/>
      <geom type="box" size="0.02 0.02 0.02" mass="0.1"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_held_part_is_stopped_by_what_it_meets(tmp_path):
    """A physics step leaves a held part where the engine put it (CoppeliaSim reports a dynamic
    shape's pose from the engine, its force-sensor link a constraint solved with the contacts):
    the wall stops the cube, and the gripper through it; put back on its holder after each
    step, the cube went through the wall with the gripper."""
    f = tmp_path / "wall.xml"
    f.write_text(WALL_SCENE)
    sim = Simulation(f, dt=0.05, realtime=False)
    try:
        sim.start()
        api = script_sim(sim.world, sim.world.resolve("gripper").handle, sim.signals, simulation=sim)
        cube, attach, slide = api.getObject("/cube"), api.getObject("/attach"), api.getObject("/slide")
        api.setObjectParent(cube, attach, True)
        api.setJointMaxForce(slide, 30.0)
        api.setJointTargetPosition(slide, 0.3)
        for _ in range(40):
            sim.step()
            assert api.getObjectPosition(cube, -1)[0] + 0.02 < 0.099 + 2e-3     # never into the wall
        assert api.getJointPosition(slide) < 0.2                               # the gripper is held back
        assert api.getObjectParent(cube) == attach
    finally:
        sim.close()


def test_a_held_part_keeps_its_orientation_under_a_torque(tmp_path):
    """The grasp weld holds the part's orientation as firmly as MuJoCo allows (its highest
    impedance): a 1 kg bar, 40 cm long, held at its middle, turns about 1 degree under 10 N m
    (at 99 % impedance, 62 degrees); CoppeliaSim's force-sensor link is rigid."""
    f = tmp_path / "torque.xml"
    f.write_text(SCENE.replace('<geom type="box" size="0.025 0.025 0.025" mass="0.1"/>',
                               '<geom type="box" size="0.2 0.01 0.01" mass="1.0"/>', 1))
    sim = Simulation(f, dt=0.05, realtime=False)
    try:
        sim.start()
        api = script_sim(sim.world, sim.world.resolve("gripper").handle, sim.signals, simulation=sim)
        bar, attach, lift = api.getObject("/cube"), api.getObject("/attach"), api.getObject("/lift")
        api.setObjectParent(bar, attach, True)
        api.setJointTargetPosition(lift, 0.2)
        _run(sim, 1.0)
        before = api.getObjectOrientation(bar, attach)
        for _ in range(10):
            api.addForceAndTorque(bar, [0.0, 0.0, 0.0], [0.0, 10.0, 0.0])
            sim.step()
        turned = [a - b for a, b in zip(api.getObjectOrientation(bar, attach), before)]
        assert abs(turned[1]) < 0.035                                          # under 2 degrees
        assert api.getObjectPosition(bar, attach)[2] == pytest.approx(-0.165, abs=1e-3)
    finally:
        sim.close()
