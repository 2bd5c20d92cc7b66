"""``sim.moveToConfig`` / ``sim.moveToPose`` in threaded child scripts, Lua and Python: CoppeliaSim
4.3-4.5's positional forms with a callback (a Lua function, a Python callable) and the 4.6 map
form, on the facade's one implementation (simx_server/scripts/facade_motion.py): the callback runs
once per step, the thread yields between increments, the call returns the end state."""

from __future__ import annotations

import pytest

from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

CHILD = 1

SCENE = """<mujoco model="movers">
  <option timestep="0.005" gravity="0 0 0"/>
  <worldbody>
    <site name="LuaMover" pos="-1 0 0" size="0.01"/>
    <site name="PyMover" pos="-1 0.2 0" size="0.01"/>
    <site name="LuaMarker" pos="0 0 0.2" size="0.01"/>
    <site name="PyMarker" pos="0 0 0.2" size="0.01"/>
    <body name="LuaArm" pos="0 0.5 0">
      <joint name="LuaJoint" type="hinge" axis="0 0 1" damping="1"/>
      <geom type="box" size="0.2 0.02 0.02" pos="0.2 0 0" mass="1"/>
    </body>
    <body name="PyArm" pos="0 -0.5 0">
      <joint name="PyJoint" type="hinge" axis="0 0 1" damping="1"/>
      <geom type="box" size="0.2 0.02 0.02" pos="0.2 0 0" mass="1"/>
    </body>
  </worldbody>
  <actuator>
    <position joint="LuaJoint" kp="200" kv="10"/>
    <position joint="PyJoint" kp="200" kv="10"/>
  </actuator>
  <custom>
    <text name="simx:LuaMover" data="child_script=mover.lua"/>
    <text name="simx:PyMover" data="child_script=mover.py"/>
  </custom>
</mujoco>
"""

LUA = """
done = 0
function sysCall_thread()
    sim.setThreadAutomaticSwitch(false)  -- no switch at a getObject when the machine is slow: see the test
    local j, marker = sim.getObject('/LuaJoint'), sim.getObject('/LuaMarker')
    calls, times = 0, {}
    local pos, vel, accel, left = sim.moveToConfig(-1, {0}, nil, nil, {1}, {2}, {20}, {0.6}, nil,
        function(q, v, a, handles)
            calls = calls + 1
            times[#times + 1] = sim.getSimulationTime()
            sim.setJointTargetPosition(handles[1], q[1])
        end, {j})
    endPos, span, left1 = pos[1], times[#times] - times[1], left
    poses = 0
    local pose, left2 = sim.moveToPose(-1, {0, 0, 0.2, 0, 0, 0, 1}, {0.5}, {2}, {40}, {0.3, 0, 0.2, 0, 0, 0, 1},
        function(p, v, a, h) poses = poses + 1 sim.setObjectPose(h, -1, p) end, marker, {1, 1, 1, 0.1})
    poseX = pose[1]
    local out = sim.moveToConfig({joints = {j}, targetPos = {-0.3}, maxVel = {1}, maxAccel = {2}, maxJerk = {20}})
    mapEnd = out.pos[1]
    done = 1
end

function results(ints, floats, strings, buf)
    return {done, calls or 0, poses or 0}, {endPos or 0, span or 0, poseX or 0, mapEnd or 0}
end

function outside(ints, floats, strings, buf)
    local ok, err = pcall(sim.moveToConfig, {joints = {sim.getObject('/LuaJoint')}, targetPos = {1}})
    return {}, {}, {tostring(err)}
end
"""

PY = """
done = 0
calls, poses, times = 0, 0, []
end_pos = span = pose_x = map_end = 0.0


def sysCall_thread():
    global calls, poses, end_pos, span, pose_x, map_end, done
    sim.setThreadAutomaticSwitch(False)
    j, marker = sim.getObject('/PyJoint'), sim.getObject('/PyMarker')

    def follow(q, v, a, handles):
        global calls
        calls += 1
        times.append(sim.getSimulationTime())
        sim.setJointTargetPosition(handles[0], q[0])

    def place(p, v, a, h):
        global poses
        poses += 1
        sim.setObjectPose(h, -1, p)

    pos, vel, accel, left = sim.moveToConfig(-1, [0], None, None, [1], [2], [20], [0.6], None, follow, [j])
    end_pos, span = pos[0], times[-1] - times[0]
    pose, left2 = sim.moveToPose(-1, [0, 0, 0.2, 0, 0, 0, 1], [0.5], [2], [40], [0.3, 0, 0.2, 0, 0, 0, 1], place,
                                 marker, [1, 1, 1, 0.1])
    pose_x = pose[0]
    out = sim.moveToConfig({'joints': [j], 'targetPos': [-0.3], 'maxVel': [1], 'maxAccel': [2], 'maxJerk': [20]})
    map_end = out['pos'][0]
    done = 1


def results(ints, floats, strings, buf):
    return [done, calls, poses], [end_pos, span, pose_x, map_end], [], b''


def outside(ints, floats, strings, buf):
    try:
        sim.moveToConfig({'joints': [sim.getObject('/PyJoint')], 'targetPos': [1]})
    except Exception as exc:
        return [], [], [str(exc)], b''
    return [], [], ['no error'], b''
"""


@pytest.fixture
def sim(tmp_path):
    (tmp_path / "movers.xml").write_text(SCENE)
    (tmp_path / "mover.lua").write_text(LUA)
    (tmp_path / "mover.py").write_text(PY)
    s = Simulation(tmp_path / "movers.xml", realtime=False, allow_python_scripts=True)
    s.start()
    yield s
    s.stop()
    s.close()


@pytest.mark.parametrize("script,joint", [("LuaMover", "LuaJoint"), ("PyMover", "PyJoint")])
def test_positional_motions_with_a_callback_in_a_thread(sim, script, joint):
    dt = sim.world.dt
    for _ in range(400):  # 20 s at most; the three motions take about 4 s
        ints, floats, _, _ = sim.scripts.call(script, CHILD, "results", [], [], [], b"")
        if ints[0] == 1:
            break
        sim.step()
    (done, calls, poses), (end_pos, span, pose_x, map_end) = ints, floats
    assert done == 1
    assert end_pos == pytest.approx(0.6) and map_end == pytest.approx(-0.3)
    # one callback per resume of the thread, one step apart; the thread's first two resumes (at the
    # start, then before the first step) both come at t = 0. The threads forbid automatic switches:
    # with them, a first resume that used its 2 ms slice before the motion began (a loaded machine)
    # switched at a getObject, and the motion's first callback came only at the second resume.
    assert calls >= 20 and span == pytest.approx((calls - 2) * dt)
    assert poses >= 10 and pose_x == pytest.approx(0.3)
    marker = sim.world.resolve(script.replace("Mover", "Marker")).handle
    assert sim.world.position(marker, -1) == pytest.approx([0.3, 0, 0.2], abs=1e-6)
    for _ in range(20):
        sim.step()
    assert sim.world.joint_position(sim.world.resolve(joint).handle) == pytest.approx(-0.3, abs=0.01)


@pytest.mark.parametrize("script", ["LuaMover", "PyMover"])
def test_motions_outside_a_thread_are_refused(sim, script):
    _, _, strings, _ = sim.scripts.call(script, CHILD, "outside", [], [], [], b"")
    assert "threaded script" in strings[0]
