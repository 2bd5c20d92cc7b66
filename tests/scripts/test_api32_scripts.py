"""Issue 32's programs as child scripts, in Lua (reach.lua) and Python (reach.py), on
tests/scenes/api32/arm.xml: an IK reach with simIK that the arm's motors then follow, a
collision and distance check against an obstacle, and a line seen by an explicitly handled
vision sensor with readVisionSensor."""

from __future__ import annotations

import math

import pytest

from conftest import ROOT
from simx_server.scene.simulation import Simulation

ARM = ROOT / "tests" / "scenes" / "api32" / "arm.xml"
CHILD = 1


@pytest.fixture
def sim():
    s = Simulation(ARM, realtime=False, allow_python_scripts=True)
    s.start()
    yield s
    s.stop()
    s.close()


def call(sim, script, function, floats=()):
    return sim.scripts.call(script, CHILD, function, [], [float(f) for f in floats], [], b"")


def tip(sim):
    return sim.world.position(sim.world.resolve("tip").handle, -1)


@pytest.mark.parametrize("script", ["Reach", "PyReach"])
def test_ik_reach_then_the_motors_follow(sim, script):
    ints, q, _, _ = call(sim, script, "reach", [0.45, 0.35])
    assert ints == [1, 2]  # simIK.result_success, two joints
    # forward kinematics of the solution: the tip on the target
    x = 0.4 * math.cos(q[0]) + 0.3 * math.cos(q[0] + q[1])
    y = 0.4 * math.sin(q[0]) + 0.3 * math.sin(q[0] + q[1])
    assert (x, y) == pytest.approx((0.45, 0.35), abs=1e-3)
    for _ in range(60):  # 3 s: the position motors get there
        sim.step()
    assert tip(sim)[:2] == pytest.approx([0.45, 0.35], abs=5e-3)


@pytest.mark.parametrize("script", ["Reach", "PyReach"])
def test_reach_stops_on_collision_and_distance(sim, script):
    hit, dist, _, _ = call(sim, script, "contact")
    assert hit == [0] and dist[0] > 0.05  # the arm lies along x, the obstacle at (0.35, 0.45)
    call(sim, script, "reach", [0.35, 0.45])  # into the obstacle: stop when touching or close
    for _ in range(100):
        sim.step()
        hit, dist, _, _ = call(sim, script, "contact")
        if hit == [1] or dist[0] < 0.02:
            break
    assert hit == [1] or dist[0] < 0.02


@pytest.mark.parametrize("script", ["Reach", "PyReach"])
def test_line_seen_with_read_vision_sensor(sim, script):
    sim.step()
    (col, width), (avg_red,), _, _ = call(sim, script, "see")
    assert width == 32 and abs(col - 15.5) <= 2  # the line runs through the middle of the view
    assert 0.3 < avg_red < 1.0  # mostly the light patch
