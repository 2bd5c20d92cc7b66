"""A ``.ttt``'s collision and distance objects (V-REP's ``COL`` / ``DST`` records: named pairs of
objects, collections or "all other objects") converted and served by their names (issue 41):
``simxGetDistanceHandle`` / ``simxReadDistance`` and ``simxGetCollisionHandle`` /
``simxReadCollision`` on a real server, and the 3.x script calls (``simHandleDistance``...)."""

from __future__ import annotations

import mujoco
import pytest

import tttwriter as W

try:
    from conftest import ServerProcess
except ImportError:
    from tests.conftest import ServerProcess

import vrep
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here
B = vrep.simx_opmode_blocking

SCRIPT = """
function sysCall_init()
    local d = simGetDistanceHandle('Distance#')
    local result, distance = simHandleDistance(d)
    simSetFloatSignal('distance', distance)
    simSetIntegerSignal('distance_result', result)
    local r2, d2 = simReadDistance(simGetDistanceHandle('armDistance'))
    simSetFloatSignal('arm_distance', d2)
    simSetIntegerSignal('collides', simReadCollision(simGetCollisionHandle('targetCollision')))
    simSetIntegerSignal('all', simHandleDistance(sim_handle_all))
end
"""


def _scene() -> bytes:
    """A robot 0.8 m from a target, a wall touching the robot; a collection "Arm" (the robot's
    tree); a distance object robot-target, one collection-target (with a threshold), a collision
    object robot-target and one robot-all others, and one whose entity is gone."""
    return W.ttt_file(
        W.cuboid_shape(1, -1, "Robot", (0.2, 0.2, 0.2), (0, 0, 0.5), dynamic=False) +
        W.cuboid_shape(2, -1, "Target", (0.2, 0.2, 0.2), (1.0, 0, 0.5), dynamic=False) +
        W.cuboid_shape(3, -1, "Wall", (0.1, 1, 1), (-0.15, 0, 0.5), dynamic=False) +
        W.collection("Arm", [(1, 1, True)], 2_000_000) +
        W.distance_object("Distance", 1, 2, 1) +
        W.distance_object("armDistance", 2_000_000, 2, 2, threshold=0.5) +
        W.collision_object("targetCollision", 1, 2, 1) +
        W.collision_object("wall0", 1, -1, 2) +
        W.collision_object("lost", 1, 99, 3) +
        W.script(100, 1, SCRIPT))


def test_the_converter_declares_them_by_name(tmp_path):
    f = tmp_path / "m.ttt"
    f.write_bytes(_scene())
    xml, report = convert.convert(reader.read(f), tmp_path / "out", "scene")
    texts = {t.name: t.data for t in mujoco.MjSpec.from_file(str(xml)).texts}
    assert texts["simx.distance:Distance"] == "entity1=Robot entity2=Target"
    assert texts["simx.distance:armDistance"] == "entity1=collection:Arm entity2=Target"
    assert texts["simx.collision:targetCollision"] == "entity1=Robot entity2=Target"
    assert texts["simx.collision:wall0"] == "entity1=Robot entity2=all"
    assert "simx.collision:lost" not in texts
    assert report.counts["collision objects whose entities are not in the scene"] == 1
    assert report.counts["distance objects' thresholds (simx measures every distance)"] == 1


def test_scripts_read_them_with_the_3x_calls(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    f = tmp_path / "m.ttt"
    f.write_bytes(_scene())
    sim = Simulation(f, realtime=False)
    try:
        sim.start()
        sim.step()
        get = sim.signals.get
        assert get("float", "distance") == pytest.approx(0.8, abs=1e-5)
        assert get("int", "distance_result") == 1
        assert get("float", "arm_distance") == pytest.approx(0.8, abs=1e-5)
        assert get("int", "collides") == 0
        assert get("int", "all") == 2
        sim.stop()
    finally:
        sim.close()


def test_a_legacy_program_reads_them_on_a_real_server(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    f = tmp_path / "m.ttt"
    f.write_bytes(_scene())
    srv = ServerProcess(str(f), "--pacing", "immediate", renderers="on-demand")
    try:
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        rc, dist = vrep.simxGetDistanceHandle(cid, "Distance#", B)
        assert rc == 0
        rc, d = vrep.simxReadDistance(cid, dist, B)
        assert rc == 0 and d == pytest.approx(0.8, abs=1e-4)  # not 0: no "Success!" at the first step
        rc, target = vrep.simxGetCollisionHandle(cid, "targetCollision", B)
        assert rc == 0
        assert vrep.simxReadCollision(cid, target, B) == (0, False)
        rc, wall = vrep.simxGetCollisionHandle(cid, "wall0", B)
        assert vrep.simxReadCollision(cid, wall, B) == (0, True)  # the wall touches the robot
        # the robot moved onto the target: they collide, the distance is 0
        rc, robot = vrep.simxGetObjectHandle(cid, "Robot", B)
        assert vrep.simxSetObjectPosition(cid, robot, -1, [0.9, 0, 0.5], B) == 0
        assert vrep.simxReadCollision(cid, target, B) == (0, True)
        assert vrep.simxReadDistance(cid, dist, B) == (0, 0.0)
        assert vrep.simxGetDistanceHandle(cid, "Nothing", B)[0] == vrep.simx_return_remote_error_flag
        vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    assert "no distance object 'Nothing' in scene m.ttt" in log, log[-2000:]
